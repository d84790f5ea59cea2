"""Synthetic field-plot data with known truth, for testing the regression, SIMEX and bootstrap code.

The Harvard and Howland data of Ahmed et al. (2014) are not public, so the tests and the figures of
docs/theory/retrieval.md use plots drawn from a known model, with the error structure of the paper:

* true AGB x_i of n plots (uniform or log-uniform over a range, or stratified: one plot drawn uniformly in
  each of n equal parts of the range, the design of a calibration campaign that spans its range);
* field AGB with allometric error, ``W_i = x_i + u_i``, ``u_i ~ N(0, sigma_ui^2)`` (eq. 9), sigma_ui a
  fraction of x_i (Ahmed et al. 2013 report allometric errors of a few to tens of percent);
* backscatter of the plot ``y_i = f(beta, x_i) + eps_i`` with error in equation ``eps_i ~ N(0, sigma^2)``
  (eq. 2), and its measurement ``D_i = y_i + q_i``, ``q_i ~ N(0, sigma_qi^2)`` (eq. 8), sigma_qi a
  fraction of y_i (e.g. the relative SD of the backscatter error budget at the plot's scale).

For the multi-channel log-linear model the error in equation is multiplicative (Gaussian in ln sigma with
the model's residual covariance) and each channel gets its own measurement error. Negative field AGB
draws are set to 0 and counted (``n_clipped``): the models are defined for AGB >= 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.models import RetrievalModel

AGB_DISTRIBUTIONS = ("uniform", "loguniform", "stratified")


@dataclass(frozen=True)
class FieldPlots:
    """Synthetic field plots; leading axes (...) are independent data sets, the last one the n plots.

    agb_true : true AGB x (t/ha). agb : field AGB W with allometric error (t/ha). agb_error_sd : sigma_u
    per plot (t/ha). sigma_true : backscatter of the plot y = f(x) + eps (m^2/m^2; (..., n, 3) for a
    multi-channel model). sigma : measured backscatter D = y + q. sigma_error_sd : sigma_q per plot.
    model_error_sd : SD of the error in equation (m^2/m^2; ln units for the log-linear model).
    model : the true model. incidence_rad : local incidence angle per plot (rad), or None.
    n_clipped : field AGB draws below 0 set to 0.
    """

    agb_true: np.ndarray
    agb: np.ndarray
    agb_error_sd: np.ndarray
    sigma_true: np.ndarray
    sigma: np.ndarray
    sigma_error_sd: np.ndarray
    model_error_sd: float
    model: RetrievalModel
    incidence_rad: np.ndarray | None
    n_clipped: int

    @property
    def n_plots(self) -> int:
        return self.agb.shape[-1]

    def dataset(self, i: int) -> FieldPlots:
        """Data set i of a batch."""
        take = lambda a: None if a is None else a[i]
        return FieldPlots(self.agb_true[i], self.agb[i], self.agb_error_sd[i], self.sigma_true[i], self.sigma[i],
                          self.sigma_error_sd[i], self.model_error_sd, self.model, take(self.incidence_rad),
                          int(np.count_nonzero((self.agb[i] == 0) & (self.agb_true[i] > 0))))


def synthetic_field_plots(
    model: RetrievalModel,
    n_plots: int,
    rng: np.random.Generator,
    n_datasets: int | None = None,
    agb_range_t_ha: tuple = (5.0, 350.0),
    agb_distribution: str = "uniform",
    allometric_error: float = 0.10,
    backscatter_error: float = 0.05,
    model_error_sd: float = 0.0,
    incidence_range_rad: tuple | None = None,
    model_error: float | None = None,
) -> FieldPlots:
    """Draw field plots from ``model`` (module docstring). ``n_datasets`` adds a leading axis.

    allometric_error : sigma_u as a fraction of the true AGB. backscatter_error :
    sigma_q as a fraction of the plot's backscatter y. model_error_sd : SD of the error in equation
    (m^2/m^2 for single-channel models; for the log-linear model the ln residuals are drawn from its
    ``residual_covariance`` scaled so that the HV SD is model_error_sd, or not at all if 0).
    incidence_range_rad : (low, high) local incidence angles (rad) drawn uniformly, or None (theta = 0).
    model_error : instead of model_error_sd, the error in equation as a fraction of f(x)
    (single-channel) or the SD of ln sigma (log-linear HV channel).
    """
    if n_plots < 2:
        raise PhysicsInputError(f"need at least 2 plots, got {n_plots}")
    lo, hi = (float(v) for v in agb_range_t_ha)
    if not 0 <= lo < hi:
        raise PhysicsInputError(f"agb_range_t_ha must be (low, high) with 0 <= low < high, got {agb_range_t_ha}")
    if agb_distribution not in AGB_DISTRIBUTIONS:
        raise PhysicsInputError(f"agb_distribution must be one of {AGB_DISTRIBUTIONS}, got {agb_distribution!r}")
    for name, value in (("allometric_error", allometric_error),
                        ("backscatter_error", backscatter_error), ("model_error_sd", model_error_sd)):
        if not value >= 0:
            raise PhysicsInputError(f"{name} must be >= 0, got {value}")
    shape = (n_plots,) if n_datasets is None else (n_datasets, n_plots)
    if agb_distribution == "uniform":
        x = rng.uniform(lo, hi, shape)
    elif agb_distribution == "stratified":
        x = lo + (np.arange(n_plots) + rng.uniform(0.0, 1.0, shape)) * ((hi - lo) / n_plots)
    else:
        if lo <= 0:
            raise PhysicsInputError("a log-uniform AGB distribution needs a lower bound > 0")
        x = np.exp(rng.uniform(np.log(lo), np.log(hi), shape))
    theta = None
    if incidence_range_rad is not None:
        theta = rng.uniform(incidence_range_rad[0], incidence_range_rad[1], shape)
    su = allometric_error * x
    w = x + su * rng.standard_normal(shape)
    n_clipped = int(np.count_nonzero(w < 0))
    w = np.clip(w, 0.0, None)
    cov = {} if theta is None else {"incidence_rad": theta}
    f = model.evaluate(x, **cov)
    if model_error is not None:
        if not model_error >= 0:
            raise PhysicsInputError(f"model_error must be >= 0, got {model_error}")
    if f.ndim == x.ndim + 1:  # multi-channel: multiplicative error in equation
        if model_error is not None:
            model_error_sd = model_error
        if model_error_sd > 0:
            rc = np.asarray(model.residual_covariance)
            chol = np.linalg.cholesky(rc * model_error_sd**2 / rc[1, 1])
            y = f * np.exp(rng.standard_normal(f.shape) @ chol.T)
        else:
            y = f
    elif model_error is not None:
        y = f * (1.0 + model_error * rng.standard_normal(shape))
    else:
        y = f + model_error_sd * rng.standard_normal(shape)
    sq = backscatter_error * np.abs(y)
    d = y + sq * rng.standard_normal(y.shape)
    return FieldPlots(x, w, su, y, d, sq, float(model_error_sd), model, theta, n_clipped)
