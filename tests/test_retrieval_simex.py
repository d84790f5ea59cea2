"""SIMEX, Ahmed et al. (2014), eqs. (17)-(19): on synthetic plots with known truth it removes the
coefficient bias that measurement error causes (statistical tests over many data sets, any seed), counts
non-converging fits, and checks its input."""

import numpy as np
import pytest

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.power_law import PowerLaw
from e2esim.retrieval.saturating import SaturatingModel
from e2esim.retrieval.simex import SIMEX_OK, simex, simex_batch
from e2esim.retrieval.synthetic import synthetic_field_plots

SAT = SaturatingModel(0.055, 0.015, 0.008)
PL = PowerLaw.through(200.0, 0.0726, 2.2)
Z = 4.0  # one-sided z for "significantly": false-failure rate 3e-5 per comparison


def _bias_reduced(true, naive, corrected, which):
    """Assert |mean(corrected) - truth| < |mean(naive) - truth| for coefficients ``which``, by two paired
    z tests: both (e_n - e_c) and (e_n + e_c) have the sign of the naive bias (|b_c| < |b_n| exactly when
    both do), and the naive bias itself is significant."""
    en, ec = naive - true.params, corrected - true.params
    n = en.shape[0]
    for j in which:
        sign = np.sign(en[:, j].mean())
        z_naive = abs(en[:, j].mean()) / (en[:, j].std(ddof=1) / np.sqrt(n))
        t1 = sign * (en[:, j] - ec[:, j]).mean() / ((en[:, j] - ec[:, j]).std(ddof=1) / np.sqrt(n))
        t2 = sign * (en[:, j] + ec[:, j]).mean() / ((en[:, j] + ec[:, j]).std(ddof=1) / np.sqrt(n))
        assert z_naive > Z and t1 > Z and t2 > Z, (true.param_names[j], z_naive, t1, t2)


def test_simex_removes_power_law_attenuation(rng):
    """Classical attenuation: 15 % allometric error flattens the log-log slope (the exponent p comes out
    too large, z ~ 16 over 300 data sets); SIMEX removes the bias of both coefficients."""
    fp = synthetic_field_plots(PL, 40, rng, n_datasets=300, allometric_error=0.15, backscatter_error=0.05,
                               agb_distribution="loguniform", agb_range_t_ha=(20, 400))
    sb = simex_batch(PL, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd, rng, n_sim=40)
    assert sb.ok.mean() > 0.95, sb.status_counts()
    _bias_reduced(PL, sb.naive[sb.ok], sb.params[sb.ok], which=(0, 1))


def test_simex_reduces_saturating_model_bias_fast(rng):
    """Eq. (1) with 15 % allometric and 2 % backscatter error, 60 plots, 200 data sets: the naive beta0 and
    beta1 are biased (about -3 % and +17 %); SIMEX (quadratic extrapolant) reduces both biases."""
    fp = synthetic_field_plots(SAT, 60, rng, n_datasets=200, allometric_error=0.15, backscatter_error=0.02,
                               model_error_sd=0.0005, agb_range_t_ha=(5, 150))
    sb = simex_batch(SAT, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd, rng, n_sim=50)
    assert sb.ok.mean() > 0.95, sb.status_counts()
    _bias_reduced(SAT, sb.naive[sb.ok], sb.params[sb.ok], which=(0, 1))


@pytest.mark.slow
def test_simex_reduces_saturating_model_bias_all_coefficients(rng):
    fp = synthetic_field_plots(SAT, 60, rng, n_datasets=1000, allometric_error=0.15, backscatter_error=0.02,
                               model_error_sd=0.0005, agb_range_t_ha=(5, 150))
    sb = simex_batch(SAT, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd, rng, n_sim=50)
    assert sb.ok.mean() > 0.95, sb.status_counts()
    _bias_reduced(SAT, sb.naive[sb.ok], sb.params[sb.ok], which=(0, 1, 2))


def test_simex_single_dataset_result_and_reproducibility():
    fp = synthetic_field_plots(SAT, 40, np.random.default_rng(1), allometric_error=0.1,
                               backscatter_error=0.05, model_error_sd=0.002)
    run = lambda seed: simex(SAT, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd,
                             np.random.default_rng(seed), n_sim=30)
    a, b, c = run(7), run(7), run(8)
    np.testing.assert_array_equal(a.params, b.params)
    assert not np.array_equal(a.params, c.params)
    assert a.lambdas.tolist() == [0.0, 0.5, 1.0, 1.5, 2.0]
    np.testing.assert_allclose(a.params_by_lambda[0], a.naive.params)
    np.testing.assert_allclose(a.extrapolate(-1.0), a.params)  # the model's coefficients are its working ones
    assert a.extrapolant == "quadratic" and not a.fallback
    assert a.attempts.tolist() == [30] * 4
    assert a.failures.sum() == sum(a.failure_modes.values())
    assert a.reliable == (a.failure_fraction <= 0.2)


def test_simex_without_measurement_error_returns_the_naive_fit(rng):
    agb = np.linspace(5, 300, 30)
    sigma = SAT.sigma(agb) + 0.002 * np.random.default_rng(2).standard_normal(30)
    r = simex(SAT, agb, sigma, 0.0, 0.0, rng, n_sim=5)
    np.testing.assert_allclose(r.params, r.naive.params, rtol=1e-6)  # refits agree to the solver tolerance
    sb = simex_batch(SAT, agb[None], sigma[None], 0.0, 0.0, rng, n_sim=5)
    assert sb.status[0] == SIMEX_OK
    np.testing.assert_allclose(sb.params[0], r.naive.params, rtol=1e-6)  # both converged to ftol


def test_simex_counts_failures_and_flags_unreliable_results():
    """Subplot-like data (measurement error comparable to the dynamic range, Section III-D): many of the
    simulated fits fail; they are counted by mode and the result is flagged, not silently averaged."""
    rng = np.random.default_rng(4)
    fp = synthetic_field_plots(SAT, 40, rng, allometric_error=0.1, backscatter_error=0.3,
                               model_error_sd=0.004, agb_range_t_ha=(5, 350))
    r = simex(SAT, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd, rng, n_sim=50, max_failure_fraction=0.01)
    assert r.failure_fraction > 0.1  # a large share of the simulated fits fail on such data
    assert r.failures.sum() > 0
    assert r.failures.sum() == sum(r.failure_modes.values())
    assert not r.reliable
    assert r.summary()["failure_fraction"] == r.failure_fraction


class _DriftingModel(SaturatingModel):
    """A stub whose "fit" returns beta1(lambda) = 0.01 + 0.02 lambda - 0.005 lambda^2, lambda read off the
    added predictor error: concave, so the quadratic extrapolant gives beta1(-1) = -0.015 (outside the
    domain) while the linear one gives +0.0025. Its curve is the flat data whatever the coefficients, so every
    extrapolation is supported by the data (``supported_by_data``) and only the domain decides."""

    def evaluate(self, agb, params=None, **covariates):
        return 0.05 + 0.0 * super().evaluate(agb, params, **covariates)

    def fit_batch(self, agb, sigma, p0=None, space=None, weights=None, **covariates):
        from e2esim.retrieval.models import BatchFit

        agb = np.atleast_2d(agb)
        lam = np.mean((agb - _DriftingModel.base) ** 2, axis=-1) / _DriftingModel.sd**2
        b1 = 0.01 + 0.02 * lam - _DriftingModel.curvature * lam**2
        params = np.stack([np.full_like(b1, 0.05), b1, np.full_like(b1, 0.01)], axis=-1)
        status = np.zeros(b1.shape, dtype=np.int8) if _DriftingModel.converge else np.ones(b1.shape, dtype=np.int8)
        return BatchFit(params, status, np.zeros(b1.shape), np.ones(b1.shape, dtype=np.int32))


def test_simex_quadratic_falls_back_to_linear_when_it_leaves_the_domain(rng):
    agb = np.linspace(50, 300, 20_000)
    _DriftingModel.base, _DriftingModel.sd, _DriftingModel.converge = agb, 1.0, True
    _DriftingModel.curvature = 0.005
    model = _DriftingModel(0.05, 0.01, 0.01)
    r = simex(model, agb, np.full(agb.size, 0.05), 1.0, 0.0, rng, n_sim=4)
    assert r.fallback and r.extrapolant == "linear"
    assert r.params[1] == pytest.approx(0.0025, abs=2e-4)
    _DriftingModel.curvature = 0.0  # straight drift: both extrapolants reach beta1(-1) = -0.01
    with pytest.raises(PhysicsInputError, match="left the model's domain"):
        simex(model, agb, np.full(agb.size, 0.05), 1.0, 0.0, rng, n_sim=4)


def test_simex_needs_a_converged_naive_fit(rng):
    agb = np.linspace(50, 300, 100)
    _DriftingModel.base, _DriftingModel.sd, _DriftingModel.converge = agb, 1.0, False
    _DriftingModel.curvature = 0.0
    with pytest.raises(PhysicsInputError, match=r"naive fit did not converge \(max_iterations\)"):
        simex(_DriftingModel(0.05, 0.01, 0.01), agb, np.full(100, 0.05), 1.0, 0.0, rng)


@pytest.mark.parametrize("kwargs, message", [
    ({"lambdas": (1.0, 0.5)}, "positive and increasing"),
    ({"lambdas": (0.0, 1.0)}, "positive and increasing"),
    ({"lambdas": (1.0,)}, "needs at least 2 lambdas"),
    ({"n_sim": 1}, "n_sim must be an integer >= 2"),
    ({"extrapolant": "rational"}, "extrapolant must be one of"),
    ({"agb_error_sd": np.ones(3)}, r"agb_error_sd of shape \(3,\) does not match"),
    ({"sigma_error_sd": -1.0}, "sigma_error_sd must be finite and >= 0"),
])
def test_simex_bad_input_messages(rng, kwargs, message):
    agb = np.linspace(5, 300, 20)
    args = dict(agb_error_sd=1.0, sigma_error_sd=0.001)
    args.update({k: v for k, v in kwargs.items() if k in args})
    rest = {k: v for k, v in kwargs.items() if k not in args}
    with pytest.raises(PhysicsInputError, match=message):
        simex(SAT, agb, SAT.sigma(agb), args["agb_error_sd"], args["sigma_error_sd"], rng, **rest)


