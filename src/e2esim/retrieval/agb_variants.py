"""The error a requirement asks an ``AGBError`` about: its systematic part alone, with assumed terms added, without
one source, and at changed error levels.

The AGB error is where the error sources meet (``e2esim.retrieval.combine``): the propagation's error model
(``error_model``, systematic: system distortions, Faraday rotation, noise) and the variance the other, independent
sources add to it (the random-error budget by its combination rule, the regression uncertainty, the model term of
the retrieval's exponents, a requirement's assumed terms), ``added_variance``. Every variant below keeps that
split, so a requirement asks the AGB error and recomputes nothing: the margins and trade-off curves ask
``bound_violation`` (Men et al. 2021, eq. 19, at the error model's changed levels), the attribution asks
``without``.
"""

from __future__ import annotations

from dataclasses import replace
from functools import cached_property

import numpy as np

from e2esim.case_values import plain
from e2esim.retrieval.gauss_hermite import standard_normal_quantile

SYSTEMATIC = "systematic"


class ErrorVariants:
    """Mixin of ``AGBError`` (fields ``error_model``, ``error_mean``, ``error_sd``, ``sigma_hv``, ``contributions``);
    every answer is element-wise over a leading case axis, as the ``AGBError``'s own."""

    @cached_property
    def added_variance(self):
        """Variance (m^2/m^2)^2 the sources outside the error model add to its systematic error (the total
        variance less the error model's; never negative): they do not depend on the error model's levels."""
        total = np.square(np.asarray(self.error_sd, dtype=float))
        return plain(np.maximum(total - np.asarray(self.error_model.current().variance, dtype=float), 0.0))

    def systematic(self):
        """The AGB error of the error model's systematic error alone (system distortions, Faraday rotation and
        noise: the criterion of Men et al. 2021), leaving out the random-error budget, the regression and the
        model term; itself when it has nothing else. Analytic only for a block of cases."""
        if all(c.group == SYSTEMATIC for c in self.contributions):
            return self
        model = self.error_model
        m = model.current() if model.unavailable is None else None
        if np.ndim(self.exponent):  # a block of cases: analytic only
            return replace(self, sigma_hv=np.asarray(model.value, dtype=float), error_mean=np.asarray(m.mean),
                           error_sd=np.asarray(m.sd), contributions=(), saturated_fraction=())
        return type(self).from_sigma_errors(
            self.exponent, model.value, None if m is None else float(m.mean), None if m is None else float(m.sd),
            model.relative_samples(), self.mapping, error_model=model)

    def with_terms(self, terms: tuple):
        """The AGB error with further independent zero-mean terms (``AGBContribution``s of relative variance)
        added to the variance of the relative sigma error, as the retrieval adds the random-error budget;
        analytic only (the Monte Carlo samples and their saturated fraction are left out)."""
        added = sum(c.relative_variance for c in terms)
        sd = np.sqrt(np.square(np.asarray(self.error_sd, dtype=float)) + np.square(np.asarray(self.sigma_hv)) * added)
        return replace(self, error_sd=plain(sd), samples=None, contributions=tuple(self.contributions) + tuple(terms),
                       saturated_fraction=tuple((b, f) for b, f in self.saturated_fraction if b != "montecarlo"))

    def sources(self) -> tuple:
        """The sources ``without`` takes away: the error model's, then every named contribution outside it."""
        return tuple(self.error_model.sources) + tuple(c.name for c in self.contributions if c.group != SYSTEMATIC)

    def without(self, source: str) -> tuple:
        """(the analytic AGB error without ``source``, everything else kept; where it was not active): a source of
        the error model through ``ErrorModel.without`` (the added variance kept), any other by taking its variance
        out of the total. The second is None (active in every case), a per-case bool array (a block), or True
        (not active at all: the first is then None; also None for a block where the array is True in every case:
        nothing is evaluated for a source no case has)."""
        model = self.error_model
        if source in model.sources:
            variant = model.without(source)
            if variant is model:  # no case has the source; a block marks each of its cases, as its variants do
                shape = np.shape(self.error_mean)
                return None, (True if shape == () else np.ones(shape, dtype=bool))
            inactive = getattr(variant, "inactive", None)
            if inactive is not None and np.all(inactive):
                return None, inactive
            m = variant.current()
            sd = np.sqrt(np.square(m.sd) + self.added_variance)
            return replace(self, error_mean=plain(m.mean), error_sd=plain(sd), error_model=variant), inactive
        c = self.contribution(source)
        variance = np.maximum(np.asarray(self.error_sd) ** 2 - np.asarray(model.value) ** 2
                              * np.maximum(c.relative_variance, 0.0), 0.0)
        return replace(self, error_sd=plain(np.sqrt(variance))), None

    def moments_under(self, **levels) -> tuple:
        """(mean, SD) of the total sigma error (m^2/m^2) with the error model's levels changed (``levels`` broadcast
        against the case axis, shape C + further axes), the other sources as they are."""
        m = self.error_model.moments(**levels)
        mean, sd = np.asarray(m.mean), np.asarray(m.sd)
        extra = _aligned(self.added_variance, sd)
        return mean, np.where(extra != 0, np.sqrt(sd**2 + extra), sd)

    def bound_violation(self, bound: float, confidence: float, side: str, **levels):
        """Signed distance (m^2/m^2) from the limit of Men et al. (2021), eq. (19), at the error model's changed
        levels: <= 0 where P(q > bound) ("over") or P(q < -bound) ("under") stays within 1 - confidence.

            over: b + z sigma_e - f_max sigma_hv        under: f_min sigma_hv - (b - z sigma_e)

        b, sigma_e from ``moments_under``, z = Phi^-1(confidence), f the relative sigma error at the bound
        (``sigma_threshold``: eq. 16, or the retrieval model's map). Equivalent to the bound on the Gaussian
        quantile of q, since q is a non-decreasing function of the sigma error."""
        return self.bound_violation_of(self.moments_under(**levels), bound, confidence, side)

    def bound_violation_of(self, moments: tuple, bound: float, confidence: float, side: str, relative_threshold=None):
        """``bound_violation`` from the (mean, SD) that ``moments_under`` gave at the levels: the sides of a bound
        that ask the same levels share one evaluation of the moments (``e2esim.requirements.level_search``).
        relative_threshold : f where the caller holds it (``AGBBound.relative_threshold``), None: derived here."""
        mean, sd = moments
        z = float(standard_normal_quantile(confidence))
        level = bound if side == "over" else -bound
        f = self.sigma_threshold(level) if relative_threshold is None else relative_threshold
        f_sigma = _aligned(f, mean) * _aligned(self.error_model.value, mean)
        if side == "over":
            return mean + z * sd - f_sigma
        return f_sigma - (mean - z * sd)


def _aligned(x, like):
    """``x`` (per case, shape C) with trailing length-1 axes to broadcast against ``like`` (shape C + levels)."""
    x = np.asarray(x, dtype=float)
    return x.reshape(x.shape + (1,) * (np.ndim(like) - x.ndim)) if x.ndim and np.ndim(like) > x.ndim else x
