"""System drift between calibrations and the combination of visits over time (issue 25, item 4).

Drift model of one parameter x (gain in dB; crosstalk or imbalance as a complex number, each of its real and
imaginary parts following the model independently with half the stated variances):

    x(t) = x0 + d t + a sin(2 pi t / P) + b cos(2 pi t / P) + w(t),

x0 ~ N(0, s0^2) the error left before the campaign, d ~ N(0, s_d^2) an unknown linear trend, (a, b) ~ N(0, s_s^2 / 2)
each an unknown seasonal term of RMS amplitude s_s / sqrt(2) and period P (one year: temperature), and w a
random walk, E[(w(t + h) - w(t))^2] = q h. Each visit k measures y_k = x(t_k) + e_k, e_k ~ N(0, r_k).

The visits are combined by the Kalman filter of this state-space model (Kalman 1960; Gelb 1974, Table 4.2-1):
state z = (x_lin, d, a, b) with x_lin = x0 + d t + w(t) and x = x_lin + a sin + b cos. Because the error left is all
that is asked, only the covariance recursion runs; it does not depend on the measured values:

    predict  P <- F P F' + Q,  F = I except F[0, 1] = h (the trend accumulates into x_rw), Q = diag(q h, 0, 0, 0);
    update   K = P H' / (H P H' + r),  P <- (I - K H) P,  H(t) = (1, 0, sin(2 pi t / P), cos(2 pi t / P)),

so the trend reaches x through x_lin (H has 0 for d). The residual variance of the parameter at time t is
H(t) P(t) H(t)'. With no drift and equal independent visits of variance r it is (1/s0^2 + n/r)^-1, which tends to
r / n: the closed form of ``tests/test_campaign_drift.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError

YEAR_DAYS = 365.25


@dataclass(frozen=True)
class DriftModel:
    """Drift of one parameter (units of the parameter: dB for the gain, linear for crosstalk and imbalance).

    initial_sd : s0, the error before the first visit. random_walk_variance_per_day : q, the variance the random
    walk adds per day. trend_sd_per_year : s_d, the SD of the unknown linear trend per year. seasonal_sd : s_s, the SD
    of the seasonal term (its RMS over a year). seasonal_period_days : P.
    """

    initial_sd: float
    random_walk_variance_per_day: float = 0.0
    trend_sd_per_year: float = 0.0
    seasonal_sd: float = 0.0
    seasonal_period_days: float = YEAR_DAYS

    def __post_init__(self):
        for name in ("initial_sd", "random_walk_variance_per_day", "trend_sd_per_year", "seasonal_sd"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise PhysicsInputError(f"drift {name} {value!r} must be a finite number >= 0 (a variance or SD "
                                        f"cannot be negative)", key=name)
        if not self.seasonal_period_days > 0:
            raise PhysicsInputError(f"seasonal period {self.seasonal_period_days!r} days must be > 0",
                                    key="seasonal_period_days")

    def prior(self) -> np.ndarray:
        """Covariance of z = (x_rw, d [per day], a, b) before any visit."""
        d = self.trend_sd_per_year / YEAR_DAYS
        s = self.seasonal_sd**2 / 2
        return np.diag([self.initial_sd**2, d**2, s, s])

    def observation(self, day) -> np.ndarray:
        """H(t) for the days ``day`` (shape (..., 4))."""
        w = 2 * np.pi * np.asarray(day, float) / self.seasonal_period_days
        one = np.ones_like(w)
        return np.stack([one, 0 * one, np.sin(w), np.cos(w)], -1)


def residual_variance(model: DriftModel, days, visit_days, visit_variance) -> np.ndarray:
    """Variance of the error left in the parameter on each of ``days`` (from day 0) after the Kalman filter has
    combined the visits made up to that day (a visit on a day counts from that day on).

    visit_days : (V,) days of the candidate visits (fractional days allowed). visit_variance : r of each visit,
    (V,), or (S, V) for S schedules at once that use the same candidate visits (inf: the schedule does not use that
    visit, or it measures nothing). Returns (len(days),), or (S, len(days)).
    """
    vd = np.asarray(visit_days, float).ravel()
    return joint_residual_variance((model,), days, vd, np.ones((vd.size, 1)), visit_variance)[0]


def joint_residual_variance(models: tuple, days, visit_days, visit_rows, visit_variance) -> np.ndarray:
    """``residual_variance`` of m parameters estimated together: visit k measures sum_j rows[k, j] x_j(t_k) + e_k
    (each x_j with its own drift model, independent a priori: a block-diagonal state of 4 m, F and Q block by block,
    H = (rows[k, 0] H_0(t), ..., rows[k, m-1] H_{m-1}(t))). visit_rows : (V, m). Returns (m, len(days)) or
    (m, S, len(days)): the residual variance of each x_j on each day."""
    days = np.asarray(days, float)
    if np.any(np.diff(days) < 0):
        raise PhysicsInputError("the output days must be in increasing order")
    vd = np.asarray(visit_days, float).ravel()
    rows = np.asarray(visit_rows, float).reshape(vd.size, len(models))
    rv = np.asarray(visit_variance, float)
    single = rv.ndim < 2
    rv = np.broadcast_to(rv, (1, vd.size) if single else (rv.shape[0], vd.size))
    times = np.concatenate([days, vd])
    kinds = np.concatenate([np.full(days.size, -1), np.arange(vd.size)])
    order = np.lexsort((kinds < 0, times))  # by time; on the same instant a visit before an output day
    m = len(models)
    prior = np.zeros((4 * m, 4 * m))
    for j, model in enumerate(models):
        prior[4 * j:4 * j + 4, 4 * j:4 * j + 4] = model.prior()
    p = np.broadcast_to(prior, (rv.shape[0], 4 * m, 4 * m)).copy()
    q = np.array([model.random_walk_variance_per_day for model in models])
    starts = 4 * np.arange(m)
    out = np.empty((m, rv.shape[0], days.size))
    obs = [model.observation(times) for model in models]
    # the diagonal blocks (m, S, 4, 4): a view of P (the steps work in place, so it stays P's), read into one buffer
    on_diagonal = np.einsum("sjajb->jsab", p.reshape(-1, m, 4, m, 4))
    blocks = np.empty(on_diagonal.shape)
    last, out_index, pending = 0.0, 0, 0.0
    for k in order:
        h = times[k] - last
        if h > 0 and m == 1:
            p = _predict(p, h, q[0])
        elif h > 0:  # several blocks: predictions compose, F(h1) F(h2) = F(h1 + h2) (E^2 = 0, F e0 = e0), so
            pending += h  # they wait for the next visit, and an output day reads the prediction without applying it
        last = times[k] if h > 0 else last
        if kinds[k] < 0:
            if m == 1:
                out[0, :, out_index] = np.einsum("i,sij,j->s", obs[0][k], p, obs[0][k])
            else:  # H F(h) = H + h H_0 e1' on the diagonal blocks (m, S, 4, 4), plus H_0^2 q h
                blocks[...] = on_diagonal
                hk = np.stack([o[k] for o in obs])
                hk[:, 1] += pending * hk[:, 0]
                out[:, :, out_index] = (np.einsum("ji,jsik,jk->js", hk, blocks, hk)
                                        + (pending * q * hk[:, 0] ** 2)[:, None])
            out_index += 1
        else:
            if pending > 0:
                p, pending = _predict(p, pending, q, starts), 0.0
            v = kinds[k]
            hvec = obs[0][k] * rows[v, 0] if m == 1 else np.concatenate([obs[j][k] * rows[v, j] for j in range(m)])
            p = _update(p, hvec, rv[:, v])
    return out[:, 0] if single else out


def _predict(p, h, q, at=0):
    """P <- F P F' + Q for F = I + h sum_a e_a e_(a+1)' (the trend accumulates into x_lin, a in ``at``, the first
    state of each block) and Q = h sum_a q_a e_a e_a', written out, in place (the filter owns P). The blocks are
    reached through a strided view (S, m, 4, m, 4) rather than a gather of their rows: the same operations on the
    same elements, without copying P's rows and columns out and back at every step."""
    blocks = p.reshape(p.shape[0], -1, 4, p.shape[1] // 4, 4)
    blocks[:, :, 0] += h * blocks[:, :, 1]
    blocks[..., 0] += h * blocks[..., 1]
    p[:, at, at] += q * h
    return p


def _update(p, hvec, r):
    """Kalman update of S covariances (S, 4, 4) with variances r (S,) in Joseph's form (I - K H) P (I - K H)' +
    K r K' (Gelb 1974, eq. 4.2-18), computed as two rank-one corrections so that it stays symmetric and positive
    under a vague prior; a schedule with r = inf (it does not use the visit) is left as it is. In place."""
    use = np.flatnonzero(np.isfinite(r))
    if use.size == 0:
        return p
    every = use.size == r.size
    q, r = (p, r) if every else (p[use], r[use])  # q: P itself, or a copy of the rows that use the visit
    ph = q @ hvec  # (U, 4)
    gain = ph / (ph @ hvec + r)[:, None]
    term = np.multiply(gain[:, :, None], ph[:, None, :])  # one (U, n, n) buffer for the three outer products
    q -= term  # (I - K H) P, P symmetric (in place: the same operations as m = P - K (P H)')
    mh = q @ hvec
    q -= np.multiply(mh[:, :, None], gain[:, None, :], out=term)
    q += np.multiply((r[:, None] * gain)[:, :, None], gain[:, None, :], out=term)
    if not every:
        p[use] = q
    return p


def simulate_drift(model: DriftModel, days, rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` realisations of x(t) on ``days`` (sorted, >= 0) drawn from the model itself: (n, len(days))."""
    days = np.asarray(days, float)
    z = rng.multivariate_normal(np.zeros(4), model.prior(), size=n)
    steps = np.diff(np.concatenate([[0.0], days]))
    walk = np.cumsum(rng.standard_normal((n, days.size)) * np.sqrt(model.random_walk_variance_per_day * steps), axis=1)
    w = 2 * np.pi * days / model.seasonal_period_days
    return (z[:, :1] + walk + z[:, 1:2] * days + z[:, 2:3] * np.sin(w) + z[:, 3:4] * np.cos(w))
