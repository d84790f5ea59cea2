"""Power-law relation between AGB and sigma_hv, Men et al. (2021), eqs. (15)-(16).

``B = A sigma_hv^p`` (eq. 15); a relative AGB error q corresponds to a relative sigma_hv error
``(1 + q)^(1/p) - 1`` (eq. 16). Exponents from Schlund et al. (2018) as quoted in Men et al. (2021),
Section III-D: p = 2.2 for boreal and 1.9 for tropical forest.

``PowerLaw`` implements the retrieval-model interface (``e2esim.retrieval.models``): forward model
``sigma = (AGB / A)^(1/p)``, inversion ``AGB = A sigma^p`` (no saturation: the law increases without
bound; sigma <= 0 is below range), and fits by least squares in ln sigma (the usual way, a straight line
in log-log axes) or in sigma.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.models import (
    BAD_DATA,
    BELOW_RANGE,
    CONVERGED,
    INVALID,
    INVERTED,
    OUT_OF_DOMAIN,
    SATURATED,
    BatchFit,
    Inversion,
    RetrievalModel,
    ols_batch,
)
from e2esim.scene.biome_power_laws import BIOME_EXPONENTS as SCENE_EXPONENTS

# The truth's exponents by biome (e2esim.scene.biome_power_laws): the estimator assumes them unless given its own.
BIOME_EXPONENTS = SCENE_EXPONENTS


def sigma_relative_error(agb_relative_error, exponent):
    """Relative sigma_hv error giving relative AGB error q: ``(1 + q)^(1/p) - 1``, eq. (16).

    agb_relative_error : q (dimensionless, > -1), any shape. exponent : p > 0.
    """
    q = np.asarray(agb_relative_error, dtype=float)
    if np.any(q <= -1):
        raise PhysicsInputError("a relative AGB error must be > -1 (AGB estimate > 0)")
    return (1.0 + q) ** (1.0 / exponent) - 1.0


def agb_relative_error(sigma_relative, exponent):
    """Relative AGB error from a relative sigma_hv error x: ``q = (1 + x)^p - 1`` (inverse of eq. 16),
    computed as ``expm1(p log1p(x))``: exact to rounding also for small x, where ``(1 + x)^p - 1`` loses digits.

    A sigma_hv estimate at or below zero (x <= -1, possible in the tails of a Gaussian model of the
    error, never in the simulated power) means an AGB estimate of zero: q = -1.
    """
    x = np.asarray(sigma_relative, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.expm1(exponent * np.log1p(x))
    return np.where(x > -1.0, q, -1.0)


@dataclass(frozen=True)
class PowerLaw(RetrievalModel):
    """``AGB = coefficient * sigma^exponent`` (eq. 15); AGB in t/ha, sigma in m^2/m^2 (linear).

    Coefficients ``params = (coefficient A, exponent p)``, A > 0, p > 0.
    """

    coefficient: float
    exponent: float

    param_names = ("coefficient", "exponent")
    default_fit_space = "log"

    def __post_init__(self):
        if not (self.coefficient > 0 and self.exponent > 0):
            raise PhysicsInputError(
                f"power law needs coefficient > 0 and exponent > 0, got {self.coefficient} and {self.exponent}")

    # interface ------------------------------------------------------------------------------------
    @property
    def params(self) -> np.ndarray:
        return np.array([self.coefficient, self.exponent], dtype=float)

    def with_params(self, params) -> PowerLaw:
        a, p = np.asarray(params, dtype=float)
        return PowerLaw(float(a), float(p))

    def params_valid(self, params) -> np.ndarray:
        params = np.asarray(params, dtype=float)
        return np.all(np.isfinite(params), axis=-1) & (params[..., 0] > 0) & (params[..., 1] > 0)

    def to_working(self, params) -> np.ndarray:
        """(intercept c0 = -ln(A)/p, slope c1 = 1/p) of the log-log line ln sigma = c0 + c1 ln AGB."""
        params = np.asarray(params, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.stack([-np.log(params[..., 0]) / params[..., 1], 1.0 / params[..., 1]], axis=-1)

    def from_working(self, working) -> np.ndarray:
        w = np.asarray(working, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return np.stack([np.exp(-w[..., 0] / w[..., 1]), 1.0 / w[..., 1]], axis=-1)

    @classmethod
    def through(cls, agb, sigma, exponent) -> PowerLaw:
        """The power law of exponent p through the point (agb t/ha, sigma m^2/m^2): A = agb / sigma^p."""
        if not (agb > 0 and sigma > 0):
            raise PhysicsInputError(f"a power law through (AGB, sigma) needs both > 0, got ({agb}, {sigma})")
        return cls(float(agb / sigma**exponent), float(exponent))

    def evaluate(self, agb, params=None, **covariates):
        """sigma = (AGB / A)^(1/p), the inverse of eq. (15)."""
        a, p = _split(self._params(params))
        return (np.clip(np.asarray(agb, dtype=float), 0.0, None) / a) ** (1.0 / p)

    def param_jacobian(self, agb, params=None, **covariates):
        """d sigma / d(A, p) = (-sigma / (p A), -sigma ln(AGB / A) / p^2), shape (..., n, 2)."""
        a, p = _split(self._params(params))
        agb = np.asarray(agb, dtype=float)
        s = self.evaluate(agb, params)
        with np.errstate(divide="ignore", invalid="ignore"):
            log_ratio = np.where(agb > 0, np.log(np.where(agb > 0, agb, 1.0) / a), 0.0)
        return np.stack(np.broadcast_arrays(-s / (p * a), -s * log_ratio / p**2), axis=-1)

    def agb_derivative(self, agb, params=None, **covariates):
        """d sigma / d AGB = sigma / (p AGB) (infinite at AGB = 0 for p > 1)."""
        _, p = _split(self._params(params))
        agb = np.asarray(agb, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(agb > 0, self.evaluate(agb, params) / (p * np.where(agb > 0, agb, 1.0)), np.inf)

    def initial_guess(self, agb, sigma, **covariates):
        coef, ok = _log_ols(np.asarray(agb, float), np.asarray(sigma, float))
        own = np.broadcast_to(self.params, coef.shape)
        return np.where((ok & self.params_valid(coef))[..., None], coef, own)

    def invert(self, sigma, agb_max: float | None = None, **covariates) -> Inversion:
        """AGB = A sigma^p (eq. 15). sigma <= 0: below range (AGB 0); AGB above ``agb_max``: saturated."""
        s = np.asarray(sigma, dtype=float)
        cap = np.inf if agb_max is None else float(agb_max)
        finite = np.isfinite(s)
        positive = finite & (s > 0)
        with np.errstate(over="ignore"):
            agb = np.where(positive, self.coefficient * np.where(positive, s, 1.0) ** self.exponent, 0.0)
        status = np.where(positive, INVERTED, BELOW_RANGE).astype(np.int8)
        over = positive & (agb > cap)
        agb = np.where(over, cap, agb)
        status = np.where(over, SATURATED, status)
        status = np.where(finite, status, INVALID).astype(np.int8)
        agb = np.where(finite, agb, np.nan)
        sigma_max = float(self.sigma(cap)) if np.isfinite(cap) else np.inf
        return Inversion(agb, status, sigma_max, cap)

    def relative_agb_error(self, agb, sigma_relative_error, agb_max: float | None = None, **covariates):
        """q = (1 + x)^p - 1 (inverse of eq. 16), independent of A and of the AGB level without a cap."""
        if agb_max is None or not np.isfinite(agb_max):
            x = np.asarray(sigma_relative_error, dtype=float)
            q = agb_relative_error(x, self.exponent)
            status = np.where(np.isfinite(x), np.where(1 + x > 0, INVERTED, BELOW_RANGE), INVALID).astype(np.int8)
            return q, Inversion(float(agb) * (1 + q), status, np.inf, np.inf)
        return super().relative_agb_error(agb, sigma_relative_error, agb_max, **covariates)

    def fit_batch(self, agb, sigma, p0=None, space=None, weights=None, **covariates) -> BatchFit:
        """Log space: ln sigma = -ln(A)/p + (1/p) ln AGB by ordinary least squares; linear: Levenberg-Marquardt."""
        space = self._space(space)
        agb = np.asarray(agb, dtype=float)
        sigma = np.asarray(sigma, dtype=float)
        if space == "linear":
            return super().fit_batch(agb, sigma, p0, space, weights, **covariates)
        if weights is not None:
            raise PhysicsInputError("weighted log-space power-law fits are not supported; use space='linear'")
        coef, ok = _log_ols(agb, sigma)
        valid = self.params_valid(coef)
        status = np.where(ok, np.where(valid, CONVERGED, OUT_OF_DOMAIN), BAD_DATA).astype(np.int8)
        start = self.params if p0 is None else p0
        params = np.where((status == CONVERGED)[:, None], coef, np.broadcast_to(start, coef.shape))
        with np.errstate(invalid="ignore", divide="ignore"):
            resid = np.log(sigma) - np.log(self.evaluate(agb, params))
        ssr = np.where(status == CONVERGED, np.sum(resid**2, axis=-1), np.inf)
        return BatchFit(params, status, ssr, np.ones(agb.shape[0], dtype=np.int32))

    # historical names -------------------------------------------------------------------------------
    def agb(self, sigma):
        """AGB (t/ha) from sigma_hv (m^2/m^2); sigma <= 0 gives 0 (see ``invert`` for the status)."""
        return self.coefficient * np.clip(np.asarray(sigma, dtype=float), 0.0, None) ** self.exponent

    def sigma(self, agb, **covariates):
        """sigma_hv (m^2/m^2) for an AGB (t/ha)."""
        return (np.asarray(agb, dtype=float) / self.coefficient) ** (1.0 / self.exponent)


def _split(params):
    params = np.asarray(params, dtype=float)
    return params[..., None, 0], params[..., None, 1]


def _log_ols(agb, sigma):
    """Batched fit of ln sigma = c0 + c1 ln AGB; returns (A, p) coefficients (..., 2) and an ok mask."""
    agb2 = np.atleast_2d(agb)
    sig2 = np.atleast_2d(sigma)
    usable = np.all(agb2 > 0, axis=-1) & np.all(sig2 > 0, axis=-1) & np.all(np.isfinite(agb2), axis=-1) & np.all(
        np.isfinite(sig2), axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.log(np.where(agb2 > 0, agb2, np.nan))
        y = np.log(np.where(sig2 > 0, sig2, np.nan))
    design = np.stack([np.ones_like(x), x], axis=-1)
    coef, _, ok = ols_batch(np.nan_to_num(design), np.nan_to_num(y))
    ok &= usable
    c0, c1 = coef[:, 0], coef[:, 1]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        p = 1.0 / c1
        a = np.exp(-c0 / c1)
    out = np.stack([a, p], axis=-1)
    if np.ndim(agb) == 1:
        return out[0], ok[0]
    return out, ok
