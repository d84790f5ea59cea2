"""Distribution of the relative AGB error implied by an error in sigma_hv.

Men et al. (2021), Section V-B: the sigma_hv error e is close to Gaussian (Fig. 2), so exceedance
probabilities follow from its mean b and SD sigma_e (eq. 19); through the power law (eqs. 15-16) the
relative AGB error ``q = (1 + e / sigma_hv)^p - 1`` is a monotone function of e, so its quantiles are
the images of the quantiles of e. Monte Carlo samples of e give the same quantities without the
Gaussian approximation.

Any other retrieval model (``e2esim.retrieval.models``) gives the same structure through a
``RelativeErrorMap``: q is the monotone (non-decreasing) image of the relative sigma error x = e / sigma
at the case's AGB, saturation included (an estimate that saturates is capped at ``agb_max``). When the
error has several named sources (system distortions, Faraday rotation, speckle and noise, ...), each is
kept as an ``AGBContribution`` so that reports can show which one dominates.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.agb_uncertainty import SampledAnswers, relative_moments, uncertainty_scalars
from e2esim.retrieval.power_law import agb_relative_error, sigma_relative_error

_HERMITE_NODES, _HERMITE_WEIGHTS = np.polynomial.hermite_e.hermegauss(64)
_HERMITE_WEIGHTS = _HERMITE_WEIGHTS / np.sqrt(2 * np.pi)  # probabilists' Hermite: weights sum to 1
_X_SEARCH = (-1.0 + 1e-12, 1e6)  # relative sigma errors searched when inverting a map numerically
REPORTED_QUANTILES = {"q00135": 0.00135, "q02275": 0.02275, "q50": 0.5, "q97725": 0.97725, "q99865": 0.99865}
"""Quantiles of the relative AGB error reported for every case (3 sigma, 2 sigma and median)."""


def standard_normal_quantile(probability):
    """z with P(Z <= z) = probability (e.g. 0.99865 -> 3.00, Men et al. 2021, Table III)."""
    from scipy import special  # imported here: scipy.special costs a third of a second at start-up

    return special.ndtri(probability)


@dataclass(frozen=True)
class RelativeErrorMap:
    """x (relative sigma_hv error) -> q (relative AGB error) through a retrieval model at one AGB.

    model : a ``RetrievalModel``. agb_t_ha : the true AGB (t/ha). agb_max_t_ha : cap of the estimates
    (saturation), None for none. covariates : keyword arguments of the model (e.g. incidence_rad).
    For a multi-channel model the error is applied to the HV channel.
    """

    model: object
    agb_t_ha: float
    agb_max_t_ha: float | None = None
    covariates: tuple = ()

    def __call__(self, x):
        q, _ = self.model.relative_agb_error(self.agb_t_ha, x, self.agb_max_t_ha, **dict(self.covariates))
        return q

    def inversion(self, x):
        """The ``Inversion`` (statuses: saturated, below range) of sigma (1 + x)."""
        return self.model.relative_agb_error(self.agb_t_ha, x, self.agb_max_t_ha, **dict(self.covariates))[1]

    def saturation_threshold(self) -> float:
        """Smallest relative sigma error x whose estimate saturates (+inf if the model never saturates)."""
        s_max = self.inversion(np.array([0.0])).sigma_max
        if not np.isfinite(s_max):
            return np.inf
        truth = np.atleast_1d(self.model.sigma(self.agb_t_ha, **dict(self.covariates)))
        return float(s_max / truth[1 if truth.size == 3 else 0] - 1.0)

    def threshold(self, level: float) -> float:
        """x at which q reaches ``level`` (> -1): +inf if q never exceeds it (cap), -1 if q never falls to it."""
        kept = self.__dict__.setdefault("_thresholds", {})  # a bisection once per level, kept with the frozen map
        return kept[float(level)] if float(level) in kept else kept.setdefault(float(level),
                                                                                self._threshold_numeric(level))

    def _threshold_numeric(self, level):
        if not np.isfinite(level):
            return np.inf
        lo, hi = _X_SEARCH
        if self(np.array([hi]))[0] < level:
            return np.inf
        if self(np.array([lo]))[0] >= level:
            return -1.0
        for _ in range(200):  # bisection: q is non-decreasing in x
            mid = 0.5 * (lo + hi) if hi - lo > 1.0 else np.sqrt((1 + lo) * (1 + hi)) - 1.0
            if self(np.array([mid]))[0] >= level:
                hi = mid
            else:
                lo = mid
            if hi - lo <= 1e-13 * max(1.0, abs(hi)):
                break
        return hi

    def local_exponent(self) -> float:
        """The power-law exponent the map acts with near x = 0: 1 / (d ln sigma / d ln AGB) at the case's
        AGB; for the multi-channel log-linear model the HV channel weight c_hv."""
        if hasattr(self.model, "channel_weights"):
            return float(self.model.channel_weights()[1])
        return float(1.0 / self.model.sensitivity(self.agb_t_ha, **dict(self.covariates)))


@dataclass(frozen=True)
class AGBContribution:
    """One source of the backscatter error and the relative AGB error it causes on its own.

    name : e.g. "system_distortions", "faraday_rotation", "speckle_noise", "calibration", "regression".
    group : "systematic" (system distortions and FR, seed 000), "random" (error budget, seed 004) or
    "regression" (retrieval-model uncertainty). relative_mean, relative_variance : mean and variance of
    the relative sigma_hv error x = e / sigma_hv it contributes (the variance may be negative for an
    increment such as the Faraday-rotation share of the systematic error). description : one line.
    uncertainty : for a sampled term (the regression's expectation over simulated campaigns), a
    ``RegressionUncertainty``: the standard error of ``relative_variance`` and the spread across campaigns;
    None for an exact term.
    """

    name: str
    group: str
    relative_mean: float
    relative_variance: float
    description: str = ""
    uncertainty: object = None


@dataclass(frozen=True)
class AGBError(SampledAnswers):
    """Relative AGB error ``q = AGB_hat / AGB - 1`` implied by the sigma_hv error.

    exponent : power-law exponent p (for other models the local exponent 1 / (d ln sigma / d ln AGB),
        used by the trade-off curves). sigma_hv : true sigma_hv (m^2/m^2).
    error_mean, error_sd : mean and SD of the total sigma_hv error e (m^2/m^2) from the analytic model, or
        None. samples : Monte Carlo relative AGB errors (flat array), or None.
    mapping : ``RelativeErrorMap`` of a retrieval model, or None for the power law of ``exponent``.
    contributions : ``AGBContribution`` records of the named error sources (empty when the error has a
        single source, the system distortions and FR of the propagation module).
    saturated_fraction : basis -> fraction of estimates that saturate (probability for "analytic").
    error_model : the single-channel ``ErrorModel`` this error maps (a channel or a channel combination of a
        multi-channel model), for the requirements' margins, attribution and trade-off curves; None: the
        case's ``backscatter.error``.
    sensitivity : (name, value) pairs of the exponent sensitivity of the analytic RMSE (the joint multi-channel
        estimate, ``e2esim.retrieval.exponent_sensitivity``), written as ``agb.exponent_sensitivity.<name>``.
    realisations : M, independent realisations of the samples ((M, N) flattened by rows; 0: all independent).
    sample_moments : (mean, SE, SD, SE) of the Monte Carlo's x, or (). saturated_standard_error : basis -> SE.
    """

    exponent: float
    sigma_hv: float
    error_mean: float | None = None
    error_sd: float | None = None
    samples: np.ndarray | None = None
    mapping: RelativeErrorMap | None = None
    contributions: tuple = ()
    saturated_fraction: tuple = ()
    error_model: object = None
    sensitivity: tuple = ()
    realisations: int = 0
    sample_moments: tuple = ()
    saturated_standard_error: tuple = ()

    @classmethod
    def from_sigma_errors(cls, exponent, sigma_hv, error_mean=None, error_sd=None, relative_samples=None,
                          mapping=None, contributions=(), saturated_fraction=(), error_model=None,
                          saturated_standard_error=()):
        """From the analytic mean/SD of e (m^2/m^2) and/or Monte Carlo relative errors e / sigma_hv ((M, N): M
        independent realisations of N samples each, or (M,))."""
        samples, realisations, moments = None, 0, ()
        if relative_samples is not None:
            x = np.ravel(relative_samples)
            samples = agb_relative_error(x, exponent) if mapping is None else mapping(x)
            realisations = int(np.shape(relative_samples)[0]) if np.ndim(relative_samples) > 1 else 0
            moments = relative_moments(relative_samples)
        return cls(exponent, sigma_hv, error_mean, error_sd, samples, mapping, tuple(contributions),
                   tuple(saturated_fraction), error_model, realisations=realisations, sample_moments=moments,
                   saturated_standard_error=tuple(saturated_standard_error))

    def has(self, basis: str) -> bool:
        return (self.error_mean is not None) if basis == "analytic" else (self.samples is not None)

    def relative_agb(self, sigma_relative):
        """q for relative sigma errors x (the power law or the retrieval model's map). With a case axis (fields
        of shape C), x has shape C + further axes."""
        if self.mapping is None:
            x = np.asarray(sigma_relative, dtype=float)
            return agb_relative_error(x, _along(self.exponent, x.ndim - np.ndim(self.exponent)))
        return self.mapping(np.asarray(sigma_relative, dtype=float))

    def sigma_threshold(self, level):
        """Relative sigma_hv error x at which the relative AGB error reaches ``level`` (eq. 16 or the map)."""
        if self.mapping is None:
            return _plain(sigma_relative_error(level, self.exponent))
        return self.mapping.threshold(level)

    # Quantiles, exceedance, RMSE ----------------------------------------------------------
    # The analytic answers are element-wise in the fields, which may carry a leading case axis (a block of
    # sweep cases, ``AGBErrorBlock``): a case gets the same numbers alone or in a block.
    def quantile(self, probability, basis: str = "analytic"):
        """Relative AGB error q_P with P(q <= q_P) = probability (shape C + the shape of ``probability``)."""
        probability = np.asarray(probability, dtype=float)
        if basis == "analytic":
            k = probability.ndim
            e = _along(self.error_mean, k) + standard_normal_quantile(probability) * _along(self.error_sd, k)
            return self.relative_agb(e / _along(self.sigma_hv, k))
        return np.quantile(self.samples, probability)

    def exceedance(self, bound, side: str = "over", basis: str = "analytic"):
        """P(q > bound) for side "over" (bound > 0), P(q < -bound) for side "under" (bound > 0)."""
        level = bound if side == "over" else -bound
        if basis == "analytic":
            threshold = self.sigma_threshold(level) * np.asarray(self.sigma_hv)  # f sigma_hv, eq. (19)
            below = threshold - np.asarray(self.error_mean)
            sd = np.asarray(self.error_sd)
            with np.errstate(divide="ignore", invalid="ignore"):
                z = np.where(sd > 0, below / np.where(sd > 0, sd, 1.0), np.inf * np.sign(below))
            from scipy import special  # imported here, as above

            p = special.ndtr(-z) if side == "over" else special.ndtr(z)
            return _plain(np.where(np.isfinite(threshold), p, 0.0 if side == "over" else 1.0))
        return float(np.mean(self.samples > level) if side == "over" else np.mean(self.samples < level))

    def rmse(self, basis: str = "analytic"):
        """Root-mean-square relative AGB error sqrt(E[q^2]) (bias and spread together)."""
        if basis == "analytic":
            return _plain(np.sqrt(self._analytic_q_moments[1]))
        return float(np.sqrt(np.mean(self.samples**2)))

    def mean(self, basis: str = "analytic"):
        """Mean relative AGB error E[q]."""
        if basis == "analytic":
            return _plain(self._analytic_q_moments[0])
        return float(np.mean(self.samples))

    @cached_property
    def _analytic_q_moments(self) -> tuple:
        """(E[q], E[q^2]) of the Gaussian sigma error through the map, by Gauss-Hermite quadrature; computed once
        per object (a requirement asks for the RMSE of the same error several times: value, details,
        attribution). The fields are never changed in place (``dataclasses.replace`` makes a new object)."""
        if self.mapping is None:
            return _power_law_q_moments(self.error_mean, self.error_sd, self.exponent, self.sigma_hv)
        q = self._q_at_nodes()
        return hermite_average(q), hermite_average(q**2)

    def _q_at_nodes(self):
        """q at the Gauss-Hermite nodes of the Gaussian sigma error (shape C + (64,))."""
        e = _along(self.error_mean, 1) + _along(self.error_sd, 1) * _HERMITE_NODES
        return self.relative_agb(e / _along(self.sigma_hv, 1))

    # Contributions ---------------------------------------------------------------------------
    def contribution(self, name: str) -> AGBContribution:
        for c in self.contributions:
            if c.name == name:
                return c
        raise KeyError(f"no contribution {name!r}; contributions: {', '.join(c.name for c in self.contributions)}")

    def contribution_stats(self, name: str) -> dict:
        """The relative AGB error a contribution causes on its own (Gaussian x, through the map):
        mean, SD and RMSE of q (fractions), and its share of the total sigma error variance."""
        c = self.contribution(name)
        variance = np.maximum(c.relative_variance, 0.0)
        stats_ = _gaussian_q_stats(self.relative_agb, c.relative_mean, variance,
                                   self.exponent if self.mapping is None else None)
        total = sum(np.maximum(k.relative_variance, 0.0) for k in self.contributions)
        with np.errstate(divide="ignore", invalid="ignore"):
            stats_["variance_share"] = _plain(np.where(total > 0, variance / np.where(total > 0, total, 1.0), 0.0))
        stats_["sigma_mean_percent"] = 100 * c.relative_mean
        stats_["sigma_sd_percent"] = 100 * _plain(np.sign(c.relative_variance) * np.sqrt(np.abs(c.relative_variance)))
        return stats_

    def scalars(self) -> dict:
        """Output scalars (``agb.*``): the exponent; per basis the mean, RMSE and quantiles of the relative AGB
        error (percent) and the saturated fraction; per named contribution the relative AGB error it causes
        on its own (mean, SD, RMSE in percent), its share of the sigma error variance and its relative
        sigma error; the exponent sensitivity (docs/output-format.md). Arrays over cases for a block."""
        out = {"exponent": self.exponent}
        for basis in ("analytic", "montecarlo"):
            if self.has(basis):
                out[f"{basis}.mean_percent"] = 100 * self.mean(basis)
                out[f"{basis}.rmse_percent"] = 100 * self.rmse(basis)
                quantiles = self.quantile(np.array(list(REPORTED_QUANTILES.values())), basis)
                for k, label in enumerate(REPORTED_QUANTILES):
                    out[f"{basis}.{label}_percent"] = 100 * quantiles[..., k]
        out.update(uncertainty_scalars(self, REPORTED_QUANTILES))
        for basis, fraction in self.saturated_fraction:
            out[f"{basis}.saturated_fraction"] = fraction
        for basis, se in self.saturated_standard_error:
            out[f"{basis}.saturated_fraction_standard_error"] = se
        for c in self.contributions:
            stats = self.contribution_stats(c.name)
            key = f"contribution.{c.name}"
            out[f"{key}.mean_percent"] = 100 * stats["mean"]
            out[f"{key}.sd_percent"] = 100 * stats["sd"]
            out[f"{key}.rmse_percent"] = 100 * stats["rmse"]
            out[f"{key}.variance_share"] = stats["variance_share"]
            out[f"{key}.sigma_mean_percent"] = stats["sigma_mean_percent"]
            out[f"{key}.sigma_sd_percent"] = stats["sigma_sd_percent"]
        for name, value in self.sensitivity:
            out[f"exponent_sensitivity.{name}"] = value
        return out

    def dominant_contribution(self) -> str | None:
        """Name of the contribution with the largest mean square relative sigma error (bias^2 + variance)."""
        if not self.contributions:
            return None
        return max(self.contributions, key=lambda c: c.relative_mean**2 + max(c.relative_variance, 0.0)).name


def _gaussian_q_stats(mapping, mean, variance, exponent=None) -> dict:
    """Mean, SD and RMSE of q = mapping(x), x ~ N(mean, variance); ``exponent``: the map is the power law
    with that exponent (evaluated in cache-sized chunks, ``_power_law_q_moments``)."""
    if exponent is not None:
        m, ms = _power_law_q_moments(mean, np.sqrt(variance), exponent)
    else:
        x = _along(mean, 1) + np.sqrt(_along(variance, 1)) * _HERMITE_NODES
        q = mapping(x)
        m = hermite_average(q)
        ms = hermite_average(q**2)
    # a source without spread gives q without spread: SD 0, not the rounding noise of E[q^2] - E[q]^2
    sd = np.where(np.asarray(variance) > 0, np.sqrt(np.maximum(ms - np.square(m), 0.0)), 0.0)
    return {"mean": _plain(m), "sd": _plain(sd), "rmse": _plain(np.sqrt(ms))}


_SHORT_RULE_NODES = 16
_SHORT_RULE_LARGEST_SPREAD = 0.1
"""Cases whose sigma estimate (sigma + e) has a relative spread sd / (sigma + mean) of at most 0.1 take the
16-node Gauss-Hermite rule instead of the 64-node one: q = (1 + x)^p - 1 is then analytic over many standard
deviations around the mean (its branch point lies beyond 10 of them), and the two rules agree to about 1e-15
relative for exponents 0.5-5 (tests/test_agb_error.py). A wider spread keeps 64 nodes."""
_SHORT_NODES, _SHORT_WEIGHTS = np.polynomial.hermite_e.hermegauss(_SHORT_RULE_NODES)
_SHORT_WEIGHTS = _SHORT_WEIGHTS / np.sqrt(2 * np.pi)
_CHUNK_VALUES = 256 * 64
"""Values of q evaluated at once in ``_power_law_q_moments``: 128 kB stay in the CPU cache, where a block's
whole (4096, 64) array would not (twice the time per element)."""


def _power_law_q_moments(mean, sd, exponent, sigma=None) -> tuple:
    """(E[q], E[q^2]) of q = (1 + x)^p - 1 (inverse of Men et al. 2021, eq. 16; q = -1 for x <= -1) with
    x = (mean + sd Z) / sigma, Z ~ N(0, 1) (sigma None: x = mean + sd Z), by Gauss-Hermite quadrature: 16 nodes
    where the spread is small enough (``_SHORT_RULE_LARGEST_SPREAD``), 64 otherwise.

    Per case the operations of ``agb_relative_error`` at the nodes followed by ``hermite_average``, so a case
    gets bitwise the same numbers alone or in a block; a block is evaluated in cache-sized chunks, in place.
    Arrays broadcast; the results have their broadcast shape.
    """
    fields = [mean, sd, exponent, 1.0 if sigma is None else sigma]
    fields = np.broadcast_arrays(*(np.asarray(f, dtype=float) for f in fields))
    shape = fields[0].shape
    mean, sd, exponent, scale = (f.reshape(-1) for f in fields)
    first, second = np.empty(mean.size), np.empty(mean.size)
    with np.errstate(divide="ignore", invalid="ignore"):
        short = sd <= _SHORT_RULE_LARGEST_SPREAD * (scale + mean)  # False for nan and for sigma + mean <= 0
    for cases, nodes, weights in ((np.flatnonzero(short), _SHORT_NODES, _SHORT_WEIGHTS),
                                  (np.flatnonzero(~short), _HERMITE_NODES, _HERMITE_WEIGHTS)):
        step = _CHUNK_VALUES // len(nodes)
        for start in range(0, len(cases), step):
            rows = cases[start:start + step]
            first[rows], second[rows] = _power_law_moments_at(mean[rows], sd[rows], exponent[rows],
                                                              None if sigma is None else scale[rows], nodes, weights)
    return first.reshape(shape), second.reshape(shape)


def _power_law_moments_at(mean, sd, exponent, sigma, nodes, weights) -> tuple:
    x = mean[:, None] + sd[:, None] * nodes
    if sigma is not None:
        x /= sigma[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.log1p(x)
        q *= exponent[:, None]
        np.expm1(q, out=q)
    q[~(x > -1.0)] = -1.0  # an estimate at or below zero: q = -1 (agb_relative_error)
    first = (q * weights).sum(-1)  # hermite_average, with this rule's weights
    np.square(q, out=q)
    return first, (q * weights).sum(-1)


def hermite_average(values):
    """E[h(Z)], Z standard normal, from h at the 64 Gauss-Hermite nodes (last axis): an element-wise product
    and numpy's sum, the same operations for one case as for a block of them."""
    return (values * _HERMITE_WEIGHTS).sum(-1)


def _along(x, extra: int):
    """``x`` (a number, or an array over cases) with ``extra`` trailing length-1 axes, to broadcast against
    arrays of shape case + ``extra`` further axes."""
    x = np.asarray(x, dtype=float)
    return x.reshape(x.shape + (1,) * extra) if extra > 0 else x


def _plain(x):
    """A float for a 0-d result (one case), the array otherwise (a block)."""
    return float(x) if np.ndim(x) == 0 else np.asarray(x)


def binomial_interval(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """Clopper-Pearson interval for a proportion (exceedance probability from Monte Carlo counts)."""
    from scipy import stats  # imported here: scipy.stats costs a second at start-up

    alpha = 1 - confidence
    lo = stats.beta.ppf(alpha / 2, successes, trials - successes + 1) if successes > 0 else 0.0
    hi = stats.beta.ppf(1 - alpha / 2, successes + 1, trials - successes) if successes < trials else 1.0
    return float(lo), float(hi)


def check_relative_variance(name: str, value: float) -> float:
    if not np.isfinite(value):
        raise PhysicsInputError(f"contribution {name!r} has a non-finite variance {value}")
    return float(value)

