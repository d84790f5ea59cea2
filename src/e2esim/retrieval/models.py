"""The interface every backscatter-AGB retrieval model implements, and what its methods return.

A retrieval model is a forward model ``sigma = f(AGB; beta)`` (backscattering coefficient in m^2/m^2 as a
function of above-ground biomass in t/ha, parameters ``beta``) with

* ``sigma(agb)`` and ``derivative(agb)`` (d sigma / d AGB) for its own parameters, and the vectorised
  ``evaluate(agb, params)``, ``param_jacobian(agb, params)`` (d sigma / d beta, eq. 5 of Ahmed et al.
  2014) and ``agb_derivative(agb, params)`` for any parameter array, which the regression, SIMEX and
  bootstrap code use;
* ``invert(sigma)`` -> ``Inversion``: the AGB estimate with a status per value. A model that saturates
  (Ahmed et al. 2014, eq. 1) has no inverse above the largest backscatter it reaches on its increasing
  branch; such values are reported as *saturated* (AGB +inf, or the cap ``agb_max``), values at or below
  the model's lowest backscatter as *below range* (AGB 0). Nothing is returned as a silent NaN;
* ``fit(agb, sigma)`` -> ``FitResult`` with the covariance of the coefficients, and ``fit_batch`` for
  many data sets at once (the engine of SIMEX and the bootstrap).

Fits in the linear space (additive error in sigma, Ahmed et al. 2014, eq. 2) use the batched
Levenberg-Marquardt solver of ``e2esim.retrieval.fitting``, which fits thousands of small data sets in one
set of numpy operations and reports, per data set, whether it converged. Fits in the log space (multiplicative
error; power law and log-linear model) are ordinary least squares in ln sigma.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.fitting import (  # noqa: F401  (re-exported: the fit statuses belong to the interface)
    BAD_DATA,
    CONVERGED,
    FIT_STATUS_NAMES,
    MAX_ITERATIONS,
    NON_FINITE,
    OUT_OF_DOMAIN,
    STALLED,
    BatchFit,
    bisect_increasing,
    levenberg_marquardt,
    ols_batch,
)

# Inversion status codes ------------------------------------------------------------------------
INVERTED = 0
"""Status: sigma lies on the model's increasing branch; the AGB estimate is finite."""
BELOW_RANGE = 1
"""Status: sigma at or below the smallest backscatter of the model (e.g. sigma <= 0): AGB = lowest AGB (0)."""
SATURATED = 2
"""Status: sigma at or above the largest backscatter the model reaches below ``agb_max``: AGB unbounded."""
INVALID = 3
"""Status: sigma is not a finite number."""
STATUS_NAMES = {INVERTED: "inverted", BELOW_RANGE: "below_range", SATURATED: "saturated", INVALID: "invalid"}

FIT_SPACES = ("linear", "log")


@dataclass(frozen=True)
class Inversion:
    """AGB estimates from backscatter, with a status per value.

    agb : AGB estimate (t/ha), shape of the input sigma (without a channel axis). +inf where saturated
        without a cap, ``agb_max`` where saturated with one; the lowest AGB of the model where below range.
    status : ``INVERTED``, ``BELOW_RANGE``, ``SATURATED`` or ``INVALID`` per value (int8).
    sigma_max : largest backscatter (m^2/m^2) the model reaches on its increasing branch below the cap.
    agb_max : the cap used (t/ha), +inf if none.
    """

    agb: np.ndarray
    status: np.ndarray
    sigma_max: float
    agb_max: float

    @property
    def saturated(self) -> np.ndarray:
        return self.status == SATURATED

    def count(self, status: int) -> int:
        return int(np.count_nonzero(self.status == status))

    @property
    def saturated_fraction(self) -> float:
        return self.count(SATURATED) / max(self.status.size, 1)

    def counts(self) -> dict:
        """Number of values per status name."""
        return {name: self.count(code) for code, name in STATUS_NAMES.items()}


@dataclass(frozen=True)
class FitResult:
    """A fitted retrieval model with the uncertainty of its coefficients.

    model : the model with the fitted coefficients. covariance : (p, p) covariance of the coefficients,
    ``sigma_hat^2 (J^T J)^-1`` (Ahmed et al. 2014, eq. 6, with the residual variance that the printed
    equation omits; Draper & Smith 1998, Section 24.3; docs/errata.md). residual_variance : sigma_hat^2,
    SSR / (n - p), in the fit space ((m^2/m^2)^2 for "linear", dimensionless for "log").
    n : number of points. dof : n - p. space : "linear" or "log". status : fit status code.
    iterations : solver iterations. residuals : (n, ...) data minus fit, in the fit space.
    """

    model: RetrievalModel
    covariance: np.ndarray
    residual_variance: float
    n: int
    dof: int
    space: str
    status: int
    iterations: int
    residuals: np.ndarray

    @property
    def converged(self) -> bool:
        return self.status == CONVERGED

    @property
    def params(self) -> np.ndarray:
        return self.model.params

    @property
    def standard_errors(self) -> np.ndarray:
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))


class RetrievalModel(ABC):
    """Base class of the backscatter-AGB models (module docstring).

    Subclasses are frozen dataclasses whose fields are the coefficients (and fixed hyper-parameters such as
    the exponent alpha of the saturating model). Class attributes:

    param_names : names of the fitted coefficients, in the order of ``params``.
    channels : polarisations of the output ("hv" for single-channel models).
    default_fit_space : "linear" (additive error in sigma) or "log" (multiplicative error).
    """

    param_names: ClassVar[tuple] = ()
    channels: ClassVar[tuple] = ("hv",)
    default_fit_space: ClassVar[str] = "linear"
    params_per_output: ClassVar[int | None] = None  # coefficients per output channel, if fewer than all

    # Coefficients ---------------------------------------------------------------------------------
    @property
    @abstractmethod
    def params(self) -> np.ndarray:
        """The coefficients as a float array of shape (p,)."""

    @abstractmethod
    def with_params(self, params) -> RetrievalModel:
        """A copy with other coefficients (same fixed hyper-parameters)."""

    def params_valid(self, params) -> np.ndarray:
        """Whether coefficient vectors (..., p) lie in the model's domain (default: all finite)."""
        return np.all(np.isfinite(params), axis=-1)

    def to_working(self, params) -> np.ndarray:
        """Coefficients (..., p) in the parameterisation SIMEX averages and extrapolates (default: the
        coefficients themselves); a model whose coefficients are strongly non-linear functions of the
        regression's natural ones (the power law's A = exp(-c0/c1)) overrides it."""
        return np.asarray(params, dtype=float)

    def from_working(self, working) -> np.ndarray:
        """Inverse of ``to_working``."""
        return np.asarray(working, dtype=float)

    def _params(self, params):
        return self.params if params is None else np.asarray(params, dtype=float)

    # Vectorised forward model ----------------------------------------------------------------------
    @abstractmethod
    def evaluate(self, agb, params=None, **covariates) -> np.ndarray:
        """sigma (m^2/m^2) at ``agb`` (t/ha). ``params`` (..., p) broadcasts against ``agb`` (..., n)
        as ``params[..., None, :]``; None uses the model's own coefficients."""

    @abstractmethod
    def param_jacobian(self, agb, params=None, **covariates) -> np.ndarray:
        """d sigma / d beta, shape (..., n, p) (Ahmed et al. 2014, eq. 5)."""

    @abstractmethod
    def agb_derivative(self, agb, params=None, **covariates) -> np.ndarray:
        """d sigma / d AGB ((m^2/m^2) per t/ha), shape of ``evaluate``."""

    def initial_guess(self, agb, sigma, **covariates) -> np.ndarray:
        """Starting coefficients for a fit of data (..., n): by default the model's own, broadcast."""
        shape = np.shape(agb)[:-1]
        return np.broadcast_to(self.params, shape + self.params.shape).copy()

    # Convenience for the model's own coefficients ------------------------------------------------------
    def sigma(self, agb, **covariates) -> np.ndarray:
        """sigma (m^2/m^2) at ``agb`` (t/ha), any shape."""
        agb = np.asarray(agb, dtype=float)
        return self.evaluate(agb[..., None], **covariates)[..., 0] if agb.ndim == 0 else self.evaluate(
            agb, **covariates)

    def derivative(self, agb, **covariates) -> np.ndarray:
        """d sigma / d AGB at ``agb`` (t/ha)."""
        agb = np.asarray(agb, dtype=float)
        if agb.ndim == 0:
            return self.agb_derivative(agb[..., None], **covariates)[..., 0]
        return self.agb_derivative(agb, **covariates)

    def sensitivity(self, agb, **covariates) -> np.ndarray:
        """d ln sigma / d ln AGB: the relative backscatter change per relative AGB change.

        Its reciprocal is the local power-law exponent p: a small relative sigma error x gives a relative
        AGB error of about x / sensitivity (Men et al. 2021, eq. 16 linearised).
        """
        agb = np.asarray(agb, dtype=float)
        return agb * self.derivative(agb, **covariates) / self.sigma(agb, **covariates)

    # Inversion ------------------------------------------------------------------------------------------
    @abstractmethod
    def invert(self, sigma, agb_max: float | None = None, **covariates) -> Inversion:
        """AGB from sigma, saturation explicit (``Inversion``). ``agb_max`` (t/ha) caps the estimate:
        backscatter the model reaches only above it counts as saturated and is given AGB = agb_max."""

    def relative_agb_error(self, agb, sigma_relative_error, agb_max: float | None = None, **covariates):
        """Relative AGB error ``q = AGB_hat / AGB - 1`` for a relative sigma error x at true ``agb``.

        ``sigma_hat = sigma(agb) (1 + x)`` is inverted with ``invert``; returns ``(q, Inversion)``. q is
        +inf where the estimate saturates without a cap (an unbounded overestimate), and
        ``agb_max / agb - 1`` where it saturates with one.
        """
        agb = float(agb)
        if not agb > 0:
            raise PhysicsInputError(f"relative AGB errors need a true AGB > 0 t/ha, got {agb}")
        x = np.asarray(sigma_relative_error, dtype=float)
        inv = self.invert(self.sigma(agb, **covariates) * (1.0 + x), agb_max=agb_max, **covariates)
        return inv.agb / agb - 1.0, inv

    # Fitting --------------------------------------------------------------------------------------------
    def fit(self, agb, sigma, p0=None, space: str | None = None, weights=None, **covariates) -> FitResult:
        """Least-squares fit to field data; the model's own coefficients are the default start.

        agb : (n,) field AGB (t/ha). sigma : (n,) or (n, channels) backscatter (m^2/m^2).
        space : "linear" (additive error, Ahmed et al. 2014 eq. 2) or "log"; None: ``default_fit_space``.
        weights : optional (n,) weights of the squared residuals (e.g. 1 / error variance).
        Raises ``PhysicsInputError`` for unusable data; a fit that does not converge is returned with its
        status (``FitResult.converged`` False), never silently.
        """
        space = self._space(space)
        agb = np.asarray(agb, dtype=float)
        sigma = np.asarray(sigma, dtype=float)
        self._check_data(agb, sigma, space)
        batch = self.fit_batch(agb[None], sigma[None], None if p0 is None else np.asarray(p0, float)[None],
                               space, None if weights is None else np.asarray(weights, float)[None],
                               **{k: None if v is None else np.asarray(v)[None] for k, v in covariates.items()})
        params = batch.params[0]
        model = self.with_params(params)
        n, p = agb.shape[0], params.shape[0]
        resid = self._residuals(model, agb, sigma, space, **covariates)
        cov, s2 = self._covariance(model, agb, resid, space, weights, **covariates)
        return FitResult(model, cov, s2, n, n - p, space, int(batch.status[0]), int(batch.iterations[0]), resid)

    def fit_batch(self, agb, sigma, p0=None, space: str | None = None, weights=None, **covariates) -> BatchFit:
        """Fit B data sets at once: agb (B, n), sigma (B, n[, channels]); p0 (B, p) or None.

        The default implementation runs the batched Levenberg-Marquardt solver in the linear space;
        models with a closed-form log-space fit override it for ``space="log"``.
        """
        space = self._space(space)
        if space != "linear":
            raise PhysicsInputError(f"{type(self).__name__} fits only in the linear space, not {space!r}")
        agb = np.asarray(agb, dtype=float)
        sigma = np.asarray(sigma, dtype=float)
        if p0 is None:
            p0 = self.initial_guess(agb, sigma, **covariates)
        fun, jac = self._batch_functions(agb, covariates)
        return levenberg_marquardt(
            fun,
            jac,
            sigma,
            np.asarray(p0, dtype=float),
            valid=self.params_valid,
            weights=weights,
            bad=~np.all(np.isfinite(agb), axis=-1) | ~np.all(np.isfinite(sigma.reshape(sigma.shape[0], -1)), axis=-1),
        )

    # helpers --------------------------------------------------------------------------------------------
    def _batch_functions(self, agb, covariates):
        """(fun(p, idx), jac(p, idx)) of the batched solver for data sets ``idx`` of ``agb`` (B, n). Models
        may override it to cache what depends on the AGB alone."""
        return (lambda p, idx: self.evaluate(agb[idx], p, **_take(covariates, idx)),
                lambda p, idx: self.param_jacobian(agb[idx], p, **_take(covariates, idx)))

    def _space(self, space):
        space = self.default_fit_space if space is None else space
        if space not in FIT_SPACES:
            raise PhysicsInputError(f"fit space must be one of {FIT_SPACES}, got {space!r}")
        return space

    def _check_data(self, agb, sigma, space):
        if agb.ndim != 1 or sigma.shape[0] != agb.shape[0]:
            raise PhysicsInputError(
                f"field data must be agb (n,) and sigma (n,) or (n, channels); got {agb.shape} and {sigma.shape}")
        p = self.params_per_output or self.params.shape[0]
        if agb.shape[0] <= p:
            raise PhysicsInputError(f"{type(self).__name__} has {p} coefficients and needs more than {p} plots, "
                                    f"got {agb.shape[0]}")
        if not (np.all(np.isfinite(agb)) and np.all(np.isfinite(sigma))):
            raise PhysicsInputError("field data contain NaN or infinite values")
        if np.any(agb < 0):
            raise PhysicsInputError(f"field AGB must be >= 0 t/ha; smallest value {agb.min():g}")
        if space == "log" and (np.any(agb <= 0) or np.any(sigma <= 0)):
            raise PhysicsInputError("a log-space fit needs AGB > 0 and sigma > 0 for every plot")

    def _residuals(self, model, agb, sigma, space, **covariates):
        fit = model.evaluate(agb, **covariates)
        return np.log(sigma) - np.log(fit) if space == "log" else sigma - fit

    def _covariance(self, model, agb, resid, space, weights=None, **covariates):
        """sigma_hat^2 (J^T W J)^-1 in the model's coefficients (Ahmed et al. 2014, eq. 6 with sigma_hat^2)."""
        jac = model.param_jacobian(agb, **covariates)  # (n, p)
        if space == "log":
            jac = jac / model.evaluate(agb, **covariates)[..., None]  # d ln sigma / d beta
        w = np.ones(agb.shape[0]) if weights is None else np.asarray(weights, dtype=float)
        n, p = jac.shape[0], jac.shape[-1]
        s2 = float(np.sum(w * resid**2) / (n - p))
        info = jac.T @ (w[:, None] * jac)
        return s2 * safe_inverse(info), s2


def _take(covariates: dict, idx) -> dict:
    return {k: (None if v is None else np.asarray(v)[idx]) for k, v in covariates.items()}


def safe_inverse(matrix: np.ndarray) -> np.ndarray:
    """Inverse of a symmetric positive (semi-)definite matrix; +inf variances where it is singular."""
    try:
        inv = np.linalg.inv(matrix)
    except np.linalg.LinAlgError:
        return np.full(matrix.shape, np.inf)
    return 0.5 * (inv + np.swapaxes(inv, -1, -2))


@dataclass(frozen=True)
class Branch:
    """The increasing branch of a model used for inversion: AGB in [agb_low, agb_high], sigma in
    [sigma_low, sigma_high]. ``agb_high`` is +inf for a model increasing without bound."""

    agb_low: float
    agb_high: float
    sigma_low: float
    sigma_high: float
    notes: tuple = field(default_factory=tuple)
