"""Parametric (two-stage) bootstrap of the coefficient covariance under measurement error.

Ahmed, Siqueira & Hensley (2014), Section II-C-1, eqs. (11)-(16), after Buonaccorsi (2010): B data sets
are simulated from the corrected model (coefficients beta_c, from SIMEX) with the measurement errors and
the error in equation, each is refitted, and the sample covariance of the refitted coefficients is the
covariance Sigma_beta of eqs. (3)-(7):

    W_bi = W_i + u_bi,                 u_bi ~ N(0, sigma_ui^2)               (11)
    Y_bi = f(beta_c, X_bi) + eps_bi,   eps_bi ~ N(0, sigma_hat^2)            (12)
    D_bi = Y_bi + q_bi,                q_bi ~ N(0, sigma_qi^2)               (13)

with sigma_hat^2 the error in equation estimated by eq. (14) (``regression.model_error_variance``).

Two designs (``design``):

* ``"paper"``: eq. (12) as printed, ``X_bi = W_bi``: the response is generated at the very predictor
  values the refit sees, so the bootstrap data carry no predictor measurement error at all, and the
  spread it adds to the coefficients (and the attenuation) is missed;
* ``"conditional"`` (default): the field values W_i play the true AGB of the bootstrap world,
  ``X_bi = W_i``, and W_bi = W_i + u_bi is its error-prone measurement -- the data-generating process of
  eqs. (8)-(10) with beta_c as the truth (Buonaccorsi 2010, Section 6.16; Carroll et al. 2006, A.9).

Each bootstrap data set is refitted with the same estimator as the data (``refit="simex"``: SIMEX with
``simex_options``) or with the naive fit (``refit="naive"``, cheaper; the bootstrap distribution is
then that of the naive estimator around beta_c, and ``coefficient_intervals(method="basic")`` uses it
to correct the bias). tests/test_retrieval_bootstrap.py measures the coverage of each combination on
synthetic data with known truth; docs/errata.md has the result.

Non-converging refits are counted by failure mode and left out of the covariance; the result reports
their fraction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.models import RetrievalModel
from e2esim.retrieval.regression import (
    Band,
    ModelErrorEstimate,
    critical_value,
    delta_method_band,
    model_error_variance,
)
from e2esim.retrieval.simex import DEFAULT_LAMBDAS, simex_batch

DESIGNS = ("conditional", "paper")
REFITS = ("naive", "simex")
BAND_METHODS = ("delta", "percentile")
INTERVAL_METHODS = ("normal", "percentile", "basic")


@dataclass(frozen=True)
class BootstrapResult:
    """B bootstrap refits around the corrected model.

    model : the model with the centre coefficients beta_c. estimate : (p,) the estimate the intervals
    are centred on (beta_c, or the naive estimate for ``refit="naive"`` basic intervals).
    samples : (B, p) refitted coefficients (the start values where a refit failed). status : (B,) True
    where the refit converged. covariance : (p, p) sample covariance of the converged refits (Sigma_beta).
    model_error : eq. (14) estimate (its ``variance`` is sigma_hat^2). design, refit : as chosen.
    failure_modes : counts of failed refits by mode. space : fit space.
    """

    model: RetrievalModel
    estimate: np.ndarray
    samples: np.ndarray
    status: np.ndarray
    covariance: np.ndarray
    model_error: ModelErrorEstimate
    design: str
    refit: str
    failure_modes: dict
    space: str

    @property
    def n_boot(self) -> int:
        return int(self.status.size)

    @property
    def n_failed(self) -> int:
        return int(np.count_nonzero(~self.status))

    @property
    def failure_fraction(self) -> float:
        return self.n_failed / max(self.n_boot, 1)

    @property
    def converged_samples(self) -> np.ndarray:
        return self.samples[self.status]

    def coefficient_intervals(self, level: float = 0.95, method: str = "normal"):
        """(lower, upper) of each coefficient.

        "normal": estimate +- z sd (the paper's use of Sigma_beta); "percentile": quantiles of the refits;
        "basic": ``estimate - (quantile - beta_c)``, the pivot that also removes the estimator's bias
        (use with ``refit="naive"`` and the naive estimate as ``estimate``).
        """
        if method not in INTERVAL_METHODS:
            raise PhysicsInputError(f"interval method must be one of {INTERVAL_METHODS}, got {method!r}")
        z = critical_value(level)
        s = self.converged_samples
        if method == "normal":
            sd = np.sqrt(np.diag(self.covariance))
            return self.estimate - z * sd, self.estimate + z * sd
        lo_q, hi_q = np.quantile(s, [0.5 - level / 2, 0.5 + level / 2], axis=0)
        if method == "percentile":
            return lo_q, hi_q
        centre = self.model.params
        return self.estimate - (hi_q - centre), self.estimate - (lo_q - centre)

    def curve_spread(self, agb, robust: bool = True, **covariates) -> np.ndarray:
        """Spread of the bootstrap curves f(beta_b, M) relative to f(beta_c, M) at AGB values ``agb``.

        robust : half the 16-84 % range (the SD for a Gaussian spread), insensitive to the few degenerate
        refits that can dominate the sample covariance of a poorly identified model; otherwise the SD.
        """
        agb = np.atleast_1d(np.asarray(agb, dtype=float))
        curves = self.model.evaluate(agb, self.converged_samples, **covariates)
        centre = self.model.evaluate(agb, **covariates)
        if curves.ndim == 3:
            curves, centre = curves[..., 1], centre[..., 1]
        rel = curves / centre
        if robust:
            lo, hi = np.quantile(rel, [0.15865525393145707, 0.8413447460685429], axis=0)
            return (hi - lo) / 2.0
        return rel.std(axis=0, ddof=1)

    def band(self, agb, level: float = 0.95, method: str = "delta", critical: str = "normal",
             **covariates) -> Band:
        """Measurement-error-corrected confidence and prediction bands (Fig. 17 of the paper).

        "delta": eqs. (3), (4), (7) with the bootstrap Sigma_beta and the eq. (14) model error;
        "percentile": quantiles of f(beta_b, M) over the converged refits, shifted to be centred on
        f(beta_c, M), the prediction band widened by the model error in quadrature.
        """
        if method not in BAND_METHODS:
            raise PhysicsInputError(f"band method must be one of {BAND_METHODS}, got {method!r}")
        s2 = self.model_error.variance
        band = delta_method_band(self.model, self.covariance, agb, s2 if self.space == "linear" else 0.0, level,
                                 self.space, critical, None, **covariates)
        if method == "delta":
            return band
        curves = self.model.evaluate(np.asarray(agb, float), self.converged_samples, **covariates)  # (B', m)
        if curves.ndim == 3:
            curves = curves[..., 1]
        centre = self.model.evaluate(np.asarray(agb, float), **covariates)
        if centre.ndim == 2:
            centre = centre[..., 1]
        lo_q, hi_q = np.quantile(curves - curves.mean(axis=0), [0.5 - level / 2, 0.5 + level / 2], axis=0)
        half = band.z * np.sqrt(s2)
        conf_lo, conf_hi = centre + lo_q, centre + hi_q
        pred_lo = centre - np.sqrt(lo_q**2 + half**2)
        pred_hi = centre + np.sqrt(hi_q**2 + half**2)
        return Band(band.agb, centre, band.se_fit, float(np.sqrt(s2)), conf_lo, conf_hi, pred_lo, pred_hi, level,
                    band.z, self.space, self.model, band.channel)


def parametric_bootstrap(
    model: RetrievalModel,
    agb,
    sigma,
    agb_error_sd,
    sigma_error_sd,
    rng: np.random.Generator,
    n_boot: int = 1000,
    model_error: ModelErrorEstimate | float | None = None,
    design: str = "conditional",
    refit: str = "naive",
    estimate=None,
    simex_options: dict | None = None,
    space: str | None = None,
    chunk: int = 250,
    progress=None,
    denominator: str = "n-p",
    **covariates,
) -> BootstrapResult:
    """Bootstrap of eqs. (11)-(13) around ``model`` (its coefficients are beta_c, e.g. SIMEX-corrected).

    agb, sigma : (n,) field data W and D. agb_error_sd, sigma_error_sd : sigma_ui and sigma_qi.
    model_error : sigma_hat^2 as a number, an ``ModelErrorEstimate``, or None for eq. (14) from the data.
    estimate : centre of the "normal"/"basic" coefficient intervals (default beta_c).
    simex_options : keyword arguments of ``simex_batch`` for ``refit="simex"`` (lambdas, n_sim, ...).
    chunk : refits per batch (memory); progress : ``progress(iterable, total, description)`` reporting the
    chunks (e.g. a tqdm bar handed in by the caller), or None.
    """
    if design not in DESIGNS:
        raise PhysicsInputError(f"design must be one of {DESIGNS}, got {design!r}")
    if refit not in REFITS:
        raise PhysicsInputError(f"refit must be one of {REFITS}, got {refit!r}")
    if not (isinstance(n_boot, (int, np.integer)) and n_boot >= 2):
        raise PhysicsInputError(f"n_boot must be an integer >= 2, got {n_boot!r}")
    agb = np.asarray(agb, dtype=float)
    sigma = np.asarray(sigma, dtype=float)
    if sigma.shape != agb.shape:
        raise PhysicsInputError(f"the bootstrap is implemented for single-channel data: agb {agb.shape}, "
                                f"sigma {sigma.shape}")
    su = np.broadcast_to(np.asarray(agb_error_sd, dtype=float), agb.shape)
    sq = np.broadcast_to(np.asarray(sigma_error_sd, dtype=float), agb.shape)
    if np.any(su < 0) or np.any(sq < 0) or not (np.all(np.isfinite(su)) and np.all(np.isfinite(sq))):
        raise PhysicsInputError("measurement-error SDs must be finite and >= 0")
    space = model._space(space)
    if model_error is None:
        me = model_error_variance(model, agb, sigma, sq, su, denominator, **covariates)
    elif isinstance(model_error, ModelErrorEstimate):
        me = model_error
    else:
        v = float(model_error)
        if not v >= 0:
            raise PhysicsInputError(f"model_error variance must be >= 0, got {v}")
        me = ModelErrorEstimate(v, v, float("nan"), float("nan"), float("nan"), False, agb.shape[0])
    s_eps = np.sqrt(me.variance)
    beta_c = model.params
    p = beta_c.size
    samples = np.empty((n_boot, p))
    ok = np.zeros(n_boot, dtype=bool)
    modes: dict = {}
    opts = {"lambdas": DEFAULT_LAMBDAS, "n_sim": 50, **(simex_options or {})}
    starts = range(0, n_boot, chunk)
    for start in (starts if progress is None else progress(starts, len(starts), "bootstrap")):
        b = min(chunk, n_boot - start)
        w_b = agb + su * rng.standard_normal((b,) + agb.shape)  # eq. (11)
        w_b = np.clip(w_b, 0.0, None)
        x_gen = w_b if design == "paper" else np.broadcast_to(agb, w_b.shape)
        cov_b = {k: None if v is None else np.broadcast_to(np.asarray(v), w_b.shape) for k, v in covariates.items()}
        y_b = model.evaluate(x_gen, **cov_b) + s_eps * rng.standard_normal(w_b.shape)  # eq. (12)
        d_b = y_b + sq * rng.standard_normal(w_b.shape)  # eq. (13)
        p0 = np.broadcast_to(beta_c, (b, p))
        if refit == "naive":
            fit = model.fit_batch(w_b, d_b, p0=p0, space=space, **cov_b)
            samples[start:start + b] = fit.params
            ok[start:start + b] = fit.converged
            for name, count in fit.failure_counts().items():
                modes[name] = modes.get(name, 0) + count
        else:
            sb = simex_batch(model, w_b, d_b, su, sq, rng, p0=p0, space=space, **opts, **cov_b)
            samples[start:start + b] = sb.params
            ok[start:start + b] = sb.ok
            for name, count in sb.status_counts().items():
                if name != "ok":
                    modes[name] = modes.get(name, 0) + count
    good = samples[ok]
    if good.shape[0] < p + 1:
        raise PhysicsInputError(f"the bootstrap failed: only {good.shape[0]} of {n_boot} refits converged "
                                f"({modes}); the measurement errors may be too large for these data")
    cov = np.cov(good, rowvar=False).reshape(p, p)
    centre = beta_c if estimate is None else np.asarray(estimate, dtype=float)
    return BootstrapResult(model, centre, samples, ok, cov, me, design, refit, modes, space)
