"""The drift model and the Kalman combination of calibration visits (issue 25, item 4).

Closed form: equal independent measurements of a constant leave (1/s0^2 + n/r)^-1, hence r/n without a prior.
Against the model itself: the filter's residual variance equals the Gaussian conditioning of the model's own
covariance function (an independent batch formula), and a Monte Carlo of the drift model (simulate_drift) gives
that covariance and that residual within its sampling error (bounds at 5 standard errors: they hold for any seed
except with probability below 1e-6)."""

from __future__ import annotations

import numpy as np
import pytest

from e2esim.campaign import drift
from e2esim.campaign.drift import DriftModel, joint_residual_variance, residual_variance, simulate_drift
from e2esim.errors import PhysicsInputError


def test_equal_independent_visits_of_a_constant_leave_sigma2_over_n():
    r = 0.04
    visits = np.arange(10) + 0.5
    days = np.arange(11.0)  # day k sees the k visits before it
    got = residual_variance(DriftModel(initial_sd=3.0), days, visits, r)
    n = np.arange(11)
    np.testing.assert_allclose(got, 1 / (1 / 9.0 + n / r), rtol=1e-12)
    flat = residual_variance(DriftModel(initial_sd=1e4), days[1:], visits, r)
    np.testing.assert_allclose(flat, r / n[1:], rtol=1e-9)  # prior weight 4e-10 of one visit


def test_a_visit_a_schedule_does_not_use_changes_nothing():
    model = DriftModel(0.5, 1e-3, 0.2, 0.1)
    days = np.arange(0.0, 400.0, 7.0)
    visits = np.array([10.0, 50.0, 120.0, 300.0])
    both = residual_variance(model, days, visits, np.array([[0.01, np.inf, 0.02, np.inf], [0.01, 0.03, 0.02, 0.05]]))
    np.testing.assert_allclose(both[0], residual_variance(model, days, visits[[0, 2]], [0.01, 0.02]), rtol=1e-12)
    assert np.all(both[1] <= both[0] + 1e-15) and np.any(both[1] < both[0] * 0.99)


def _covariance(model: DriftModel, s, t):
    """Cov(x(s), x(t)) of the drift model, written from its definition."""
    s, t = np.asarray(s, float)[:, None], np.asarray(t, float)[None, :]
    d = model.trend_sd_per_year / 365.25
    w = 2 * np.pi / model.seasonal_period_days
    return (model.initial_sd**2 + d**2 * s * t + model.random_walk_variance_per_day * np.minimum(s, t)
            + model.seasonal_sd**2 / 2 * np.cos(w * (s - t)))


MODEL = DriftModel(initial_sd=0.4, random_walk_variance_per_day=2e-3, trend_sd_per_year=0.5, seasonal_sd=0.3)
VISITS = np.array([5.0, 40.0, 41.0, 160.0, 250.0])
R = np.array([0.01, 0.05, 0.05, 0.02, 0.1])
DAYS = np.array([1.0, 45.0, 100.0, 200.0, 250.0, 330.0])


def _conditioned(t):
    """Var(x(t) | visits up to t) by Gaussian conditioning (batch), and the regression weights."""
    seen = VISITS <= t
    cyy = _covariance(MODEL, VISITS[seen], VISITS[seen]) + np.diag(R[seen])
    cxy = _covariance(MODEL, [t], VISITS[seen])[0]
    weights = np.linalg.solve(cyy, cxy)
    return _covariance(MODEL, [t], [t])[0, 0] - cxy @ weights, weights, seen


def test_filter_equals_gaussian_conditioning_of_the_drift_model():
    got = residual_variance(MODEL, DAYS, VISITS, R)
    want = np.array([_conditioned(t)[0] for t in DAYS])
    np.testing.assert_allclose(got, want, rtol=1e-9)


def test_filter_residual_against_a_monte_carlo_of_the_drift_model(rng):
    n = 20000
    times = np.unique(np.concatenate([VISITS, DAYS]))
    x = simulate_drift(MODEL, times, rng, n)
    y = x[:, np.searchsorted(times, VISITS)] + rng.standard_normal((n, VISITS.size)) * np.sqrt(R)
    predicted = residual_variance(MODEL, DAYS, VISITS, R)
    cov = np.cov(x, rowvar=False)
    model_cov = _covariance(MODEL, times, times)
    se_cov = np.sqrt((model_cov**2 + np.outer(np.diag(model_cov), np.diag(model_cov))) / (n - 1))
    assert np.all(np.abs(cov - model_cov) < 5 * se_cov)
    for k, t in enumerate(DAYS):
        _, weights, seen = _conditioned(t)
        err = x[:, np.searchsorted(times, t)] - y[:, seen] @ weights
        sample = np.mean(err**2)
        assert abs(sample - predicted[k]) < 5 * predicted[k] * np.sqrt(2 / n), (t, sample, predicted[k])


@pytest.mark.parametrize("name", ["initial_sd", "random_walk_variance_per_day", "trend_sd_per_year", "seasonal_sd"])
def test_a_negative_drift_variance_is_refused_naming_it(name):
    with pytest.raises(PhysicsInputError, match=f"drift {name} -1.0 must be a finite number >= 0") as info:
        DriftModel(**{"initial_sd": 1.0, name: -1.0})
    assert info.value.key == name



def _gathered_predict(p, h, q, at=0):
    """The filter's predict step as first written (rows and columns gathered by index and written back)."""
    p[:, at, :] += h * p[:, at + 1, :]
    p[:, :, at] += h * p[:, :, at + 1]
    p[:, at, at] += q * h
    return p


def _copying_update(p, hvec, r):
    """The filter's update step as first written (a new array for every intermediate)."""
    use = np.flatnonzero(np.isfinite(r))
    if use.size == 0:
        return p
    every = use.size == r.size
    q, r = (p, r) if every else (p[use], r[use])
    ph = q @ hvec
    gain = ph / (ph @ hvec + r)[:, None]
    m = q - gain[:, :, None] * ph[:, None, :]
    mh = m @ hvec
    new = m - mh[:, :, None] * gain[:, None, :] + r[:, None, None] * gain[:, :, None] * gain[:, None, :]
    if every:
        p[...] = new
    else:
        p[use] = new
    return p


def _random_schedules(rng, blocks):
    models = (DriftModel(0.5, 2e-4, 0.1, 0.1), DriftModel(0.1, 1e-6, 0.01, 0.02), DriftModel(0.1, 1e-6, 0.01, 0.02))
    visit_days = np.sort(rng.uniform(0.0, 400.0, 40))
    rows = np.column_stack([np.ones(40), rng.uniform(-1, 1, 40), rng.uniform(-0.4, 0.7, 40)])[:, :blocks]
    used = rng.random((9, 40)) < rng.uniform(0.1, 0.9, (9, 1))
    used[:, 0], used[:, 1] = True, False  # a visit every schedule uses and one none uses take the other branches
    variance = np.where(used, rng.uniform(0.01, 0.2, 40), np.inf)
    return models[:blocks], np.arange(0.0, 401.0, 3.0), visit_days, rows, variance


@pytest.mark.parametrize("blocks", [1, 3])
def test_in_place_filter_steps_equal_the_copying_ones_bit_for_bit(rng, blocks, monkeypatch):
    """The predict and update steps work in place on P (a strided view of the blocks, one buffer for the outer
    products) to make the schedule search fast; over random visit sets of a single parameter and of the gain's
    joint (gain, pointing, pattern) state they must give exactly the numbers of the steps as first written."""
    args = _random_schedules(rng, blocks)
    fast = joint_residual_variance(*args)
    monkeypatch.setattr(drift, "_predict", _gathered_predict)
    monkeypatch.setattr(drift, "_update", _copying_update)
    assert np.array_equal(fast, joint_residual_variance(*args))


@pytest.mark.parametrize("blocks", [1, 3])
def test_batched_filter_equals_each_schedule_alone(rng, blocks):
    """The schedule search runs every distinct schedule in one batched filter ((S, 4 m, 4 m) covariances, each visit
    updating only the schedules that use it); each schedule's residual is what the filter gives it alone. Not bit for
    bit: the read-out's einsum sums in an order that depends on the batch (a last-bit difference on some days), so
    to 1e-14 relative."""
    args = _random_schedules(rng, blocks)
    batched = joint_residual_variance(*args)
    for s in range(args[-1].shape[0]):
        alone = joint_residual_variance(*args[:-1], args[-1][s])
        np.testing.assert_allclose(batched[:, s], alone, rtol=1e-14, atol=0)
