"""SIMEX: simulation-extrapolation correction of the coefficient bias caused by measurement error.

Ahmed, Siqueira & Hensley (2014), Section II-C-2, eqs. (17)-(19), after Cook & Stefanski (1994):
measurement error in the field AGB (predictor, variance sigma_ui^2) and in the backscatter (response,
sigma_qi^2) biases the fitted coefficients. SIMEX adds *more* error of known size, ``(1 + lambda)`` times
the original, and watches the coefficients drift:

    W_si(lambda) = W_i + lambda^(1/2) u_si,   u_si ~ N(0, sigma_ui^2)          (17)
    D_si(lambda) = D_i + lambda^(1/2) q_si,   q_si ~ N(0, sigma_qi^2)          (18)
    beta_hat(lambda) = mean over s = 1..S of beta_hat_s(lambda)                 (19)

A quadratic in lambda fitted through (0, beta_naive) and the beta_hat(lambda) and evaluated at
lambda = -1 (no measurement error at all) is the corrected estimate.

Non-converging fits are the practical weakness the paper reports ("at subplot scales ... the SIMEX
starts to falter because of the failure of iterative fitting algorithms to converge frequently"): here
each of them is counted per lambda and by failure mode, eq. (19) averages the converged ones, and the
result says whether the failure fraction exceeds the threshold above which it should not be trusted.
Field AGB values that the added error pushes below 0 are set to 0 and counted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.models import FIT_STATUS_NAMES, FitResult, RetrievalModel

EXTRAPOLANTS = {"quadratic": 2, "linear": 1}
"""Polynomial extrapolants in lambda and their degree (the paper uses the quadratic)."""
DEFAULT_LAMBDAS = (0.5, 1.0, 1.5, 2.0)
"""Cook & Stefanski (1994) and Buonaccorsi (2010) use lambda in [0, 2]."""


@dataclass(frozen=True)
class SimexResult:
    """Outcome of SIMEX for one data set.

    naive : the fit to the data as measured (lambda = 0). model : the model with corrected coefficients.
    params : (p,) corrected coefficients (extrapolation to lambda = -1).
    lambdas : (L + 1,) 0 and the lambdas used. params_by_lambda : (L + 1, p) eq. (19) per lambda (row 0
    the naive fit) in the model's working parameterisation (``RetrievalModel.to_working``: the
    coefficients, or the intercept and slope of the log-log line for the power law); NaN where no fit at
    that lambda converged. sd_by_lambda : (L + 1, p) spread of the
    S fits per lambda. attempts : (L,) fits tried per lambda (S). failures : (L,) fits that did not
    converge. failure_modes : counts by failure mode over all lambdas. extrapolant : "quadratic" or
    "linear" (the one used); coefficients : (p, degree + 1) of the polynomial in lambda (highest power
    first). fallback : True when the quadratic extrapolant left the model's domain and the linear one was
    used instead (reported, never silent). n_clipped : simulated field AGB values set to 0.
    max_failure_fraction : threshold for ``reliable``.
    """

    naive: FitResult
    model: RetrievalModel
    params: np.ndarray
    lambdas: np.ndarray
    params_by_lambda: np.ndarray
    sd_by_lambda: np.ndarray
    attempts: np.ndarray
    failures: np.ndarray
    failure_modes: dict
    extrapolant: str
    coefficients: np.ndarray
    n_clipped: int
    max_failure_fraction: float
    fallback: bool = False

    @property
    def failure_fraction(self) -> float:
        return float(self.failures.sum() / max(self.attempts.sum(), 1))

    @property
    def reliable(self) -> bool:
        """False when more than ``max_failure_fraction`` of the simulated fits failed (the paper's
        subplot case: "with enough such failures, SIMEX results become untrustworthy")."""
        return self.failure_fraction <= self.max_failure_fraction

    @property
    def bias_estimate(self) -> np.ndarray:
        """Estimated bias of the naive coefficients: naive - corrected."""
        return self.naive.params - self.params

    def extrapolate(self, lam) -> np.ndarray:
        """The extrapolant at lambda (any shape): (..., p) coefficients in the working parameterisation of
        the model (the coefficients themselves except for the power law; Fig. 16 of the paper)."""
        lam = np.asarray(lam, dtype=float)
        return np.stack([np.polyval(c, lam) for c in self.coefficients], axis=-1)

    def summary(self) -> dict:
        return {"failure_fraction": self.failure_fraction, "reliable": self.reliable, "extrapolant": self.extrapolant,
                "fallback": self.fallback,
                "failures_by_lambda": dict(zip(map(float, self.lambdas[1:]), map(int, self.failures))),
                "failure_modes": dict(self.failure_modes), "n_clipped": self.n_clipped}


def simex(
    model: RetrievalModel,
    agb,
    sigma,
    agb_error_sd,
    sigma_error_sd,
    rng: np.random.Generator,
    lambdas=DEFAULT_LAMBDAS,
    n_sim: int = 100,
    extrapolant: str = "quadratic",
    p0=None,
    space: str | None = None,
    naive: FitResult | None = None,
    max_failure_fraction: float = 0.2,
    progress=None,
    **covariates,
) -> SimexResult:
    """SIMEX estimate of the coefficients of ``model`` from error-prone field data.

    agb : (n,) field AGB W (t/ha). sigma : (n,) or (n, channels) measured backscatter D (m^2/m^2).
    agb_error_sd : sigma_ui (t/ha), scalar or (n,). sigma_error_sd : sigma_qi (m^2/m^2), scalar, (n,) or
    the shape of sigma. rng : the generator of every simulated error. lambdas : positive, increasing.
    n_sim : S, simulated data sets per lambda. p0 : start of the naive fit (the model's coefficients by
    default); the simulated fits start from the naive estimate. naive : a naive fit already done.
    progress : ``progress(iterable, total, description)`` reporting the lambdas (a bar the caller hands in),
    or None. Raises ``PhysicsInputError`` for bad input, a naive fit that does not converge, or too few
    lambdas with converged fits to extrapolate.
    """
    if extrapolant not in EXTRAPOLANTS:
        raise PhysicsInputError(f"extrapolant must be one of {tuple(EXTRAPOLANTS)}, got {extrapolant!r}")
    lam = np.asarray(lambdas, dtype=float)
    if lam.ndim != 1 or lam.size < 1 or np.any(lam <= 0) or np.any(np.diff(lam) <= 0):
        raise PhysicsInputError(f"lambdas must be positive and increasing, got {list(np.atleast_1d(lambdas))}")
    degree = EXTRAPOLANTS[extrapolant]
    if lam.size + 1 < degree + 1:
        raise PhysicsInputError(f"a {extrapolant} extrapolant needs at least {degree} lambdas, got {lam.size}")
    if not (isinstance(n_sim, (int, np.integer)) and n_sim >= 2):
        raise PhysicsInputError(f"n_sim must be an integer >= 2, got {n_sim!r}")
    agb = np.asarray(agb, dtype=float)
    sigma = np.asarray(sigma, dtype=float)
    su = _error_sd(agb_error_sd, agb.shape, "agb_error_sd")
    sq = _error_sd(sigma_error_sd, sigma.shape, "sigma_error_sd")
    if naive is None:
        naive = model.fit(agb, sigma, p0=p0, space=space, **covariates)
    if not naive.converged:
        raise PhysicsInputError(
            f"the naive fit did not converge ({FIT_STATUS_NAMES[naive.status]}); SIMEX needs it as the start of "
            "the simulated fits: give a better starting point p0")
    space = naive.space
    start = naive.params
    p = start.shape[0]
    by_lam = np.full((lam.size + 1, p), np.nan)
    sd_lam = np.full((lam.size + 1, p), np.nan)
    by_lam[0], sd_lam[0] = model.to_working(start), 0.0
    failures = np.zeros(lam.size, dtype=int)
    modes: dict = {}
    clipped = 0
    cov_batch = {k: None if v is None else np.broadcast_to(np.asarray(v), (n_sim,) + agb.shape)
                 for k, v in covariates.items()}
    for i, value in enumerate(lam if progress is None else progress(lam, len(lam), "SIMEX")):
        root = np.sqrt(value)
        w = agb + root * su * rng.standard_normal((n_sim,) + agb.shape)  # eq. (17)
        d = sigma + root * sq * rng.standard_normal((n_sim,) + sigma.shape)  # eq. (18)
        clipped += int(np.count_nonzero(w < 0))
        w = np.clip(w, 0.0, None)
        batch = model.fit_batch(w, d, p0=np.broadcast_to(start, (n_sim, p)), space=space, **cov_batch)
        ok = batch.converged
        failures[i] = n_sim - int(ok.sum())
        for name, count in batch.failure_counts().items():
            modes[name] = modes.get(name, 0) + count
        if ok.any():
            work = model.to_working(batch.params[ok])
            by_lam[i + 1] = work.mean(axis=0)  # eq. (19), in the working parameterisation
            sd_lam[i + 1] = work.std(axis=0, ddof=1) if ok.sum() > 1 else 0.0
    lam_all = np.concatenate([[0.0], lam])
    usable = np.all(np.isfinite(by_lam), axis=1)
    if usable.sum() < degree + 1:
        raise PhysicsInputError(
            f"SIMEX failed: only {int(usable.sum()) - 1} of {lam.size} lambdas have converged fits "
            f"(failures per lambda {failures.tolist()}, modes {modes}); a {extrapolant} extrapolant needs {degree}")
    tried = []
    for name in _extrapolant_chain(extrapolant):
        deg = EXTRAPOLANTS[name]
        coef = np.stack([np.polyfit(lam_all[usable], by_lam[usable, j], deg) for j in range(p)])
        corrected = model.from_working(np.array([np.polyval(c, -1.0) for c in coef]))
        tried.append(f"{name}: {dict(zip(model.param_names, np.round(corrected, 6)))}")
        supported = supported_by_data(model, corrected[None], agb[None], sigma[None], np.sum(naive.residuals**2),
                                      space, {k: None if v is None else np.asarray(v)[None]
                                              for k, v in covariates.items()})[0]
        if model.params_valid(corrected) and supported:
            return SimexResult(naive, model.with_params(corrected), corrected, lam_all, by_lam, sd_lam,
                               np.full(lam.size, n_sim), failures, modes, name, coef, clipped,
                               float(max_failure_fraction), fallback=name != extrapolant)
    raise PhysicsInputError(
        "SIMEX extrapolation left the model's domain (" + "; ".join(tried) + "); the measurement errors may "
        "be too large for this data set")


SUPPORT_LEVEL = 1e-4
"""A corrected fit must lie inside the naive fit's 1 - SUPPORT_LEVEL confidence region (``supported_by_data``)."""


def supported_by_data(model: RetrievalModel, params, agb, sigma, naive_ssr, space: str, covariates: dict) -> np.ndarray:
    """(B,) whether corrected coefficients params (B, p) are a curve the data (agb (B, n), sigma (B, n[, c])) support.

    Two conditions; ``params_valid`` (finite, in range) sees neither. The curve is positive at every plot of
    AGB > 0: a negative backscatter where a plot was measured is no backscatter curve. And the curve lies in
    the naive fit's confidence region of level 1 - ``SUPPORT_LEVEL``, ``S(beta) <= S_naive (1 + p / (n - p)
    F_{p, n-p})`` (Beale 1960; Draper & Smith 1998, Section 24.5), S the residual sum of squares in the fit space:
    the bias SIMEX removes is that of measurement errors smaller than the scatter, while an extrapolation that
    ran away along a direction the data hardly identify (a saturating model's saturation level at ten times
    the data, or a beta2 of -500 when beta1 saturates the curve within a few t/ha) gives a curve that misses
    the data by far more. Such an extrapolation counts as outside the model's domain.
    """
    from scipy import special  # imported here: scipy costs start-up time

    agb = np.asarray(agb, dtype=float)
    sigma = np.asarray(sigma, dtype=float)
    params = np.nan_to_num(np.asarray(params, dtype=float))
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        curve = model.evaluate(agb, params, **covariates)
        resid = np.log(sigma) - np.log(curve) if space == "log" else sigma - curve
    lowest = curve.min(axis=-1) if curve.ndim == agb.ndim + 1 else curve  # multi-channel: every channel
    positive = np.all((lowest > 0) | (agb <= 0), axis=-1)
    ssr = np.sum(resid.reshape(resid.shape[0], -1) ** 2, axis=1)
    n, p = resid[0].size, params.shape[-1]
    f_crit = special.fdtri(p, n - p, 1.0 - SUPPORT_LEVEL) if n > p else np.inf
    return positive & np.isfinite(ssr) & (ssr <= np.asarray(naive_ssr) * (1.0 + p / max(n - p, 1) * f_crit))


def _extrapolant_chain(extrapolant: str) -> tuple:
    """The requested extrapolant, then the linear one if the quadratic leaves the model's domain."""
    return (extrapolant,) if extrapolant == "linear" else (extrapolant, "linear")


def _error_sd(value, shape, name):
    """sigma per plot broadcast to the data shape: scalar, the data shape, or (n,) for (n, channels) data."""
    sd = np.asarray(value, dtype=float)
    if sd.ndim == 0 or sd.shape == tuple(shape):
        sd = np.broadcast_to(sd, shape)
    elif len(shape) == 2 and sd.shape == tuple(shape[:1]):
        sd = np.broadcast_to(sd[:, None], shape)
    else:
        raise PhysicsInputError(f"{name} of shape {sd.shape} does not match the data {tuple(shape)}")
    if not np.all(np.isfinite(sd)) or np.any(sd < 0):
        raise PhysicsInputError(f"{name} must be finite and >= 0")
    return sd


# Batched SIMEX: many data sets at once (bootstrap with SIMEX refits, Monte Carlo studies) -----------------
SIMEX_OK = 0
NAIVE_FAILED = 1
"""Batched SIMEX status: the naive fit of the data set did not converge."""
TOO_FEW_LAMBDAS = 2
"""Batched SIMEX status: too few lambdas with converged simulated fits to extrapolate."""
EXTRAPOLATION_OUT_OF_DOMAIN = 3
"""Batched SIMEX status: the extrapolated coefficients lie outside the model's domain."""
SIMEX_STATUS_NAMES = {SIMEX_OK: "ok", NAIVE_FAILED: "naive_failed", TOO_FEW_LAMBDAS: "too_few_lambdas",
                      EXTRAPOLATION_OUT_OF_DOMAIN: "out_of_domain"}


@dataclass(frozen=True)
class SimexBatch:
    """SIMEX of B data sets. params : (B, p) corrected (naive where status != ok). naive : (B, p).
    status : (B,) ``SIMEX_OK`` or a failure code. failure_fraction : (B,) share of simulated fits that
    failed. n_clipped : simulated field AGB values set to 0. fallback : (B,) the quadratic extrapolant left the
    model's domain and the linear one was used (as ``simex``)."""

    params: np.ndarray
    naive: np.ndarray
    status: np.ndarray
    failure_fraction: np.ndarray
    n_clipped: int
    fallback: np.ndarray | None = None

    @property
    def ok(self) -> np.ndarray:
        return self.status == SIMEX_OK

    def status_counts(self) -> dict:
        return {name: int(np.count_nonzero(self.status == code)) for code, name in SIMEX_STATUS_NAMES.items()}


def simex_batch(model: RetrievalModel, agb, sigma, agb_error_sd, sigma_error_sd, rng: np.random.Generator,
                lambdas=DEFAULT_LAMBDAS, n_sim: int = 50, extrapolant: str = "quadratic", p0=None,
                space: str | None = None, **covariates) -> SimexBatch:
    """Eqs. (17)-(19) for B data sets agb (B, n), sigma (B, n), all fits of one lambda in one batch.

    Same estimator as ``simex`` (quadratic or linear extrapolant through lambda = 0 and the lambdas, the linear
    one where the quadratic leaves the model's domain); failures are counted per data set, never dropped
    silently.
    """
    lam = np.asarray(lambdas, dtype=float)
    degree = EXTRAPOLANTS[extrapolant]
    agb = np.asarray(agb, dtype=float)
    sigma = np.asarray(sigma, dtype=float)
    nb = agb.shape[0]
    su = np.broadcast_to(np.asarray(agb_error_sd, dtype=float), agb.shape)
    sq = np.broadcast_to(np.asarray(sigma_error_sd, dtype=float), sigma.shape)
    space = model._space(space)
    naive = model.fit_batch(agb, sigma, p0=p0, space=space, **covariates)
    p = naive.params.shape[1]
    by_lam = np.full((nb, lam.size + 1, p), np.nan)
    by_lam[:, 0] = model.to_working(naive.params)
    failed = np.zeros(nb)
    clipped = 0
    rep = {k: None if v is None else np.repeat(np.asarray(v), n_sim, axis=0) for k, v in covariates.items()}
    start = np.repeat(naive.params, n_sim, axis=0)
    for i, value in enumerate(lam):
        root = np.sqrt(value)
        w = agb[:, None] + root * su[:, None] * rng.standard_normal((nb, n_sim) + agb.shape[1:])
        d = sigma[:, None] + root * sq[:, None] * rng.standard_normal((nb, n_sim) + sigma.shape[1:])
        clipped += int(np.count_nonzero(w < 0))
        w = np.clip(w, 0.0, None).reshape((nb * n_sim,) + agb.shape[1:])
        batch = model.fit_batch(w, d.reshape((nb * n_sim,) + sigma.shape[1:]), p0=start, space=space, **rep)
        ok = batch.converged.reshape(nb, n_sim)
        with np.errstate(invalid="ignore", divide="ignore"):
            params = np.nan_to_num(model.to_working(batch.params)).reshape(nb, n_sim, p)
        count = ok.sum(axis=1)
        failed += n_sim - count
        with np.errstate(invalid="ignore"):
            by_lam[:, i + 1] = np.where(count[:, None] > 0,
                                        np.sum(params * ok[..., None], axis=1) / np.maximum(count, 1)[:, None], np.nan)
    lam_all = np.concatenate([[0.0], lam])
    usable = np.all(np.isfinite(by_lam), axis=2)  # (B, L + 1)
    enough = usable.sum(axis=1) >= degree + 1
    status = np.full(nb, SIMEX_OK, dtype=np.int8)
    status[~enough] = TOO_FEW_LAMBDAS
    params = np.array(naive.params, dtype=float, copy=True)
    todo = enough.copy()
    fallback = np.zeros(nb, dtype=bool)
    for name in _extrapolant_chain(extrapolant):  # as ``simex``: the linear extrapolant where the quadratic fails
        at_minus_one = _extrapolate_batch(model, lam_all, by_lam, usable, EXTRAPOLANTS[name], todo)
        inside = todo & model.params_valid(np.nan_to_num(at_minus_one)) & supported_by_data(
            model, at_minus_one, agb, sigma, naive.ssr, space, covariates)
        params[inside] = at_minus_one[inside]
        fallback |= inside & (name != extrapolant)
        todo &= ~inside
    status[todo] = EXTRAPOLATION_OUT_OF_DOMAIN
    status[~naive.converged] = NAIVE_FAILED
    params = np.where((status == SIMEX_OK)[:, None], params, naive.params)
    return SimexBatch(params, naive.params, status, failed / (lam.size * n_sim), clipped,
                      fallback & (status == SIMEX_OK))


def _extrapolate_batch(model, lam_all, by_lam, usable, degree, rows) -> np.ndarray:
    """(B, p) coefficients at lambda = -1 of a polynomial of ``degree`` fitted to each data set's eq. (19)
    values (NaN outside ``rows`` or where too few lambdas are usable)."""
    nb, _, p = by_lam.shape
    vander = np.vander(lam_all, degree + 1)  # highest power first, like np.polyfit
    wts = usable.astype(float)
    vtv = np.einsum("lj,lk,bl->bjk", vander, vander, wts)
    vty = np.einsum("lj,bl,blp->bjp", vander, wts, np.nan_to_num(by_lam))
    rows = rows & (usable.sum(axis=1) >= degree + 1)
    coef = np.full((nb, degree + 1, p), np.nan)
    if np.any(rows):
        coef[rows] = np.linalg.solve(vtv[rows], vty[rows])
    with np.errstate(invalid="ignore", over="ignore"):
        return model.from_working(np.einsum("j,bjp->bp", np.vander([-1.0], degree + 1)[0], coef))
