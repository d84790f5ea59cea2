"""Uncertainty of a fitted backscatter-AGB model: confidence and prediction bands and their inversion.

Ahmed, Siqueira & Hensley (2014), Section II-B:

* confidence interval of the fitted backscatter at AGB M, ``f(beta_hat, M) +- t S_y`` (eq. 3), with the
  delta-method standard error ``S_y^2 = F_beta^T Sigma_beta F_beta`` (eq. 4), ``F_beta = d f / d beta``
  (eq. 5), and ``Sigma_beta`` from the fit (eq. 6, with the residual variance, see ``FitResult``) or from
  the parametric bootstrap (eqs. 11-13);
* prediction interval ``f +- t sqrt(S_y^2 + sigma_hat^2)`` (eq. 7), sigma_hat^2 the variance of the
  error in equation (model error), from the residuals or from eq. (14) (``model_error_variance``);
* numerical inversion of these bands to AGB intervals for an observed backscatter (Figs. 13, 20): the
  set of AGB values whose band contains the observation. Where the lower band never climbs above the
  observation within the AGB range considered, the interval is *unbounded above* -- the consequence of
  saturation the paper reports ("the intervals are infinitely large at biomass values larger than
  80 tons/ha").

Bands of log-space fits are computed in ln sigma and transformed back (asymmetric in sigma).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.models import BELOW_RANGE, INVERTED, SATURATED, FitResult, Inversion, RetrievalModel

CRITICAL_KINDS = ("normal", "t")

# AGB interval status codes
BOUNDED = 0
"""The AGB interval is finite."""
UNBOUNDED_ABOVE = 1
"""The band still contains the observation at the largest AGB considered: no finite upper bound."""
ABOVE_BAND = 2
"""The observation lies above the upper band everywhere: no AGB in range is consistent with it."""
BELOW_BAND = 3
"""The observation lies below the lower band everywhere (e.g. a negative backscatter)."""
INTERVAL_STATUS_NAMES = {BOUNDED: "bounded", UNBOUNDED_ABOVE: "unbounded_above", ABOVE_BAND: "above_band",
                         BELOW_BAND: "below_band"}


def critical_value(level: float, kind: str = "normal", dof: int | None = None) -> float:
    """Two-sided critical value for a confidence ``level`` (0.95 -> 1.96 for "normal").

    Ahmed et al. (2014) use the standard normal value ("t_{alpha/2} ... 1.96", eq. 3); "t" uses the
    Student t with ``dof`` degrees of freedom, the exact value for a linear model with Gaussian errors.
    """
    if not 0 < level < 1:
        raise PhysicsInputError(f"confidence level must be in (0, 1), got {level}")
    if kind == "normal":
        from scipy import special

        return float(special.ndtri(0.5 + level / 2))
    if kind == "t":
        if dof is None or dof < 1:
            raise PhysicsInputError(f"a Student t critical value needs dof >= 1, got {dof}")
        from scipy import stats  # imported here: scipy.stats costs a second at start-up

        return float(stats.t.ppf(0.5 + level / 2, dof))
    raise PhysicsInputError(f"critical value kind must be one of {CRITICAL_KINDS}, got {kind!r}")


@dataclass(frozen=True)
class Band:
    """Confidence and prediction bands of a fitted model over an AGB grid (m values).

    agb : (m,) AGB grid (t/ha). fit : (m,) fitted sigma (m^2/m^2). se_fit : (m,) S_y (eq. 4) and
    residual_sd : sigma_hat (eq. 7), both in the fit space (m^2/m^2 for "linear", ln units for "log").
    conf_lower, conf_upper : (m,) confidence band (eq. 3); pred_lower, pred_upper : (m,) prediction band
    (eq. 7), in m^2/m^2. level : confidence level; z : critical value used. space : fit space.
    model : the fitted model (its inversion gives the AGB estimate). channel : output channel index.
    """

    agb: np.ndarray
    fit: np.ndarray
    se_fit: np.ndarray
    residual_sd: float
    conf_lower: np.ndarray
    conf_upper: np.ndarray
    pred_lower: np.ndarray
    pred_upper: np.ndarray
    level: float
    z: float
    space: str
    model: RetrievalModel
    channel: int | None = None

    def bounds(self, which: str = "confidence"):
        if which == "confidence":
            return self.conf_lower, self.conf_upper
        if which == "prediction":
            return self.pred_lower, self.pred_upper
        raise PhysicsInputError(f"band must be 'confidence' or 'prediction', got {which!r}")


def delta_method_band(model: RetrievalModel, covariance, agb, residual_variance: float = 0.0, level: float = 0.95,
                      space: str = "linear", critical: str = "normal", dof: int | None = None,
                      channel: int | None = None, **covariates) -> Band:
    """Bands of eqs. (3), (4), (7) for coefficients with covariance ``covariance`` (p, p).

    agb : (m,) grid (t/ha). residual_variance : sigma_hat^2 of eq. (7), in the fit space.
    channel : output index for a multi-channel model (default: HV, index 1), None for single-channel.
    """
    agb = np.asarray(agb, dtype=float)
    cov = np.asarray(covariance, dtype=float)
    p = model.params.shape[0]
    if cov.shape != (p, p):
        raise PhysicsInputError(f"coefficient covariance must be {p}x{p}, got {cov.shape}")
    if residual_variance < 0:
        raise PhysicsInputError(f"the model-error variance must be >= 0, got {residual_variance}")
    fit = model.evaluate(agb, **covariates)
    jac = model.param_jacobian(agb, **covariates)
    if fit.ndim == agb.ndim + 1:  # multi-channel output
        channel = 1 if channel is None else channel
        fit, jac = fit[..., channel], jac[..., channel, :]
    if space == "log":
        jac = jac / fit[..., None]
    var = np.einsum("mi,ij,mj->m", jac, cov, jac)  # eq. (4)
    se = np.sqrt(np.clip(var, 0.0, None))
    z = critical_value(level, critical, dof)
    sd_pred = np.sqrt(se**2 + residual_variance)
    if space == "log":
        lf = np.log(fit)
        bands = np.exp(lf - z * se), np.exp(lf + z * se), np.exp(lf - z * sd_pred), np.exp(lf + z * sd_pred)
    else:
        bands = fit - z * se, fit + z * se, fit - z * sd_pred, fit + z * sd_pred
    return Band(agb, fit, se, float(np.sqrt(residual_variance)), *bands, level=level, z=z, space=space,
                model=model, channel=channel)


def band_from_fit(fit: FitResult, agb, level: float = 0.95, critical: str = "normal",
                  residual_variance: float | None = None, covariance=None, channel: int | None = None,
                  **covariates) -> Band:
    """Bands of a ``FitResult`` (naive intervals of Section III-A): its covariance (eq. 6) and residual
    variance, unless other ones are given (e.g. bootstrap covariance, eq. 14 model error)."""
    s2 = fit.residual_variance if residual_variance is None else residual_variance
    if np.ndim(s2):  # multi-channel fit: the channel's residual variance
        s2 = float(np.asarray(s2)[1 if channel is None else channel])
    cov = fit.covariance if covariance is None else covariance
    return delta_method_band(fit.model, cov, agb, float(s2), level, fit.space, critical, fit.dof, channel,
                             **covariates)


@dataclass(frozen=True)
class AGBIntervals:
    """AGB intervals from inverting a band at observed backscatter values (k of them).

    sigma : (k,) observed backscatter (m^2/m^2). estimate : (k,) AGB from the fitted curve (t/ha; see
    ``estimate_status`` for saturation). lower, upper : (k,) interval bounds (t/ha); upper is +inf where
    unbounded. status : (k,) ``BOUNDED``, ``UNBOUNDED_ABOVE``, ``ABOVE_BAND`` or ``BELOW_BAND``.
    estimate_status : (k,) inversion status of the estimate (``e2esim.retrieval.models``).
    agb_range : (lowest, highest) AGB of the grid the band was inverted over.
    """

    sigma: np.ndarray
    estimate: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    status: np.ndarray
    estimate_status: np.ndarray
    agb_range: tuple

    @property
    def width(self) -> np.ndarray:
        return self.upper - self.lower

    @property
    def unbounded_fraction(self) -> float:
        return float(np.mean(self.status != BOUNDED))

    def counts(self) -> dict:
        return {name: int(np.count_nonzero(self.status == code)) for code, name in INTERVAL_STATUS_NAMES.items()}


def invert_band(band: Band, sigma_obs, which: str = "confidence") -> AGBIntervals:
    """AGB interval ``{M : lower(M) <= sigma_obs <= upper(M)}`` for each observation (grid-based).

    The interval is the hull of that set on the band's AGB grid, its ends refined by linear interpolation
    between grid points. ``upper`` is +inf (``UNBOUNDED_ABOVE``) where the band still contains the
    observation at the last grid point: with a saturating model the lower band never rises above it.
    """
    lo, hi = band.bounds(which)
    m = band.agb
    s = np.atleast_1d(np.asarray(sigma_obs, dtype=float))
    if not np.all(np.isfinite(s)):
        raise PhysicsInputError("observed backscatter values must be finite")
    inside = (lo[None, :] <= s[:, None]) & (s[:, None] <= hi[None, :])  # (k, m)
    any_in = inside.any(axis=1)
    first = np.argmax(inside, axis=1)
    last = m.size - 1 - np.argmax(inside[:, ::-1], axis=1)
    lower = m[first].astype(float)
    upper = m[last].astype(float)
    # refine the lower end where the upper band crosses the observation between grid points
    j = first
    cross = any_in & (j > 0) & (hi[np.maximum(j - 1, 0)] < s)
    jj = j[cross]
    lower[cross] = _interp_crossing(m[jj - 1], m[jj], hi[jj - 1], hi[jj], s[cross])
    # refine the upper end where the lower band crosses the observation
    j = last
    cross = any_in & (j < m.size - 1) & (lo[np.minimum(j + 1, m.size - 1)] > s)
    jj = j[cross]
    upper[cross] = _interp_crossing(m[jj], m[jj + 1], lo[jj], lo[jj + 1], s[cross])
    status = np.full(s.shape, BOUNDED, dtype=np.int8)
    unbounded = any_in & (last == m.size - 1)
    status[unbounded] = UNBOUNDED_ABOVE
    upper[unbounded] = np.inf
    above = ~any_in & (s > hi.max())
    below = ~any_in & ~above
    status[above], status[below] = ABOVE_BAND, BELOW_BAND
    lower[above], upper[above] = m[-1], np.inf
    lower[below], upper[below] = m[0], m[0]
    ch = band.channel
    if ch is None:
        inv = band.model.invert(s, agb_max=float(m[-1]))
    else:  # multi-channel model: invert the channel alone through its own power law
        inv = _invert_single_channel(band.model, s, ch, float(m[-1]))
    return AGBIntervals(s, inv.agb, lower, upper, status, inv.status, (float(m[0]), float(m[-1])))


def _interp_crossing(m0, m1, v0, v1, target):
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(v1 != v0, (target - v0) / (v1 - v0), 0.5)
    return m0 + np.clip(t, 0.0, 1.0) * (m1 - m0)


def _invert_single_channel(model, s, channel, agb_max):
    ln_l, a = model.ln_l[channel], model.a[channel]
    positive = s > 0
    with np.errstate(divide="ignore", over="ignore"):
        agb = np.where(positive, np.exp((np.log(np.where(positive, s, 1.0)) - ln_l) / a), 0.0)
    status = np.where(positive, INVERTED, BELOW_RANGE).astype(np.int8)
    over = positive & (agb > agb_max)
    status[over] = SATURATED
    agb = np.where(over, agb_max, agb)
    return Inversion(agb, status, float(np.exp(ln_l) * agb_max**a), agb_max)


@dataclass(frozen=True)
class ModelErrorEstimate:
    """Variance of the error in equation, Ahmed et al. (2014), eq. (14).

    variance : the estimate, clipped at 0 ((m^2/m^2)^2). raw : before clipping. residual_mean_square :
    sum of squared residuals / denominator. response_error : mean sigma_q^2 (eq. 15). predictor_error :
    mean F_X^2 sigma_u^2 over the plots (eq. 14 with eqs. 15-16). clipped : the measurement errors explain
    all the residual scatter (raw < 0). denominator : n - p or n - k.
    """

    variance: float
    raw: float
    residual_mean_square: float
    response_error: float
    predictor_error: float
    clipped: bool
    denominator: int


DENOMINATORS = ("n-p", "n-k")


def model_error_variance(model: RetrievalModel, agb, sigma, sigma_error_sd, agb_error_sd,
                         denominator: str = "n-p", **covariates) -> ModelErrorEstimate:
    """Eq. (14): residual mean square of the (corrected) fit minus the measurement-error variances.

    ``sigma_hat^2 = sum_i (D_i - f(beta_c, W_i))^2 / (n - p) - mean_i sigma_qi^2 - mean_i F_X(W_i)^2 sigma_ui^2``.

    Two differences from the printed equation, both from the linear-regression result it borrows
    (Buonaccorsi 2010, Section 5.4) and checked by simulation in tests/test_retrieval_bootstrap.py:
    the denominator is n - p (p coefficients), not n - k (k predictors; ``denominator="n-k"`` gives the
    printed form), and with heteroscedastic errors the predictor term is the mean over plots of
    ``F_X(W_i)^2 sigma_ui^2`` rather than F_X^T (mean Sigma_u) F_X at an unspecified point (identical when
    F_X and sigma_u are constant).
    """
    agb = np.asarray(agb, dtype=float)
    sigma = np.asarray(sigma, dtype=float)
    n = agb.shape[0]
    if denominator not in DENOMINATORS:
        raise PhysicsInputError(f"denominator must be one of {DENOMINATORS}, got {denominator!r}")
    dof = n - (model.params.shape[0] if denominator == "n-p" else 1)
    if dof < 1:
        raise PhysicsInputError(f"eq. (14) needs more plots than coefficients, got n = {n}")
    fit = model.evaluate(agb, **covariates)
    deriv = model.agb_derivative(agb, **covariates)
    if fit.ndim == agb.ndim + 1:
        raise PhysicsInputError("eq. (14) is implemented for single-channel models")
    rms = float(np.sum((sigma - fit) ** 2) / dof)
    q = float(np.mean(np.broadcast_to(np.asarray(sigma_error_sd, float), agb.shape) ** 2))
    u = float(np.mean(np.where(np.isfinite(deriv), deriv, 0.0) ** 2 * np.broadcast_to(
        np.asarray(agb_error_sd, float), agb.shape) ** 2))
    raw = rms - q - u
    return ModelErrorEstimate(max(raw, 0.0), raw, rms, q, u, raw < 0, dof)
