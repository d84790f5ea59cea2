"""Non-linear regression uncertainty, Ahmed et al. (2014), eqs. (2)-(7) and (14): delta-method bands,
their coverage, their numerical inversion to AGB intervals (unbounded where the model saturates), and
the model-error estimate of eq. (14)."""

import math

import numpy as np
import pytest
from scipy import stats

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.power_law import PowerLaw
from e2esim.retrieval.regression import (
    ABOVE_BAND,
    BELOW_BAND,
    BOUNDED,
    UNBOUNDED_ABOVE,
    Band,
    band_from_fit,
    critical_value,
    delta_method_band,
    invert_band,
    model_error_variance,
)
from e2esim.retrieval.saturating import SaturatingModel
from e2esim.retrieval.synthetic import synthetic_field_plots

SAT = SaturatingModel(0.055, 0.015, 0.008)


def test_critical_values():
    assert critical_value(0.95) == pytest.approx(1.959964, abs=1e-6)  # "t_{alpha/2} = 1.96", eq. (3)
    assert critical_value(0.95, "t", 10) == pytest.approx(2.228139, abs=1e-6)
    with pytest.raises(PhysicsInputError, match=r"confidence level must be in \(0, 1\), got 95"):
        critical_value(95)
    with pytest.raises(PhysicsInputError, match="needs dof >= 1"):
        critical_value(0.95, "t")
    with pytest.raises(PhysicsInputError, match="kind must be one of"):
        critical_value(0.95, "student")


def test_delta_band_eqs_3_4_7_hand_value():
    cov = np.diag([1e-6, 4e-6, 9e-6])
    band = delta_method_band(SAT, cov, np.array([100.0]), residual_variance=4e-6)
    f = SAT.param_jacobian(np.array([100.0]))[0]
    s2 = float(f @ cov @ f)  # eq. (4)
    fit = float(SAT.sigma(100.0))
    assert band.se_fit[0] == pytest.approx(math.sqrt(s2))
    assert band.conf_upper[0] == pytest.approx(fit + 1.959964 * math.sqrt(s2), rel=1e-6)  # eq. (3)
    assert band.pred_lower[0] == pytest.approx(fit - 1.959964 * math.sqrt(s2 + 4e-6), rel=1e-6)  # eq. (7)
    with pytest.raises(PhysicsInputError, match="covariance must be 3x3"):
        delta_method_band(SAT, np.eye(2), np.array([1.0]))
    with pytest.raises(PhysicsInputError, match="model-error variance must be >= 0"):
        delta_method_band(SAT, cov, np.array([1.0]), residual_variance=-1.0)


def test_log_space_band_is_asymmetric_in_sigma():
    pl = PowerLaw.through(200.0, 0.0726, 2.2)
    agb = np.exp(np.linspace(np.log(20), np.log(400), 30))
    rng = np.random.default_rng(0)
    fit = pl.fit(agb, pl.sigma(agb) * np.exp(0.2 * rng.standard_normal(30)))
    band = band_from_fit(fit, np.array([100.0]))
    up, down = band.conf_upper[0] - band.fit[0], band.fit[0] - band.conf_lower[0]
    assert up > down > 0
    assert math.log(band.conf_upper[0] / band.fit[0]) == pytest.approx(1.959964 * band.se_fit[0], rel=1e-6)


def test_naive_confidence_band_coverage_and_eq_6_needs_the_residual_variance(rng):
    """Without measurement error, the eq. (3) band at M = 100 t/ha covers the true curve at the nominal
    rate (binomial test over 300 data sets, Student t critical value). The printed eq. (6),
    (J^T J)^-1 without sigma_hat^2, gives a band wider by 1/sigma_hat: it always covers (errata)."""
    hits = printed = 0
    n_sets, m = 300, np.array([100.0])
    truth = SAT.sigma(100.0)
    for _ in range(n_sets):
        fp = synthetic_field_plots(SAT, 40, rng, agb_range_t_ha=(5, 300), allometric_error=0.0,
                                   backscatter_error=0.0, model_error_sd=0.003)
        fit = SAT.fit(fp.agb, fp.sigma)
        assert fit.converged
        band = band_from_fit(fit, m, critical="t")
        hits += band.conf_lower[0] <= truth <= band.conf_upper[0]
        wide = band_from_fit(fit, m, covariance=fit.covariance / fit.residual_variance, critical="t")
        printed += wide.conf_lower[0] <= truth <= wide.conf_upper[0]
    assert stats.binomtest(hits, n_sets, 0.95).pvalue > 1e-4, hits
    assert printed == n_sets


def _band(lo, hi, agb):
    agb = np.asarray(agb, float)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    mid = 0.5 * (lo + hi)
    return Band(agb, mid, mid * 0, 0.0, lo, hi, lo, hi, 0.95, 1.96, "linear", SAT)


def test_invert_band_hand_cases():
    agb = np.array([0.0, 10.0, 20.0, 30.0, 40.0])
    lo = np.array([0.00, 0.01, 0.02, 0.03, 0.035])
    hi = np.array([0.01, 0.02, 0.03, 0.04, 0.045])
    iv = invert_band(_band(lo, hi, agb), [0.025, 0.0395, 0.05, -0.01])
    # 0.025: upper band crosses at 15 (0.02 -> 0.03), lower band at 25
    assert iv.lower[0] == pytest.approx(15.0) and iv.upper[0] == pytest.approx(25.0)
    assert iv.status[0] == BOUNDED
    # 0.0395: the lower band is still below it at the last AGB: unbounded above
    assert iv.status[1] == UNBOUNDED_ABOVE and np.isposinf(iv.upper[1])
    assert iv.lower[1] == pytest.approx(29.5)
    assert iv.status[2] == ABOVE_BAND and iv.status[3] == BELOW_BAND
    assert iv.counts() == {"bounded": 1, "unbounded_above": 1, "above_band": 1, "below_band": 1}
    with pytest.raises(PhysicsInputError, match="must be finite"):
        invert_band(_band(lo, hi, agb), [np.nan])


def test_inverted_intervals_become_unbounded_with_saturation():
    """Figs. 13 and 20: the inverted confidence interval is bounded at low AGB and unbounded where the
    lower band flattens below the observation."""
    rng = np.random.default_rng(5)
    fp = synthetic_field_plots(SAT, 40, rng, agb_range_t_ha=(5, 350), allometric_error=0.0,
                               backscatter_error=0.0, model_error_sd=0.004)
    fit = SAT.fit(fp.agb, fp.sigma)
    band = band_from_fit(fit, np.linspace(0, 600, 1201))
    iv = invert_band(band, fit.model.sigma(np.array([20.0, 50.0, 300.0])))
    assert iv.status[0] == BOUNDED and iv.lower[0] < 20 < iv.upper[0]
    assert iv.status[-1] == UNBOUNDED_ABOVE
    np.testing.assert_allclose(iv.estimate, [20.0, 50.0, 300.0], rtol=1e-8)
    pred = invert_band(band, fit.model.sigma(np.array([20.0])), which="prediction")
    assert pred.width[0] > iv.width[0]


def test_model_error_eq_14_is_unbiased(rng):
    """Eq. (14) subtracts the measurement errors from the residual scatter. (a) No predictor error, fitted
    coefficients, denominator n - p: E[sigma_hat^2] = sigma^2; (b) with a 10 % allometric error and the
    true coefficients (n degrees of freedom): the F_X^2 sigma_u^2 term removes the predictor error to first
    order. z tests over 300 data sets; the printed n - k denominator is (n - p)/(n - 1) times smaller."""
    sigma_eps, n = 0.002, 20
    a, b = [], []
    for _ in range(300):
        fp = synthetic_field_plots(SAT, n, rng, agb_range_t_ha=(5, 300), allometric_error=0.0,
                                   backscatter_error=0.05, model_error_sd=sigma_eps)
        fit = SAT.fit(fp.agb, fp.sigma)
        me = model_error_variance(fit.model, fp.agb, fp.sigma, fp.sigma_error_sd, 0.0)
        a.append(me.raw)
        nk = model_error_variance(fit.model, fp.agb, fp.sigma, fp.sigma_error_sd, 0.0, denominator="n-k")
        assert nk.residual_mean_square == pytest.approx(me.residual_mean_square * (n - 3) / (n - 1))
        fp = synthetic_field_plots(SAT, n, rng, agb_range_t_ha=(20, 300), allometric_error=0.1,
                                   backscatter_error=0.05, model_error_sd=sigma_eps)
        me = model_error_variance(SAT, fp.agb, fp.sigma, fp.sigma_error_sd, fp.agb_error_sd)
        b.append(me.residual_mean_square * (n - 3) / n - me.response_error - me.predictor_error)
    for est in (np.array(a), np.array(b)):
        z = (est.mean() - sigma_eps**2) / (est.std(ddof=1) / math.sqrt(est.size))
        assert abs(z) < 5, z


def test_model_error_clipping_and_bad_input():
    agb = np.linspace(10, 300, 10)
    me = model_error_variance(SAT, agb, SAT.sigma(agb), 0.01, 1.0)
    assert me.clipped and me.variance == 0.0 and me.raw < 0
    with pytest.raises(PhysicsInputError, match="denominator must be one of"):
        model_error_variance(SAT, agb, SAT.sigma(agb), 0.0, 0.0, denominator="n")
    with pytest.raises(PhysicsInputError, match="needs more plots than coefficients"):
        model_error_variance(SAT, agb[:3], SAT.sigma(agb[:3]), 0.0, 0.0)
