"""Parametric bootstrap, Ahmed et al. (2014), eqs. (11)-(16): measurement-error-corrected confidence bands
cover the true curve at the nominal rate (binomial tests over many synthetic data sets with known
truth, any seed); the printed eq. (12) does not; failures are counted; bad input."""

import numpy as np
import pytest
from scipy import stats

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.bootstrap import parametric_bootstrap
from e2esim.retrieval.regression import ModelErrorEstimate
from e2esim.retrieval.saturating import SaturatingModel
from e2esim.retrieval.simex import simex
from e2esim.retrieval.synthetic import synthetic_field_plots

SAT = SaturatingModel(0.055, 0.015, 0.008)
# 60 plots between 5 and 150 t/ha, 15 % allometric and 2 % backscatter error, small error in equation:
# measurement error dominates, the naive fit is clearly biased (test_retrieval_simex.py).
DESIGN = dict(allometric_error=0.15, backscatter_error=0.02, model_error_sd=0.0005,
              agb_range_t_ha=(5, 150))
P_MIN = 1e-4  # two-sided binomial p-value below which the coverage is inconsistent with 95 %


MAX_REFUSED = 0.02
"""Share of data sets whose SIMEX correction the data do not support (it leaves the model's domain or the naive
fit's confidence region, ``simex.supported_by_data``: refused, as a simulated campaign that fails is left out of
the regression term); above it the coverage would describe a selected minority."""


def _coverage(rng, n_sets, design, agb=50.0, n_sim=50, n_boot=200, refit="naive"):
    """(hits, data sets used): the band covers the truth in ``hits`` of the data sets SIMEX accepts."""
    truth = SAT.sigma(agb)
    hits = refused = 0
    for _ in range(n_sets):
        fp = synthetic_field_plots(SAT, 60, rng, **DESIGN)
        try:
            sx = simex(SAT, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd, rng, n_sim=n_sim)
        except PhysicsInputError:
            refused += 1
            continue
        boot = parametric_bootstrap(sx.model, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd, rng,
                                    n_boot=n_boot, design=design, refit=refit)
        band = boot.band(np.array([agb]))
        hits += band.conf_lower[0] <= truth <= band.conf_upper[0]
    assert refused <= MAX_REFUSED * n_sets, (refused, n_sets)
    return hits, n_sets - refused


def test_bootstrap_confidence_band_covers_truth_at_nominal_rate(rng):
    """SIMEX centre, conditional bootstrap, eqs. (3)-(4) with the bootstrap covariance: 95 % band at
    50 t/ha over 60 data sets, binomial test (a simulation of 800 data sets gives 95.0 %; the printed
    design's 45 % fails such a test by far, see below; 200 data sets in the slow test)."""
    hits, used = _coverage(rng, 60, "conditional")
    assert stats.binomtest(hits, used, 0.95).pvalue > P_MIN, hits


@pytest.mark.slow
def test_bootstrap_coverage_at_50_t_ha_with_more_data_sets(rng):
    hits, used = _coverage(rng, 200, "conditional")
    assert stats.binomtest(hits, used, 0.95).pvalue > P_MIN, hits


@pytest.mark.slow
@pytest.mark.parametrize("agb", [25.0, 100.0])
def test_bootstrap_coverage_other_agb_levels(rng, agb):
    hits, used = _coverage(rng, 400, "conditional", agb=agb)
    assert stats.binomtest(hits, used, 0.95).pvalue > P_MIN, hits


def test_printed_eq_12_undercovers(rng):
    """Eq. (12) as printed generates the response at the perturbed predictor W_b, so the bootstrap data
    carry no predictor error: the band is far too narrow (about 45 % coverage at 50 t/ha)."""
    hits, used = _coverage(rng, 60, "paper", n_sim=20, n_boot=100)
    assert stats.binomtest(hits, used, 0.95, alternative="less").pvalue < P_MIN, hits


def test_bootstrap_result_and_reproducibility():
    fp = synthetic_field_plots(SAT, 40, np.random.default_rng(3), **DESIGN)
    run = lambda seed: parametric_bootstrap(SAT, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd,
                                            np.random.default_rng(seed), n_boot=120, chunk=50)
    a, b = run(1), run(1)
    np.testing.assert_array_equal(a.samples, b.samples)
    assert a.n_boot == 120 and a.samples.shape == (120, 3)
    assert a.n_failed == a.n_boot - a.converged_samples.shape[0]
    np.testing.assert_allclose(a.covariance, np.cov(a.converged_samples, rowvar=False))
    assert a.model_error.denominator == 40 - 3
    lo, hi = a.coefficient_intervals(method="normal")
    np.testing.assert_allclose((lo + hi) / 2, SAT.params)
    lo, hi = a.coefficient_intervals(method="percentile")
    assert np.all(lo < hi)
    band = a.band(np.linspace(0, 300, 31))
    assert np.all(band.pred_upper >= band.conf_upper)
    pct = a.band(np.linspace(0, 300, 31), method="percentile")
    assert np.all(pct.conf_upper >= pct.conf_lower)
    spread = a.curve_spread(np.array([50.0]))
    assert 0 < spread[0] < 1


def test_bootstrap_with_simex_refits_and_given_model_error():
    fp = synthetic_field_plots(SAT, 40, np.random.default_rng(4), **DESIGN)
    r = parametric_bootstrap(SAT, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd, np.random.default_rng(5),
                             n_boot=20, refit="simex", model_error=0.0005**2, simex_options={"n_sim": 10})
    assert r.refit == "simex" and r.model_error.variance == pytest.approx(0.0005**2)
    assert r.n_failed == sum(r.failure_modes.values())


def test_bootstrap_counts_failed_refits():
    """Backscatter error comparable to the dynamic range (the paper's subplots): some refits fail; they
    are counted by mode and left out of the covariance."""
    fp = synthetic_field_plots(SAT, 40, np.random.default_rng(6), allometric_error=0.1,
                               backscatter_error=0.4, model_error_sd=0.005, agb_range_t_ha=(5, 350))
    r = parametric_bootstrap(SAT, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd, np.random.default_rng(7),
                             n_boot=300)
    assert r.n_failed > 0
    assert r.n_failed == sum(r.failure_modes.values())
    assert r.failure_fraction == pytest.approx(r.n_failed / 300)
    np.testing.assert_allclose(r.covariance, np.cov(r.samples[r.status], rowvar=False))


@pytest.mark.parametrize("kwargs, message", [
    ({"design": "two-stage"}, "design must be one of"),
    ({"refit": "jackknife"}, "refit must be one of"),
    ({"n_boot": 1}, "n_boot must be an integer >= 2"),
    ({"model_error": -1.0}, "model_error variance must be >= 0"),
])
def test_bootstrap_bad_input_messages(rng, kwargs, message):
    agb = np.linspace(5, 300, 20)
    with pytest.raises(PhysicsInputError, match=message):
        parametric_bootstrap(SAT, agb, SAT.sigma(agb), 1.0, 0.001, rng, **kwargs)


def test_bootstrap_rejects_multichannel_data_and_negative_errors(rng):
    agb = np.linspace(5, 300, 20)
    with pytest.raises(PhysicsInputError, match="single-channel data"):
        parametric_bootstrap(SAT, agb, np.ones((20, 3)), 1.0, 0.001, rng)
    with pytest.raises(PhysicsInputError, match="finite and >= 0"):
        parametric_bootstrap(SAT, agb, SAT.sigma(agb), -1.0, 0.001, rng)


def test_given_model_error_estimate_is_used(rng):
    agb = np.linspace(5, 300, 20)
    me = ModelErrorEstimate(1e-6, 1e-6, 2e-6, 5e-7, 5e-7, False, 17)
    r = parametric_bootstrap(SAT, agb, SAT.sigma(agb), 1.0, 0.001, rng, n_boot=20,
                             model_error=me)
    assert r.model_error is me
