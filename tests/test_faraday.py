"""Faraday-rotation distributions: moments (Men et al. 2021, eqs. 9-10) and exact averaging."""

import numpy as np
import pytest

from e2esim.errors import PhysicsInputError
from e2esim.faraday.distribution import ConstantFaraday, EmpiricalFaraday, GaussianFaraday
from helpers import Z_ACCEPT


def test_eq10_moments_against_sampling(rng):
    fr = GaussianFaraday(np.pi / 3, np.pi / 36)
    n = 200_000
    om = fr.sample(rng, n)
    for p in (2, 4):
        expected = np.cos(p * fr.mean) * np.exp(-(fr.sd * p) ** 2 / 2)  # eq. (10)
        x = np.cos(p * om)
        assert abs(x.mean() - expected) < Z_ACCEPT * x.std() / np.sqrt(n)
        assert fr.circular_moment(p).real == pytest.approx(expected)


def test_eq9_trig_moments_match_direct_averages():
    fr = GaussianFaraday(0.7, 0.4)
    nodes = np.linspace(-6, 6, 200001)  # Gaussian integral by quadrature on a fine grid
    w = np.exp(-((nodes - fr.mean) ** 2) / (2 * fr.sd**2))
    w /= w.sum()
    c, s = np.cos(nodes), np.sin(nodes)
    t = fr.trig_moments()
    assert t["c4"] == pytest.approx(np.dot(w, c**4), abs=1e-10)
    assert t["s4"] == pytest.approx(np.dot(w, s**4), abs=1e-10)
    assert t["c2s2"] == pytest.approx(np.dot(w, c**2 * s**2), abs=1e-10)
    assert t["cs"] == pytest.approx(np.dot(w, c * s), abs=1e-10)


@pytest.mark.parametrize("fr", [GaussianFaraday(1.0, 0.6), ConstantFaraday(-0.3),
                                EmpiricalFaraday(np.array([0.1, 0.5, 2.0]), np.array([1.0, 2.0, 1.0]))])
def test_quadrature_is_exact_for_trig_polynomials_up_to_degree_8(fr):
    nodes, weights = fr.quadrature(8)
    for m in range(0, 9):
        for fn in (np.cos, np.sin):
            exact = (fr.circular_moment(m).real if fn is np.cos else fr.circular_moment(m).imag)
            assert np.dot(weights, fn(m * nodes)) == pytest.approx(float(exact), abs=1e-13)
    # and so for a product of eight trigonometric factors (the variance terms)
    c, s = np.cos(nodes), np.sin(nodes)
    h = (c * s) ** 2 * c**3 * s  # degree 8
    grid = np.linspace(0, 2 * np.pi, 4001)[:-1]
    coeffs = np.fft.rfft((np.cos(grid) * np.sin(grid)) ** 2 * np.cos(grid) ** 3 * np.sin(grid)) / grid.size
    exact = coeffs[0].real + sum(2 * (coeffs[k] * fr.circular_moment(k)).real for k in range(1, 9))
    assert np.dot(weights, h) == pytest.approx(float(exact), abs=1e-13)


def test_empirical_distribution_moments_and_sampling(rng):
    samples = np.array([0.0, 0.5, 1.0])
    fr = EmpiricalFaraday(samples, np.array([1.0, 1.0, 2.0]))
    assert fr.mean_rad == pytest.approx(0.625)
    assert fr.circular_moment(2) == pytest.approx(np.dot([0.25, 0.25, 0.5], np.exp(2j * samples)))
    draws = fr.sample(rng, 100_000)
    assert set(np.unique(draws)) <= set(samples)
    p = np.mean(draws == 1.0)
    assert abs(p - 0.5) < Z_ACCEPT * np.sqrt(0.25 / 100_000)


def test_bad_distributions_are_rejected():
    with pytest.raises(PhysicsInputError, match="SD >= 0"):
        GaussianFaraday(0.0, -1.0)
    with pytest.raises(PhysicsInputError, match="at least one finite sample"):
        EmpiricalFaraday(np.array([]))
    with pytest.raises(PhysicsInputError, match="weights"):
        EmpiricalFaraday(np.array([0.1, 0.2]), np.array([1.0, -1.0]))
