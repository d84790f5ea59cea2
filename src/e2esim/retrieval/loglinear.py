"""Multi-channel log-linear backscatter-AGB model, like the BIOMASS level-2 AGB prototype.

``sigma0_pq = l_pq AGB^(a_pq) cos^(n_pq)(theta)`` for pq in (hh, hv, vv) (Soja et al. 2018, "Mapping
above-ground biomass in tropical forests with ground-cancelled P-band SAR and limited reference data",
Remote Sens. Environ. 211, the form the BIOMASS AGB algorithm builds on), theta the local incidence
angle. In logarithms it is linear in the coefficients,

    ln sigma_pq = ln l_pq + a_pq ln AGB + n_pq ln cos(theta) + r_pq,

with residuals r correlated between channels (covariance ``residual_covariance``, 3 x 3).

* Joint fit over HH, HV and VV: a system of seemingly unrelated regressions. All three channels have the
  same regressors (1, ln AGB, ln cos theta), so the generalised least-squares estimator of the system is
  channel-wise ordinary least squares (Zellner 1962), and the covariance of the nine coefficients is
  ``Sigma_r kron (X^T X)^-1``; the residual covariance Sigma_r couples the channels.
* Joint inversion: every channel gives an estimate of ln AGB, ``y_pq = (ln sigma_pq - ln l_pq - n_pq ln
  cos theta)``; the minimum-variance combination is the generalised least-squares estimate
  ``ln AGB = (a^T Sigma_r^-1 y) / (a^T Sigma_r^-1 a)``, i.e. ``ln AGB = sum_pq c_pq (ln sigma_pq - ...)``
  with channel weights ``c = Sigma_r^-1 a / (a^T Sigma_r^-1 a)``. A relative error x in one channel alone
  therefore gives a relative AGB error ``(1 + x)^(c_pq) - 1``: the model acts on an HV error like a power
  law of exponent c_hv.

Channels with sigma <= 0 (possible in the tails of an error model) are left out of the combination for
that value; if no channel is usable the value is below range (AGB 0). The model increases without bound
(a_pq > 0), so saturation only occurs through the cap ``agb_max``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from itertools import product

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.models import (
    BAD_DATA,
    BELOW_RANGE,
    CONVERGED,
    INVALID,
    INVERTED,
    SATURATED,
    BatchFit,
    FitResult,
    Inversion,
    RetrievalModel,
    ols_batch,
    safe_inverse,
)

CHANNELS = ("hh", "hv", "vv")
_N_CH = len(CHANNELS)


def selected_channels(channels=None) -> np.ndarray:
    """Boolean mask over (hh, hv, vv) of the channel names given (None: all)."""
    if channels is None:
        return np.ones(_N_CH, dtype=bool)
    unknown = [c for c in channels if c not in CHANNELS]
    if unknown or not channels:
        raise PhysicsInputError(f"channels must be a non-empty subset of {CHANNELS}, got {tuple(channels)}")
    return np.array([c in channels for c in CHANNELS])
_THETA_SPREAD = 1e-6  # rad: incidence angles spread less than this cannot determine n_pq (held fixed)


@dataclass(frozen=True)
class LogLinearModel(RetrievalModel):
    """``sigma0_pq = l_pq AGB^(a_pq) cos^(n_pq)(theta)`` for (hh, hv, vv).

    ln_l : (3,) ln l_pq (l_pq in m^2/m^2 at 1 t/ha and theta = 0). a : (3,) AGB exponents a_pq.
    n : (3,) cosine powers n_pq. residual_covariance : (3, 3) covariance of the ln-residuals between
    channels (weights of the joint inversion); the identity when unknown.
    Coefficients ``params`` = (ln_l_hh, a_hh, n_hh, ln_l_hv, a_hv, n_hv, ln_l_vv, a_vv, n_vv).
    Covariate of every method: ``incidence_rad`` (local incidence angle, rad; None for theta = 0).
    """

    ln_l: tuple
    a: tuple
    n: tuple
    residual_covariance: np.ndarray = field(default_factory=lambda: np.eye(_N_CH))

    param_names = tuple(f"{name}_{ch}" for ch in CHANNELS for name in ("ln_l", "a", "n"))
    channels = CHANNELS
    default_fit_space = "log"
    params_per_output = 3

    def __post_init__(self):
        for name in ("ln_l", "a", "n"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (_N_CH,) or not np.all(np.isfinite(value)):
                raise PhysicsInputError(f"log-linear model: {name} must be 3 finite numbers (hh, hv, vv), got {value}")
            object.__setattr__(self, name, tuple(float(v) for v in value))
        cov = np.asarray(self.residual_covariance, dtype=float)
        if cov.shape != (_N_CH, _N_CH) or not np.allclose(cov, cov.T) or np.any(np.linalg.eigvalsh(cov) <= 0):
            raise PhysicsInputError("log-linear model: residual_covariance must be a symmetric positive definite 3x3 "
                                    "matrix")
        cov = cov.copy()
        cov.setflags(write=False)
        object.__setattr__(self, "residual_covariance", cov)

    def check_hv_weight(self) -> None:
        """Raise unless the joint inversion gives HV a positive weight (needed to map an HV error)."""
        if not self.channel_weights()[1] > 0:
            raise PhysicsInputError("log-linear model: the joint inversion gives HV no positive weight "
                                    f"(channel weights {self.channel_weights()}); check a_pq and the covariance")

    @classmethod
    def from_linear(cls, l_pq, a_pq, n_pq, residual_covariance=None) -> LogLinearModel:
        """From l_pq in m^2/m^2 (linear), a_pq, n_pq, each (hh, hv, vv)."""
        l_pq = np.asarray(l_pq, dtype=float)
        if np.any(l_pq <= 0):
            raise PhysicsInputError(f"log-linear model: l_pq must be > 0, got {l_pq}")
        cov = np.eye(_N_CH) if residual_covariance is None else residual_covariance
        return cls(tuple(np.log(l_pq)), tuple(a_pq), tuple(n_pq), cov)

    # coefficients --------------------------------------------------------------------------------------
    @property
    def params(self) -> np.ndarray:
        return np.stack([self.ln_l, self.a, self.n], axis=-1).reshape(-1)

    def with_params(self, params) -> LogLinearModel:
        c = np.asarray(params, dtype=float).reshape(_N_CH, 3)
        return replace(self, ln_l=tuple(c[:, 0]), a=tuple(c[:, 1]), n=tuple(c[:, 2]))

    def with_residual_covariance(self, cov) -> LogLinearModel:
        return replace(self, residual_covariance=np.asarray(cov, dtype=float))

    def channel_weights(self, channels=None) -> np.ndarray:
        """c = Sigma_r^-1 a / (a^T Sigma_r^-1 a): weights of ln sigma_pq in the GLS estimate of ln AGB, over the
        ``channels`` used (default all; the others get weight 0)."""
        use = selected_channels(channels)
        a = np.asarray(self.a)[use]
        w = np.linalg.solve(self.residual_covariance[np.ix_(use, use)], a)
        out = np.zeros(_N_CH)
        out[use] = w / float(a @ w)
        return out

    # forward model -------------------------------------------------------------------------------------
    def _coefficients(self, params):
        c = self._params(params)
        c = c.reshape(c.shape[:-1] + (_N_CH, 3))
        return c[..., None, :, 0], c[..., None, :, 1], c[..., None, :, 2]  # (..., 1, 3) each

    @staticmethod
    def _log_cos(agb, incidence_rad):
        if incidence_rad is None:
            return np.zeros(np.shape(agb) + (1,))
        theta = np.asarray(incidence_rad, dtype=float)
        if np.any(np.abs(theta) >= np.pi / 2):
            raise PhysicsInputError("incidence angles must be within (-90, 90) degrees")
        return np.log(np.cos(np.broadcast_to(theta, np.shape(agb))))[..., None]

    def log_sigma(self, agb, params=None, incidence_rad=None):
        """ln sigma_pq, shape (..., n, 3)."""
        ln_l, a, n = self._coefficients(params)
        agb = np.asarray(agb, dtype=float)
        with np.errstate(divide="ignore"):
            ln_agb = np.log(np.clip(agb, 0.0, None))[..., None]
        return ln_l + a * ln_agb + n * self._log_cos(agb, incidence_rad)

    def evaluate(self, agb, params=None, incidence_rad=None, **covariates):
        """sigma_pq = l_pq AGB^(a_pq) cos^(n_pq)(theta), shape (..., n, 3) in (hh, hv, vv)."""
        return np.exp(self.log_sigma(agb, params, incidence_rad))

    def param_jacobian(self, agb, params=None, incidence_rad=None, **covariates):
        """d sigma_pq / d beta, shape (..., n, 3, 9); block-diagonal over channels."""
        s = self.evaluate(agb, params, incidence_rad)
        agb = np.asarray(agb, dtype=float)
        with np.errstate(divide="ignore"):
            ln_agb = np.broadcast_to(np.log(np.clip(agb, 0.0, None))[..., None], s.shape)
        ln_cos = np.broadcast_to(self._log_cos(agb, incidence_rad), s.shape)
        per = np.stack([s, s * np.where(s > 0, ln_agb, 0.0), s * ln_cos], axis=-1)  # (..., n, 3, 3)
        jac = np.zeros(s.shape + (_N_CH * 3,))
        for c in range(_N_CH):
            jac[..., c, 3 * c:3 * c + 3] = per[..., c, :]
        return jac

    def agb_derivative(self, agb, params=None, incidence_rad=None, **covariates):
        """d sigma_pq / d AGB = a_pq sigma_pq / AGB, shape (..., n, 3)."""
        _, a, _ = self._coefficients(params)
        agb = np.asarray(agb, dtype=float)[..., None]
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(agb > 0, a * self.evaluate(agb[..., 0], params, incidence_rad) / np.where(
                agb > 0, agb, 1.0), np.inf)

    def sigma(self, agb, incidence_rad=None, **covariates):
        """sigma_pq at ``agb``: shape agb.shape + (3,)."""
        agb = np.asarray(agb, dtype=float)
        if agb.ndim == 0:
            return self.evaluate(agb[None], incidence_rad=incidence_rad)[0]
        return self.evaluate(agb, incidence_rad=incidence_rad)

    def derivative(self, agb, incidence_rad=None, **covariates):
        agb = np.asarray(agb, dtype=float)
        if agb.ndim == 0:
            return self.agb_derivative(agb[None], incidence_rad=incidence_rad)[0]
        return self.agb_derivative(agb, incidence_rad=incidence_rad)

    def sensitivity(self, agb, incidence_rad=None, **covariates):
        """d ln sigma_pq / d ln AGB = a_pq for every AGB, shape agb.shape + (3,)."""
        return np.broadcast_to(np.asarray(self.a), np.shape(agb) + (_N_CH,)).copy()

    # inversion -------------------------------------------------------------------------------------------
    def invert(self, sigma, agb_max: float | None = None, incidence_rad=None, channels=None,
               **covariates) -> Inversion:
        """Joint GLS inversion of (..., 3) backscatter (hh, hv, vv) to AGB (module docstring), from the
        ``channels`` given (default all three; the others are ignored)."""
        s = np.asarray(sigma, dtype=float)
        if s.shape[-1:] != (_N_CH,):
            raise PhysicsInputError(f"log-linear inversion needs sigma (..., 3) in (hh, hv, vv), got shape {s.shape}")
        use = selected_channels(channels)
        cap = np.inf if agb_max is None else float(agb_max)
        finite = np.all(np.isfinite(s[..., use]), axis=-1)
        usable = np.isfinite(s) & (s > 0) & use
        ln_l, a, n = (np.asarray(v) for v in (self.ln_l, self.a, self.n))
        ln_cos = self._log_cos(s[..., 0], incidence_rad)
        with np.errstate(divide="ignore", invalid="ignore"):
            y = (np.log(np.where(usable, s, 1.0)) - ln_l - n * ln_cos) / 1.0
        ln_agb = np.full(s.shape[:-1], np.nan)
        for mask in product((False, True), repeat=_N_CH):
            mask = np.array(mask)
            if not mask.any():
                continue
            rows = np.all(usable == mask, axis=-1) & finite
            if not np.any(rows):
                continue
            cov = self.residual_covariance[np.ix_(mask, mask)]
            am = a[mask]
            w = np.linalg.solve(cov, am)
            denom = float(am @ w)
            if denom <= 0:
                continue
            ln_agb[rows] = (y[rows][..., mask] @ w) / denom
        none_usable = finite & ~np.any(usable, axis=-1)
        with np.errstate(over="ignore"):
            agb = np.exp(ln_agb)
        status = np.full(s.shape[:-1], INVERTED, dtype=np.int8)
        status[none_usable | (finite & ~np.isfinite(ln_agb))] = BELOW_RANGE
        agb = np.where(status == BELOW_RANGE, 0.0, agb)
        over = (status == INVERTED) & (agb > cap)
        status[over] = SATURATED
        agb = np.where(over, cap, agb)
        status[~finite] = INVALID
        agb = np.where(finite, agb, np.nan)
        sigma_max = float(self.sigma(cap)[1]) if np.isfinite(cap) else np.inf
        return Inversion(agb, status, sigma_max, cap)

    def relative_agb_error(self, agb, sigma_relative_error, agb_max: float | None = None, channel: str = "hv",
                           incidence_rad=None, channels=None, **covariates):
        """Relative AGB error for relative sigma errors x applied to ``channel`` alone (any shape), or with
        ``channel=None`` to all channels (x of shape (..., 3) in hh, hv, vv). Returns (q, Inversion)."""
        agb = float(agb)
        if not agb > 0:
            raise PhysicsInputError(f"relative AGB errors need a true AGB > 0 t/ha, got {agb}")
        x = np.asarray(sigma_relative_error, dtype=float)
        truth = self.sigma(agb, incidence_rad=incidence_rad)
        if channel is None:
            if x.shape[-1:] != (_N_CH,):
                raise PhysicsInputError(f"errors of all channels need shape (..., 3), got {x.shape}")
        else:
            if channel not in CHANNELS:
                raise PhysicsInputError(f"unknown channel {channel!r}; expected one of {CHANNELS}")
            full = np.zeros(x.shape + (_N_CH,))
            full[..., CHANNELS.index(channel)] = x
            x = full
        inv = self.invert(truth * (1.0 + x), agb_max=agb_max, incidence_rad=incidence_rad, channels=channels)
        return inv.agb / agb - 1.0, inv

    # fitting ---------------------------------------------------------------------------------------------
    def fit_batch(self, agb, sigma, p0=None, space=None, weights=None, incidence_rad=None, **covariates):
        """Channel-wise OLS in ln sigma (the SUR estimator with identical regressors); linear space: LM."""
        space = self._space(space)
        agb = np.asarray(agb, dtype=float)
        sigma = np.asarray(sigma, dtype=float)
        if space == "linear":
            if p0 is None:
                p0 = self.fit_batch(agb, np.clip(sigma, 1e-12, None), space="log", incidence_rad=incidence_rad).params
            return super().fit_batch(agb, sigma, p0, space, weights, incidence_rad=incidence_rad)
        if weights is not None:
            raise PhysicsInputError("weighted log-space fits are not supported; use space='linear'")
        design, fixed_n, offset = self._design(agb, incidence_rad)
        usable = np.all(agb > 0, axis=-1) & np.all(sigma > 0, axis=(-2, -1)) & np.all(np.isfinite(sigma),
                                                                                      axis=(-2, -1))
        with np.errstate(divide="ignore", invalid="ignore"):
            y = np.log(np.where(sigma > 0, sigma, np.nan)) - offset
        coef, ssr, ok = ols_batch(np.nan_to_num(design), np.nan_to_num(y))
        ok &= usable
        nb = agb.shape[0]
        params = np.empty((nb, _N_CH, 3))
        params[:, :, 0] = coef[:, 0, :]
        params[:, :, 1] = coef[:, 1, :]
        params[:, :, 2] = np.asarray(self.n) if fixed_n else coef[:, 2, :]
        params = params.reshape(nb, -1)
        start = np.broadcast_to(self.params if p0 is None else p0, params.shape)
        params = np.where(ok[:, None], params, start)
        status = np.where(ok, CONVERGED, BAD_DATA).astype(np.int8)
        return BatchFit(params, status, np.where(ok, ssr.sum(axis=-1), np.inf), np.ones(nb, dtype=np.int32))

    def _design(self, agb, incidence_rad):
        """Design (B, n, k) with columns 1, ln AGB[, ln cos theta]; n_pq is held at the model's value when
        the incidence angles do not vary (returned offset n_pq ln cos theta, (B, n, 3))."""
        with np.errstate(divide="ignore"):
            ln_agb = np.log(np.where(agb > 0, agb, np.nan))
        ones = np.ones_like(ln_agb)
        if incidence_rad is None:
            return np.stack([ones, ln_agb], axis=-1), True, np.zeros(agb.shape + (_N_CH,))
        ln_cos = self._log_cos(agb, incidence_rad)[..., 0]
        if np.all(np.ptp(np.broadcast_to(np.asarray(incidence_rad, float), agb.shape), axis=-1) < _THETA_SPREAD):
            return np.stack([ones, ln_agb], axis=-1), True, ln_cos[..., None] * np.asarray(self.n)
        return np.stack([ones, ln_agb, ln_cos], axis=-1), False, np.zeros(agb.shape + (_N_CH,))

    def fit(self, agb, sigma, p0=None, space=None, weights=None, incidence_rad=None, **covariates) -> FitResult:
        """Joint fit; the fitted model carries the residual covariance, the result the SUR covariance of
        the nine coefficients, ``Sigma_r kron (X^T X)^-1`` (log space)."""
        space = self._space(space)
        agb = np.asarray(agb, dtype=float)
        sigma = np.asarray(sigma, dtype=float)
        if sigma.shape != agb.shape + (_N_CH,):
            raise PhysicsInputError(f"log-linear fit needs sigma of shape (n, 3) for agb (n,), got {sigma.shape}")
        self._check_data(agb, sigma, space)
        theta = None if incidence_rad is None else np.broadcast_to(np.asarray(incidence_rad, float), agb.shape)
        batch = self.fit_batch(agb[None], sigma[None], None if p0 is None else np.asarray(p0)[None], space,
                               None if weights is None else np.asarray(weights)[None],
                               incidence_rad=None if theta is None else theta[None])
        model = self.with_params(batch.params[0])
        resid = self._residuals(model, agb, sigma, space, incidence_rad=theta)
        design, _fixed_n, _ = self._design(agb[None], None if theta is None else theta[None])
        k = design.shape[-1]
        dof = agb.shape[0] - k
        sigma_r = resid.T @ resid / dof  # (3, 3)
        if space == "log":
            model = model.with_residual_covariance(sigma_r)
            xtx_inv = safe_inverse(design[0].T @ design[0])
            cov_k = np.zeros((3, 3))
            cov_k[:k, :k] = xtx_inv  # a fixed n_pq has zero variance
            cov = np.kron(sigma_r, cov_k)
        else:
            cov, _ = self._covariance(model, agb, resid.reshape(-1), space, incidence_rad=theta)
        return FitResult(model, cov, np.diag(sigma_r).copy(), agb.shape[0], dof, space, int(batch.status[0]),
                         int(batch.iterations[0]), resid)

    def _covariance(self, model, agb, resid, space, weights=None, incidence_rad=None, **covariates):
        jac = model.param_jacobian(agb, incidence_rad=incidence_rad).reshape(-1, _N_CH * 3)
        n, p = jac.shape
        s2 = float(np.sum(resid**2) / (n - p))
        return s2 * safe_inverse(jac.T @ jac), s2
