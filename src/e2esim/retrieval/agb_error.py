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

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from e2esim.block import Batched
from e2esim.case_values import plain
from e2esim.errors import PhysicsInputError
from e2esim.retrieval.agb_uncertainty import SampledAnswers, relative_moments, uncertainty_scalars
from e2esim.retrieval.agb_variants import ErrorVariants
from e2esim.retrieval.gauss_hermite import (
    HERMITE_NODES,
    along,
    gaussian_q_stats,
    hermite_average,
    power_law_q_moments,
    standard_normal_quantile,
)
from e2esim.retrieval.power_law import agb_relative_error, sigma_relative_error
from e2esim.retrieval.relative_error_map import RelativeErrorMap

REPORTED_QUANTILES = {"q00135": 0.00135, "q02275": 0.02275, "q50": 0.5, "q97725": 0.97725, "q99865": 0.99865}
"""Quantiles of the relative AGB error reported for every case (3 sigma, 2 sigma and median)."""


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
class AGBError(ErrorVariants, SampledAnswers, Batched):
    """Relative AGB error ``q = AGB_hat / AGB - 1`` implied by the sigma_hv error.

    exponent : power-law exponent p (for other models the local exponent 1 / (d ln sigma / d ln AGB),
        used by the trade-off curves). sigma_hv : true sigma_hv (m^2/m^2).
    error_mean, error_sd : mean and SD of the total sigma_hv error e (m^2/m^2) from the analytic model, or
        None. samples : Monte Carlo relative AGB errors (flat array), or None.
    mapping : ``RelativeErrorMap`` of a retrieval model, or None for the power law of ``exponent``.
    contributions : ``AGBContribution`` records of the named error sources (empty when the error has a
        single source, the system distortions and FR of the propagation module).
    saturated_fraction : basis -> fraction of estimates that saturate (probability for "analytic").
    error_model : the single-channel ``ErrorModel`` this error maps (``backscatter.error``, or a channel or a
        channel combination of a multi-channel model): the systematic part of the error, whose levels the
        requirements' margins and trade-off curves change and whose sources their attribution takes away
        (``e2esim.retrieval.agb_variants``); None only for an error no retrieval made.
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
            return agb_relative_error(x, along(self.exponent, x.ndim - np.ndim(self.exponent)))
        return self.mapping(np.asarray(sigma_relative, dtype=float))

    def sigma_threshold(self, level, memo=None):
        """Relative sigma_hv error x at which the relative AGB error reaches ``level`` (eq. 16 or the map; memo: the
        run's ``KernelMemo``, which keeps a map's bisection, ``RelativeErrorMap.threshold``)."""
        if self.mapping is None:
            return plain(sigma_relative_error(level, self.exponent))
        return self.mapping.threshold(level, memo)

    # Quantiles, exceedance, RMSE ----------------------------------------------------------
    # The analytic answers are element-wise in the fields, which may carry a leading case axis (a block of
    # sweep cases, the case axis below): a case gets the same numbers alone or in a block.
    def quantile(self, probability, basis: str = "analytic"):
        """Relative AGB error q_P with P(q <= q_P) = probability (shape C + the shape of ``probability``)."""
        probability = np.asarray(probability, dtype=float)
        if basis == "analytic":
            k = probability.ndim
            e = along(self.error_mean, k) + standard_normal_quantile(probability) * along(self.error_sd, k)
            return self.relative_agb(e / along(self.sigma_hv, k))
        return np.quantile(self.samples, probability)

    def exceedance(self, bound, side: str = "over", basis: str = "analytic", relative_threshold=None):
        """P(q > bound) for side "over" (bound > 0), P(q < -bound) for side "under" (bound > 0). relative_threshold:
        ``sigma_threshold`` at the side's level where the caller holds it already (``AGBBound.relative_threshold``,
        for this error or a variant with its map and exponent), None: derived here."""
        level = bound if side == "over" else -bound
        if basis == "analytic":
            f = self.sigma_threshold(level) if relative_threshold is None else relative_threshold
            threshold = f * np.asarray(self.sigma_hv)  # f sigma_hv, eq. (19)
            below = threshold - np.asarray(self.error_mean)
            sd = np.asarray(self.error_sd)
            with np.errstate(divide="ignore", invalid="ignore"):
                z = np.where(sd > 0, below / np.where(sd > 0, sd, 1.0), np.inf * np.sign(below))
            from scipy import special  # imported here, as above

            p = special.ndtr(-z) if side == "over" else special.ndtr(z)
            return plain(np.where(np.isfinite(threshold), p, 0.0 if side == "over" else 1.0))
        return float(np.mean(self.samples > level) if side == "over" else np.mean(self.samples < level))

    def rmse(self, basis: str = "analytic"):
        """Root-mean-square relative AGB error sqrt(E[q^2]) (bias and spread together)."""
        if basis == "analytic":
            return plain(np.sqrt(self._analytic_q_moments[1]))
        return float(np.sqrt(np.mean(self.samples**2)))

    def mean(self, basis: str = "analytic"):
        """Mean relative AGB error E[q]."""
        if basis == "analytic":
            return plain(self._analytic_q_moments[0])
        return float(np.mean(self.samples))

    @cached_property
    def _analytic_q_moments(self) -> tuple:
        """(E[q], E[q^2]) of the Gaussian sigma error through the map, by Gauss-Hermite quadrature; computed once
        per object (a requirement asks for the RMSE of the same error several times: value, details,
        attribution). The fields are never changed in place (``dataclasses.replace`` makes a new object)."""
        if self.mapping is None:
            return power_law_q_moments(self.error_mean, self.error_sd, self.exponent, self.sigma_hv)
        q = self._q_at_nodes()
        return hermite_average(q), hermite_average(q**2)

    def _q_at_nodes(self):
        """q at the Gauss-Hermite nodes of the Gaussian sigma error (shape C + (64,))."""
        e = along(self.error_mean, 1) + along(self.error_sd, 1) * HERMITE_NODES
        return self.relative_agb(e / along(self.sigma_hv, 1))

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
        stats_ = gaussian_q_stats(self.relative_agb, c.relative_mean, variance,
                                   self.exponent if self.mapping is None else None)
        total = sum(np.maximum(k.relative_variance, 0.0) for k in self.contributions)
        with np.errstate(divide="ignore", invalid="ignore"):
            stats_["variance_share"] = plain(np.where(total > 0, variance / np.where(total > 0, total, 1.0), 0.0))
        stats_["sigma_mean_percent"] = 100 * c.relative_mean
        stats_["sigma_sd_percent"] = 100 * plain(np.sign(c.relative_variance) * np.sqrt(np.abs(c.relative_variance)))
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

    # The case axis ---------------------------------------------------------------------------------------------
    # A block of sweep cases is one ``AGBError`` whose fields are arrays over its cases (analytic: exponent,
    # sigma_hv, error_mean, error_sd of shape (B,), contributions with (B,) means and variances, the error model a
    # block of them); one case has numbers, a block of one.
    def __bool__(self) -> bool:
        return True

    @property
    def case_shape(self) -> tuple:
        """() for one case, (B,) for a block."""
        return np.shape(self.exponent)

    def block_item(self, i: int) -> AGBError:
        """The one-case ``AGBError`` of case ``i``, as the per-case engine makes it."""
        return AGBError(float(self.exponent[i]), float(self.sigma_hv[i]), _at(self.error_mean, i),
                        _at(self.error_sd, i), None, self.mapping,
                        tuple(AGBContribution(c.name, c.group, float(c.relative_mean[i]), float(c.relative_variance[i]),
                                              c.description, None if c.uncertainty is None else c.uncertainty.item(i))
                              for c in self.contributions),
                        tuple((basis, float(np.asarray(f)[i])) for basis, f in self.saturated_fraction),
                        None if self.error_model is None else self.error_model.item(i))

    def take(self, positions) -> AGBError:
        def at(x):
            return None if x is None else x[positions]

        return replace(self, exponent=self.exponent[positions], sigma_hv=self.sigma_hv[positions],
                       error_mean=at(self.error_mean), error_sd=at(self.error_sd),
                       contributions=tuple(replace(c, relative_mean=c.relative_mean[positions],
                                                   relative_variance=c.relative_variance[positions],
                                                   uncertainty=None if c.uncertainty is None
                                                   else c.uncertainty.take(positions)) for c in self.contributions),
                       saturated_fraction=tuple((b, np.asarray(f)[positions]) for b, f in self.saturated_fraction),
                       error_model=None if self.error_model is None else self.error_model.take(positions))

    @classmethod
    def concatenate(cls, parts: list) -> AGBError:
        first = parts[0]

        def joined(get):
            return np.concatenate([np.asarray(get(p)) for p in parts])

        def joined_term(k, c):
            return replace(c, relative_mean=joined(lambda p: p.contributions[k].relative_mean),
                           relative_variance=joined(lambda p: p.contributions[k].relative_variance),
                           uncertainty=None if c.uncertainty is None else type(c.uncertainty).concatenate(
                               [p.contributions[k].uncertainty for p in parts]))

        return replace(first, exponent=joined(lambda p: p.exponent), sigma_hv=joined(lambda p: p.sigma_hv),
                       error_mean=joined(lambda p: p.error_mean), error_sd=joined(lambda p: p.error_sd),
                       contributions=tuple(joined_term(k, c) for k, c in enumerate(first.contributions)),
                       saturated_fraction=tuple((b, joined(lambda p, k=k: p.saturated_fraction[k][1]))
                                                for k, (b, _) in enumerate(first.saturated_fraction)),
                       error_model=None if first.error_model is None else type(first.error_model).concatenate(
                           [p.error_model for p in parts]))

    def scalar_columns(self) -> dict:
        """The output scalars of every case of a block: {name: (B,) array}."""
        n = len(self)
        return {name: np.broadcast_to(np.asarray(value, dtype=float), (n,)) for name, value in self.scalars().items()}

    def source_groups(self) -> dict:
        """{contribution name: its group}, the same for every case."""
        return {c.name: c.group for c in self.contributions}


def _at(values, i: int):
    return None if values is None else float(values[i])


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

