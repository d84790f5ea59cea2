"""Power law and relative AGB error (Men et al. 2021, eqs. 15-16 and Section V-B)."""

import numpy as np
import pytest

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.agb_error import AGBError, binomial_interval, standard_normal_quantile
from e2esim.retrieval.power_law import PowerLaw, agb_relative_error, sigma_relative_error
from helpers import Z_ACCEPT


def test_eq16_and_its_inverse():
    q = np.array([-0.2, -0.1, 0.1, 0.2])
    for p in (2.2, 1.9):
        np.testing.assert_allclose(agb_relative_error(sigma_relative_error(q, p), p), q, rtol=1e-12)
    law = PowerLaw(coefficient=5000.0, exponent=2.2)
    sigma = law.sigma(200.0)
    assert law.agb(sigma * (1 + sigma_relative_error(0.2, 2.2))) == pytest.approx(240.0)  # eq. (15)-(16)


def test_standard_normal_quantiles_of_table3():
    # Men et al. (2021), Section V-B / Table III: 95 %, 99 %, 99.865 % -> 1.65, 2.33, 3.00.
    for p, z in [(0.95, 1.645), (0.99, 2.326), (0.99865, 3.000)]:
        assert standard_normal_quantile(p) == pytest.approx(z, abs=5e-4)


def test_non_positive_sigma_estimates_map_to_zero_agb():
    assert agb_relative_error(-1.5, 2.2) == -1.0
    with pytest.raises(PhysicsInputError, match="> -1"):
        sigma_relative_error(-1.0, 2.2)


def test_analytic_and_sampled_agb_error_agree_for_gaussian_errors(rng):
    sigma_hv, mean, sd, p = 0.07, 1e-3, 2e-3, 2.2
    e = mean + sd * rng.standard_normal(400_000)
    agb = AGBError.from_sigma_errors(p, sigma_hv, mean, sd, e / sigma_hv)
    n = e.size
    for prob in (0.00135, 0.5, 0.99865):
        q_an, q_mc = agb.quantile(prob, "analytic"), agb.quantile(prob, "montecarlo")
        # quantile standard error: sqrt(P(1-P)/n) / density; density of q at q_an from the mapping
        dens = np.exp(-0.5 * standard_normal_quantile(prob) ** 2) / np.sqrt(2 * np.pi) / (
            sd / sigma_hv * p * (1 + (mean + standard_normal_quantile(prob) * sd) / sigma_hv) ** (p - 1))
        assert abs(q_mc - q_an) < Z_ACCEPT * np.sqrt(prob * (1 - prob) / n) / dens
    for bound, side in [(0.1, "over"), (0.05, "under")]:
        pa, pm = agb.exceedance(bound, side, "analytic"), agb.exceedance(bound, side, "montecarlo")
        assert abs(pm - pa) < Z_ACCEPT * np.sqrt(pa * (1 - pa) / n)
    q = agb.samples
    assert abs(agb.rmse("montecarlo") ** 2 - agb.rmse("analytic") ** 2) < Z_ACCEPT * np.std(q**2) / np.sqrt(n)
    assert abs(agb.mean("montecarlo") - agb.mean("analytic")) < Z_ACCEPT * q.std() / np.sqrt(n)


def test_exceedance_at_the_quantile_is_one_minus_confidence():
    agb = AGBError.from_sigma_errors(1.9, 0.05, 5e-4, 1e-3)
    q = agb.quantile(0.99, "analytic")
    assert agb.exceedance(float(q), "over", "analytic") == pytest.approx(0.01, rel=1e-9)


def test_binomial_interval_covers_the_proportion():
    lo, hi = binomial_interval(13, 1000)
    assert lo < 0.013 < hi and 0.006 < lo and hi < 0.023
    assert binomial_interval(0, 100)[0] == 0.0


def test_short_hermite_rule_agrees_with_the_64_node_rule_where_it_is_used():
    """The 16-node rule serves cases with sd / (sigma + mean) <= 0.1 (gauss_hermite._SHORT_RULE_LARGEST_SPREAD): there
    its E[q] and E[q^2] match the 64-node rule to 1e-14 relative (or of sqrt(E[q^2]) when E[q] is near zero)."""
    from e2esim.retrieval import gauss_hermite

    sigma = 0.05
    spread = np.linspace(0.0, gauss_hermite._SHORT_RULE_LARGEST_SPREAD, 11)
    mean = sigma * np.array([-0.3, -0.05, 0.0, 0.05, 0.3])[:, None, None]
    p = np.array([0.5, 1.0, 1.9, 2.2, 3.0, 5.0])[:, None]
    sd = spread * (sigma + mean)
    m, ms = gauss_hermite.power_law_q_moments(mean, sd, p, sigma)
    nodes = gauss_hermite.HERMITE_NODES
    x = (mean[..., None] + sd[..., None] * nodes) / sigma
    q = agb_relative_error(x, p[..., None])
    m64, ms64 = gauss_hermite.hermite_average(q), gauss_hermite.hermite_average(q**2)
    scale = np.sqrt(ms64)
    assert np.all(np.abs(m - m64) <= 1e-14 * np.maximum(np.abs(m64), scale))
    assert np.all(np.abs(ms - ms64) <= 1e-14 * ms64)
    wide = gauss_hermite.power_law_q_moments(0.0, 0.2 * sigma, 2.2, sigma)  # beyond: the 64-node rule itself
    x = (0.0 + 0.2 * sigma * nodes) / sigma
    assert wide[1] == gauss_hermite.hermite_average(agb_relative_error(x, 2.2) ** 2)


def test_one_type_for_a_case_and_a_block_of_cases():
    """A block of cases is one AGBError with a leading case axis; a case is a block of one; taking and joining cases
    keeps every case's numbers (issue 27, Build 1)."""
    one = AGBError.from_sigma_errors(2.2, 0.05, 5e-4, 1e-3)
    assert len(one) == 1 and one.item(0) is one and bool(one)
    block = AGBError(np.array([2.2, 1.9, 2.2]), np.array([0.05, 0.04, 0.03]), np.array([5e-4, -2e-4, 1e-3]),
                     np.array([1e-3, 2e-3, 5e-4]))
    assert len(block) == 3
    rmse = block.rmse()
    for i in range(3):
        assert block.item(i).rmse() == rmse[i]  # element-wise: the same number alone and in the block
    joined = AGBError.concatenate([block.take(np.array([2])), block.take(np.array([0, 1]))])
    assert np.array_equal(joined.rmse(), rmse[[2, 0, 1]])
    assert np.array_equal(block.scalar_columns()["analytic.rmse_percent"], 100 * rmse)
