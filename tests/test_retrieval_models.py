"""Retrieval models behind one interface: power law (Men et al. 2021, eq. 15), saturating model (Ahmed et
al. 2014, eq. 1) and the multi-channel log-linear model; forward, derivatives, inversion with explicit
saturation, fits, non-convergence counting, and bad input."""

import math

import numpy as np
import pytest
from scipy import optimize, stats

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.fitting import bisect_increasing
from e2esim.retrieval.loglinear import LogLinearModel
from e2esim.retrieval.models import (
    BAD_DATA,
    BELOW_RANGE,
    CONVERGED,
    INVALID,
    INVERTED,
    MAX_ITERATIONS,
    OUT_OF_DOMAIN,
    SATURATED,
    levenberg_marquardt,
)
from e2esim.retrieval.power_law import PowerLaw, agb_relative_error, sigma_relative_error
from e2esim.retrieval.saturating import SaturatingModel

SAT = SaturatingModel(0.055, 0.015, 0.008)
PL = PowerLaw.through(200.0, 0.0726, 2.2)  # Men et al. (2021), Table I boreal 200 t/ha
LL = LogLinearModel.from_linear([0.02, 0.004, 0.015], [0.35, 0.5, 0.25], [1.0, 1.5, 2.0],
                                residual_covariance=[[0.04, 0.02, 0.01], [0.02, 0.04, 0.01], [0.01, 0.01, 0.05]])


def _fd_jacobian(model, agb, h=1e-7, **cov):
    p = model.params
    out = []
    for k in range(p.size):
        dp = np.zeros(p.size)
        dp[k] = h * max(abs(p[k]), 1e-3)
        out.append((model.evaluate(agb, p + dp, **cov) - model.evaluate(agb, p - dp, **cov)) / (2 * dp[k]))
    return np.stack(out, axis=-1)


# power law --------------------------------------------------------------------------------------------------
def test_power_law_keeps_its_historical_api():
    assert PL.sigma(200.0) == pytest.approx(0.0726)
    assert PL.agb(0.0726) == pytest.approx(200.0)
    assert PL.agb(-0.1) == 0.0
    assert PL.params.tolist() == [PL.coefficient, 2.2]
    with pytest.raises(PhysicsInputError, match="coefficient > 0 and exponent > 0"):
        PowerLaw(1.0, -2.0)


def test_power_law_inversion_statuses():
    inv = PL.invert([0.0726, 0.0, -0.01, np.nan, 0.5], agb_max=1000.0)
    assert inv.status.tolist() == [INVERTED, BELOW_RANGE, BELOW_RANGE, INVALID, SATURATED]
    assert inv.agb[0] == pytest.approx(200.0)
    assert inv.agb[1] == 0.0 and inv.agb[4] == 1000.0
    assert inv.counts() == {"inverted": 1, "below_range": 2, "saturated": 1, "invalid": 1}
    assert inv.sigma_max == pytest.approx(PL.sigma(1000.0))


def test_power_law_relative_errors_eq_16():
    x = np.array([-0.2, 0.0864, 0.1])
    q, _ = PL.relative_agb_error(200.0, x)
    np.testing.assert_allclose(q, (1 + x) ** 2.2 - 1)
    np.testing.assert_allclose(q, agb_relative_error(x, 2.2))
    assert sigma_relative_error(0.2, 2.2) == pytest.approx(0.0864, abs=5e-5)  # Men et al. (2021), Table III
    q_cap, inv = PL.relative_agb_error(200.0, np.array([1.0]), agb_max=500.0)
    assert q_cap[0] == pytest.approx(1.5) and inv.status[0] == SATURATED


def test_power_law_derivatives_and_jacobian():
    agb = np.array([10.0, 100.0, 400.0])
    np.testing.assert_allclose(PL.param_jacobian(agb), _fd_jacobian(PL, agb), rtol=1e-6)
    np.testing.assert_allclose(PL.derivative(agb), PL.sigma(agb) / (2.2 * agb))
    np.testing.assert_allclose(PL.sensitivity(agb), 1 / 2.2)


def test_power_law_log_fit_exact_and_linear_fit():
    agb = np.linspace(20, 400, 25)
    fit = PL.fit(agb, PL.sigma(agb))
    assert fit.converged and fit.space == "log"
    np.testing.assert_allclose(fit.params, PL.params, rtol=1e-10)
    lin = PL.fit(agb, PL.sigma(agb), space="linear", p0=[PL.coefficient * 1.5, 2.0])
    assert lin.converged
    np.testing.assert_allclose(lin.params, PL.params, rtol=1e-6)


def test_power_law_log_fit_covariance_is_exact_ols_theory(rng):
    """Log-space OLS with Gaussian ln-residuals: the +-t SE interval of the exponent covers the truth 95 % of
    the time (binomial test over 400 data sets)."""
    n_sets, n, hits = 400, 15, 0
    agb = np.exp(rng.uniform(np.log(20), np.log(400), n))
    t = stats.t.ppf(0.975, n - 2)
    for _ in range(n_sets):
        fit = PL.fit(agb, PL.sigma(agb) * np.exp(0.2 * rng.standard_normal(n)))
        hits += abs(fit.params[1] - 2.2) <= t * fit.standard_errors[1]
    assert stats.binomtest(hits, n_sets, 0.95).pvalue > 1e-4, hits


# saturating model -------------------------------------------------------------------------------------------
def test_saturating_eq_1_hand_value():
    e = math.exp(-1.5)
    assert SAT.sigma(100.0) == pytest.approx(0.055 * (1 - e) + 0.008 * 100**0.2 * e, rel=1e-14)  # 0.0472116
    assert SAT.sigma(0.0) == 0.0
    assert SAT.sigma(1e5) == pytest.approx(0.055, rel=1e-12)


def test_saturating_derivatives_and_jacobian():
    agb = np.array([1.0, 10.0, 50.0, 150.0, 400.0])
    np.testing.assert_allclose(SAT.param_jacobian(agb), _fd_jacobian(SAT, agb), rtol=1e-5)
    h = 1e-4
    np.testing.assert_allclose(SAT.derivative(agb), (SAT.sigma(agb + h) - SAT.sigma(agb - h)) / (2 * h), rtol=1e-6)
    assert np.isinf(SAT.derivative(0.0))  # M^(alpha - 1) at 0


def test_saturating_peak_is_root_of_h():
    peak = SAT.peak_agb()
    assert SAT.derivative(peak * 0.999) > 0 > SAT.derivative(peak * 1.001)
    steep = SaturatingModel(0.02, 0.05, 0.02)  # beta2 M^alpha outgrows beta0: a visible peak
    p = steep.peak_agb()
    assert 0 < p < 1e4
    assert steep.sigma(p) > steep.sigma(2 * p) > 0.02


def test_saturating_inversion_round_trip_and_saturation():
    agb = np.array([0.5, 5.0, 50.0, 200.0, 600.0])
    inv = SAT.invert(SAT.sigma(agb), agb_max=1000.0)
    assert (inv.status == INVERTED).all()
    np.testing.assert_allclose(inv.agb, agb, rtol=1e-9)
    inv = SAT.invert([0.0549999999, 0.06, 0.0, -0.01, np.inf], agb_max=1000.0)
    assert inv.status.tolist() == [SATURATED, SATURATED, BELOW_RANGE, BELOW_RANGE, INVALID]
    assert inv.agb[0] == 1000.0 and inv.agb[2] == 0.0
    assert not np.isnan(inv.agb[:4]).any()
    # without a cap the estimate of a saturated value is unbounded, not NaN
    free = SAT.invert([0.056])
    assert free.status[0] == SATURATED and np.isposinf(free.agb[0])


def test_saturating_beta2_zero_closed_form_and_negative_beta2_branch():
    m = SaturatingModel(0.05, 0.01, 0.0)
    s = np.array([0.01, 0.03, 0.049])
    np.testing.assert_allclose(m.invert(s).agb, -np.log(1 - s / 0.05) / 0.01)
    neg = SaturatingModel(0.05, 0.01, -0.002)
    br = neg.branch()
    assert br.agb_low > 0 and br.sigma_low < 0
    agb = np.array([br.agb_low * 2, 100.0])
    np.testing.assert_allclose(neg.invert(neg.sigma(agb)).agb, agb, rtol=1e-8)


def test_saturating_fit_recovers_truth_and_matches_scipy():
    rng = np.random.default_rng(11)
    agb = rng.uniform(5, 350, 40)
    exact = SAT.fit(agb, SAT.sigma(agb), p0=[0.04, 0.03, 0.004])
    assert exact.converged
    np.testing.assert_allclose(exact.params, SAT.params, rtol=1e-6)
    noisy = SAT.sigma(agb) + 0.003 * rng.standard_normal(40)
    fit = SAT.fit(agb, noisy)
    ref = optimize.least_squares(lambda p: SAT.evaluate(agb, p) - noisy, SAT.params, xtol=1e-15, ftol=1e-15)
    np.testing.assert_allclose(fit.params, ref.x, rtol=1e-5)
    # eq. (6) with the residual variance: the covariance of curve_fit
    _, pcov = optimize.curve_fit(lambda m, a, b, c: SAT.evaluate(m, np.array([a, b, c])), agb, noisy, p0=SAT.params)
    np.testing.assert_allclose(fit.covariance, pcov, rtol=1e-3)


def test_saturating_initial_guess_finds_the_basin():
    agb = np.linspace(2, 300, 30)
    guess = SAT.initial_guess(agb, SAT.sigma(agb))
    assert guess[1] == pytest.approx(0.015, rel=0.2)
    far = SaturatingModel(0.5, 0.5, 0.5)  # a template far from the data
    fit = far.fit(agb, SAT.sigma(agb), p0=far.initial_guess(agb, SAT.sigma(agb)))
    np.testing.assert_allclose(fit.params, SAT.params, rtol=1e-5)


def test_non_convergence_is_counted_never_dropped():
    """Every data set gets a result and a status: unusable data are flagged (and keep the start values), flat
    data are fitted by a flat curve with beta1 stopped on its bound, which is no least-squares solution (that lies
    at beta1 = inf) and counts as out of domain; good data recover the model; from a poor start the exact data
    give the true coefficients."""
    rng = np.random.default_rng(3)
    agb = np.tile(np.linspace(5, 300, 20), (50, 1))
    sigma = SAT.sigma(agb) + 0.002 * rng.standard_normal(agb.shape)
    sigma[:5] = 0.05  # flat data: no saturation curve but a constant
    sigma[5] = np.nan  # unusable
    batch = SAT.fit_batch(agb, sigma, p0=np.tile(SAT.params, (50, 1)))
    assert batch.params.shape == (50, 3) and batch.status.shape == (50,)
    assert batch.status[5] == BAD_DATA and batch.n_failed == 6
    np.testing.assert_array_equal(batch.status[:5], OUT_OF_DOMAIN)
    np.testing.assert_allclose(batch.params[:5, 1], 1.0, rtol=1e-3)  # BETA1_MAX
    np.testing.assert_array_equal(batch.params[5], SAT.params)  # flagged, not fitted
    assert sum(batch.failure_counts().values()) == batch.n_failed
    for row in range(5):  # the fitted curve is the flat data
        np.testing.assert_allclose(SaturatingModel(*batch.params[row]).sigma(agb[row]), 0.05, atol=1e-6)
    good = batch.params[6:][batch.converged[6:]]
    assert len(good) == 44
    np.testing.assert_allclose(np.median(good, axis=0), SAT.params, rtol=0.15)  # noise of 0.002 on ~0.03
    few = SAT.fit_batch(agb[:3], SAT.sigma(agb[:3]), p0=np.tile([0.02, 0.5, -0.05], (3, 1)))
    assert np.all(few.status == CONVERGED)
    np.testing.assert_allclose(few.params, np.tile(SAT.params, (3, 1)), rtol=1e-6)


def test_levenberg_marquardt_iteration_limit_reported():
    x = np.linspace(0, 1, 10)
    y = np.exp(3 * x)[None]
    fit = levenberg_marquardt(lambda p, i: np.exp(p[:, :1] * x), lambda p, i: (x * np.exp(p[:, :1] * x))[..., None],
                              y, np.array([[-5.0]]), max_iter=2)
    assert fit.status[0] == MAX_ITERATIONS
    fit = levenberg_marquardt(lambda p, i: np.exp(p[:, :1] * x), lambda p, i: (x * np.exp(p[:, :1] * x))[..., None],
                              y, np.array([[-5.0]]))
    assert fit.status[0] == CONVERGED and fit.params[0, 0] == pytest.approx(3.0, rel=1e-9)


@pytest.mark.parametrize("args, message", [
    ((np.arange(3.0), np.ones(3)), "needs more than 3 plots"),
    ((np.arange(10.0), np.ones(9)), "field data must be agb"),
    ((np.r_[np.arange(9.0), np.nan], np.ones(10)), "NaN or infinite"),
    ((np.r_[np.arange(9.0), -1.0], np.ones(10)), "field AGB must be >= 0"),
])
def test_fit_bad_input_messages(args, message):
    with pytest.raises(PhysicsInputError, match=message):
        SAT.fit(*args)


def test_saturating_bad_coefficients():
    with pytest.raises(PhysicsInputError, match="beta0 > 0, beta1 > 0"):
        SaturatingModel(0.05, -0.01, 0.01)
    with pytest.raises(PhysicsInputError, match="below the start of the model's increasing branch"):
        SaturatingModel(0.05, 0.01, -0.002).branch(agb_max=1e-3)


# log-linear model -------------------------------------------------------------------------------------------
def test_loglinear_channel_weights_and_single_channel_exponent():
    # the weights are the minimum-variance unbiased combination: minimise c^T R c subject to c^T a = 1,
    # solved here numerically (an independent route to the closed form the model uses)
    from scipy import optimize

    a, r = np.array(LL.a), np.asarray(LL.residual_covariance)
    best = optimize.minimize(lambda c: c @ r @ c, np.full(3, 1 / a.sum()), method="SLSQP",
                             constraints=[{"type": "eq", "fun": lambda c: c @ a - 1}], options={"ftol": 1e-15})
    np.testing.assert_allclose(LL.channel_weights(), best.x, rtol=1e-5, atol=1e-7)
    assert LL.channel_weights() @ a == pytest.approx(1.0)
    x = np.array([-0.1, 0.05, 0.2])
    q, _ = LL.relative_agb_error(150.0, x, incidence_rad=0.5)
    np.testing.assert_allclose(q, (1 + x) ** LL.channel_weights()[1] - 1, rtol=1e-12)


def test_loglinear_inversion_exact_and_with_unusable_channels():
    agb = np.array([10.0, 100.0, 500.0])
    theta = np.radians([25.0, 35.0, 45.0])
    s = LL.sigma(agb, incidence_rad=theta)
    inv = LL.invert(s, incidence_rad=theta)
    np.testing.assert_allclose(inv.agb, agb, rtol=1e-12)
    s2 = s.copy()
    s2[0, 0] = -0.01  # HH unusable: the other two still give the exact AGB
    s2[1] = [-1.0, -1.0, -1.0]
    inv = LL.invert(s2, agb_max=300.0, incidence_rad=theta)
    assert inv.agb[0] == pytest.approx(10.0, rel=1e-12)
    assert inv.status.tolist() == [INVERTED, BELOW_RANGE, SATURATED]
    with pytest.raises(PhysicsInputError, match=r"needs sigma \(\.\.\., 3\)"):
        LL.invert(np.ones(4))


def test_loglinear_joint_fit_recovers_coefficients_and_sur_covariance(rng):
    """Coverage of the +-1.96 SE intervals of a_hv (SUR covariance Sigma_r kron (X^T X)^-1) over 300 data
    sets: binomial test against 95 % (normal critical value, 60 plots: t_57 differs by 1.5 %)."""
    chol = np.linalg.cholesky(LL.residual_covariance)
    hits = 0
    for _ in range(300):
        agb = rng.uniform(20, 400, 60)
        theta = np.radians(rng.uniform(25, 45, 60))
        s = LL.sigma(agb, incidence_rad=theta) * np.exp(rng.standard_normal((60, 3)) @ chol.T)
        fit = LL.fit(agb, s, incidence_rad=theta)
        hits += abs(fit.params[4] - 0.5) <= stats.t.ppf(0.975, 57) * fit.standard_errors[4]
    assert stats.binomtest(hits, 300, 0.95).pvalue > 1e-4, hits


def test_loglinear_jacobian_and_fixed_cosine_power():
    agb = np.array([20.0, 200.0])
    theta = np.radians([30.0, 40.0])
    np.testing.assert_allclose(LL.param_jacobian(agb, incidence_rad=theta),
                               _fd_jacobian(LL, agb, h=1e-6, incidence_rad=theta), rtol=1e-5, atol=1e-12)
    # constant incidence: n_pq cannot be fitted and keeps the template's value
    agb = np.linspace(20, 400, 20)
    s = LL.sigma(agb, incidence_rad=np.full(20, 0.6))
    fit = LL.fit(agb, s, incidence_rad=np.full(20, 0.6))
    np.testing.assert_allclose(fit.params, LL.params, rtol=1e-9, atol=1e-12)


def test_loglinear_bad_input():
    with pytest.raises(PhysicsInputError, match="must be 3 finite numbers"):
        LogLinearModel((0.0, 0.0), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    with pytest.raises(PhysicsInputError, match="symmetric positive definite"):
        LogLinearModel((0.0,) * 3, (1.0,) * 3, (0.0,) * 3, -np.eye(3))
    with pytest.raises(PhysicsInputError, match="gives HV no positive weight"):
        LogLinearModel((0.0,) * 3, (0.5, -0.1, 0.5), (0.0,) * 3).check_hv_weight()
    with pytest.raises(PhysicsInputError, match="incidence angles must be within"):
        LL.sigma(100.0, incidence_rad=2.0)


def _bisect_with_arrays(func, target, lo, hi, iterations=80, rtol=1e-13):
    """``bisect_increasing``'s loop on arrays, as it was written for every shape: the reference of one element."""
    target, lo, hi = (np.array([float(v)]) for v in (target, lo, hi))
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        above = func(mid) >= target
        hi, lo = np.where(above, mid, hi), np.where(above, lo, mid)
        if np.all(hi - lo <= rtol * np.maximum(np.abs(hi), 1.0)):
            break
    flo, fhi = func(lo), func(hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(fhi > flo, lo + (target - flo) * (hi - lo) / (fhi - flo), 0.5 * (lo + hi))
    return np.clip(x, lo, hi)


def test_one_value_inversion_is_the_array_loop_bit_for_bit():
    # one value is bisected on Python floats, sigma kept at its midpoints: the array loop's numbers exactly
    branch = SAT.branch(1000.0)
    for t in SAT.sigma(np.array([0.3, 7.0, 123.456, 400.0, 999.0])):
        expected = _bisect_with_arrays(SAT.sigma, t, branch.agb_low, branch.agb_high)
        assert bisect_increasing(SAT.sigma, np.array([t]), branch.agb_low, branch.agb_high).tobytes() == \
            expected.tobytes()
        # the model's own inversion, twice (the second from the kept sigma values), and by a fresh model
        for model in (SAT, SAT, SaturatingModel(SAT.beta0, SAT.beta1, SAT.beta2)):
            assert model.invert(np.array([t]), agb_max=1000.0).agb.tobytes() == expected.tobytes()
