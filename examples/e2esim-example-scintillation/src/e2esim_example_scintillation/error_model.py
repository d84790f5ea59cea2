"""An error model with one more source: amplitude scintillation multiplying the measured intensity.

The estimate with scintillation is ``sigma' = sigma_hat g``, with g independent of everything else, E[g] = 1,
Var[g] = V (``Scintillation.variance``). With ``e = sigma_hat - sigma`` of mean m and variance v (the wrapped
model), the error ``e' = sigma_hat g - sigma`` has, exactly,

    E[e'] = m,        Var[e'] = E[sigma_hat^2] E[g^2] - E[sigma_hat]^2 = v (1 + V) + (sigma + m)^2 V.

V is a level of the model ("scintillation"), so requirement margins find how much scintillation a mission
can take; "scintillation" is a source, so the attribution says how much it adds.
"""

from __future__ import annotations

import numpy as np

from e2esim.error_model import Contribution, ErrorModel, Moments

LEVEL = SOURCE = "scintillation"


class ScintillationErrorModel(ErrorModel):
    """``base`` (any e2esim ``ErrorModel``) with a multiplicative intensity factor of variance ``variance``.

    factor_samples : Monte Carlo draws of g, shape of the base model's samples (or None).
    """

    def __init__(self, base: ErrorModel, variance: float, factor_samples=None):
        self.base = base
        self.variance = float(variance)
        self.factor_samples = factor_samples
        self.channel = base.channel
        self.unavailable = base.unavailable
        self.includes_speckle = base.includes_speckle
        self.notes = base.notes
        self.validity = base.validity  # the factor is exact: the base model's range holds (margins stop there)
        self._memo: dict = {}

    @property
    def value(self) -> float:
        return self.base.value

    @property
    def levels(self) -> dict:
        return {**self.base.levels, LEVEL: self.variance}

    @property
    def sources(self) -> tuple:
        return (*self.base.sources, SOURCE)

    def moments(self, scintillation=None, **levels):
        m = self.base.moments(**levels)
        v = self.variance if scintillation is None else np.asarray(scintillation, dtype=float)
        mean = np.asarray(m.mean)
        return Moments(mean, np.asarray(m.variance) * (1 + v) + (self.value + mean) ** 2 * v)

    def current(self):
        if "current" not in self._memo:
            self._memo["current"] = self.moments()
        return self._memo["current"]

    def without(self, source: str) -> ErrorModel:
        if source == SOURCE:
            return self if self.variance == 0.0 else ScintillationErrorModel(self.base, 0.0)
        variant = self.base.without(source)
        return self if variant is self.base else ScintillationErrorModel(variant, self.variance)

    def contributions(self) -> dict:
        parts = dict(self.base.contributions())
        added = float(self.current().variance) - float(self.base.current().variance)
        parts[SOURCE] = Contribution(0.0, added, "amplitude scintillation (multiplicative intensity factor)")
        return parts

    def relative_samples(self):
        x = self.base.relative_samples()
        if x is None or self.factor_samples is None:
            return x
        return (1.0 + x) * self.factor_samples - 1.0

    def scalars(self) -> dict:
        out = dict(self.base.scalars())
        if self.unavailable is None:
            out["analytic.scintillated_sd"] = float(self.current().sd)
        return out
