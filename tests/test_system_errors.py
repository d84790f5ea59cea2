"""Sampling of the system errors (Men et al. 2021, Section III assumptions 1-2) and their validation."""

import numpy as np
import pytest

from e2esim.errors import PhysicsInputError
from e2esim.instrument.system_errors import SystemErrorModel
from helpers import Z_ACCEPT


def _check_cov(x, y, expected, n):
    prod = x * np.conj(y)
    assert abs(prod.mean() - expected) < Z_ACCEPT * np.sqrt(np.mean(np.abs(prod) ** 2) / n)


def test_sampled_covariances_match_unequal_variances_and_complex_correlations(rng):
    model = SystemErrorModel(
        crosstalk_level=2e-3, crosstalk_relative=(1.0, 0.5, 2.0, 0.8),
        crosstalk_rho13=0.7 * np.exp(1j), crosstalk_rho24=-0.4j,
        imbalance_level=1e-3, imbalance_relative=(1.0, 3.0), imbalance_rho=0.6 * np.exp(-2j),
    )
    n = 200_000
    s = model.sample(rng, n)
    d, e = s.delta, s.f - 1
    v = model.crosstalk_variance
    for i in range(4):
        _check_cov(d[:, i], d[:, i], v[i], n)
    _check_cov(d[:, 0], d[:, 2], model.crosstalk_cov13, n)
    _check_cov(d[:, 1], d[:, 3], model.crosstalk_cov24, n)
    _check_cov(e[:, 0], e[:, 1], model.imbalance_cov12, n)
    for i, j in [(0, 1), (0, 3), (1, 2), (2, 3)]:  # uncorrelated pairs (assumption 2)
        _check_cov(d[:, i], d[:, j], 0.0, n)
    _check_cov(d[:, 0], e[:, 0], 0.0, n)
    # circular: pseudo-covariance E[d^2] = 0
    _check_cov(d[:, 0], np.conj(d[:, 0]), 0.0, n)
    np.testing.assert_array_equal(s.gain, 1.0)


def test_gain_error_is_lognormal_in_power(rng):
    model = SystemErrorModel(gain_offset_db=0.3, gain_sd_db=0.5)
    g2 = model.sample(rng, 200_000).gain ** 2
    m1, m2 = model.gain_power_moments
    assert abs(g2.mean() - m1) < Z_ACCEPT * g2.std() / np.sqrt(g2.size)
    assert abs(np.mean(g2**2) - m2) < Z_ACCEPT * np.std(g2**2) / np.sqrt(g2.size)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(crosstalk_rho13=1.2), "crosstalk_rho13: correlation coefficient magnitude 1.2 is above 1"),
        (dict(crosstalk_level=-1.0), "must be finite and >= 0"),
        (dict(imbalance_relative=(1.0,)), "2 relative channel-imbalance variances"),
        (dict(gain_sd_db=-0.1), "must be finite and >= 0"),
    ],
)
def test_invalid_statistics_are_rejected(kwargs, message):
    with pytest.raises(PhysicsInputError, match=message):
        SystemErrorModel(**kwargs)


def test_with_levels_keeps_structure():
    model = SystemErrorModel(crosstalk_level=1e-3, crosstalk_rho13=0.5j, imbalance_level=2e-4)
    scaled = model.with_levels(crosstalk=4e-3)
    assert scaled.crosstalk_cov13 == pytest.approx(4 * model.crosstalk_cov13)
    assert scaled.imbalance_level == model.imbalance_level


def test_unit_structure_is_the_unit_level_model_bit_for_bit():
    """``unit_structure`` is computed from the fields (a block asks for thousands); it must be exactly what the
    model at unit levels gives, with the same types."""
    model = SystemErrorModel(crosstalk_level=3e-4, crosstalk_relative=(1.0, 0.3, 2.5, 0.7), crosstalk_rho13=0.4 + 0.2j,
                             crosstalk_rho24=0.1, imbalance_level=5e-3, imbalance_relative=(0.9, 1.7),
                             imbalance_rho=-0.3j, noise_power=1e-2)
    unit = model.with_levels(crosstalk=1.0, imbalance=1.0)
    expected = (np.asarray(unit.crosstalk_variance), unit.crosstalk_cov13, unit.crosstalk_cov24,
                np.asarray(unit.imbalance_variance), unit.imbalance_cov12)
    for got, want in zip(model.unit_structure, expected, strict=True):
        assert type(got) is type(want) and np.array_equal(got, want)
    assert model.unit_structure[1] != 0 and model.unit_structure[4] != 0  # the correlations are in it


@pytest.mark.parametrize("levels", [(2e-3, 1e-3), (0.0, 1e-3)])
def test_draws_are_the_complex_formula_bit_for_bit(levels):
    # The sampler scales the normal draws as reals, in place: the same bits as the complex products
    # a = sqrt(V_a) xi_a, b = (C*/V_a) a + sqrt(V_b - |C|^2/V_a) xi_b with xi = (x + j y)/sqrt(2), the real parts
    # of (a, b) drawn first, then the imaginary parts (one stream for every release's draws).
    model = SystemErrorModel(crosstalk_level=levels[0], crosstalk_relative=(1.0, 0.5, 2.0, 0.8),
                             crosstalk_rho13=0.7 * np.exp(1j), crosstalk_rho24=-0.4j, imbalance_level=levels[1],
                             imbalance_rho=0.6 * np.exp(-2j))
    n, seed = 1000, 11
    rng = np.random.default_rng(seed)
    columns = []
    for var_a, var_b, cov in [(*model.crosstalk_variance[0::2], model.crosstalk_cov13),
                              (*model.crosstalk_variance[1::2], model.crosstalk_cov24),
                              (*model.imbalance_variance, model.imbalance_cov12)]:
        x, y = rng.standard_normal((2, n)), rng.standard_normal((2, n))
        xi = (x + 1j * y) * (1 / np.sqrt(2))
        a = np.sqrt(var_a) * xi[0]
        b = (np.conj(cov) / var_a * a + np.sqrt(max(var_b - abs(cov) ** 2 / var_a, 0.0)) * xi[1] if var_a > 0
             else np.sqrt(var_b) * xi[1])
        columns.append((a, b))
    s = model.sample(np.random.default_rng(seed), n)
    (d1, d3), (d2, d4), (e1, e2) = columns
    assert np.array_equal(s.delta, np.stack([d1, d2, d3, d4], -1))
    assert np.array_equal(s.f, 1 + np.stack([e1, e2], -1))
