"""A retrieval model's map from the relative sigma_hv error x to the relative AGB error q at one AGB.

Any retrieval model (``e2esim.retrieval.models``) gives q as the monotone (non-decreasing) image of
x = e / sigma at the case's AGB, saturation included (an estimate that saturates is capped at ``agb_max``), so the
quantiles of q are the images of those of x (Men et al. 2021, Section V-B, for the power law).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.memo_keys import value_key

_X_SEARCH = (-1.0 + 1e-12, 1e6)  # relative sigma errors searched when inverting a map numerically

THRESHOLDS_KEPT = 64
"""Thresholds a kernel memo keeps (a requirement asks one or two levels of each distinct map of a run)."""


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

    def threshold(self, level: float, memo=None) -> float:
        """x at which q reaches ``level`` (> -1): +inf if q never exceeds it (cap), -1 if q never falls to it.

        memo : the run's ``KernelMemo`` (``case.services.memo``, handed in by the requirement that asks), which
        keeps the bisection for every map of the same values asked at the same level (the cases of a sweep that
        share an AGB and a model); None: bisected anew. The same bisection either way."""
        if memo is None:
            return self._threshold_numeric(level)
        try:
            key = ("relative error threshold", value_key(self, float(level)))
        except TypeError:  # a plug-in model with a field that cannot key a memo: not kept
            return self._threshold_numeric(level)
        return memo.recall(key, lambda: self._threshold_numeric(level), keep=THRESHOLDS_KEPT)

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

