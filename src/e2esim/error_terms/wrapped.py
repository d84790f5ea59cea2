"""An error model with one more error source: a wrapped ``ErrorModel`` and an ``Effect``.

``wrapped(base, effect)`` is the model an error term makes of the propagation's model (or of the previous term's):
a ``WrappedErrorModel`` for a single-channel model, a ``WrappedMultiChannelErrorModel`` for a multi-channel one,
so that a multi-channel retrieval still gets the joint moments. The effect's ``source`` is one more level
(``moments(<source>=...)``, requirement margins) and one more source (``without``, attribution, contributions,
coverage): every question of ``e2esim.error_model.ErrorModel`` is answered from the wrapped model's answer and the
effect's equations (``e2esim.error_terms.effects``). ``innermost`` finds the propagation's own model under the
wrappers (a stage that reads its physics, e.g. the stack budget).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from e2esim.derived import EvaluatedOnce, JointEvaluatedOnce
from e2esim.distortion.validation import sample_moments
from e2esim.error_model import (
    Contribution,
    ErrorModel,
    JointContribution,
    JointMoments,
    Moments,
    MultiChannelErrorModel,
)

SCALARS = ("analytic.with_error_terms_mean", "analytic.with_error_terms_sd", "montecarlo.with_error_terms_mean",
           "montecarlo.with_error_terms_sd", "montecarlo.with_error_terms_mean_se")
"""Output scalars of a wrapped model besides its base model's: its error with every error term (m^2/m^2)."""


class _Wrapped:
    """What both wrappers share: levels, sources, availability and ``without`` (``base``, ``effect``)."""

    def __init__(self, base: ErrorModel, effect):
        if effect.source in base.levels or effect.source in base.sources:
            raise ValueError(f"the error term {effect.source!r} has the name of a level or source the model already "
                             f"has ({', '.join(dict.fromkeys((*base.levels, *base.sources)))})")
        self.base = base
        self.effect = effect
        self.channel = base.channel

    unavailable = property(lambda self: self.base.unavailable)
    includes_speckle = property(lambda self: self.base.includes_speckle)
    added_notes: tuple = ()  # remarks of the error-term stage (``with_notes``)
    notes = property(lambda self: (*self.base.notes, *self.added_notes))
    validity = property(lambda self: self.base.validity)  # the effects are exact: the base model's range holds

    @property
    def levels(self) -> dict:
        return {**self.base.levels, self.effect.source: self.effect.level}

    @property
    def sources(self) -> tuple:
        return (*self.base.sources, self.effect.source)

    def without(self, source: str) -> ErrorModel:
        if source == self.effect.source:
            return wrapped(self.base, self.effect.removed()) if self.effect.active else self
        variant = self.base.without(source)
        return self if variant is self.base else wrapped(variant, self.effect)

    def _level(self, levels: dict):
        """The effect's level in ``levels`` (taken out of it), else its own."""
        own = levels.pop(self.effect.source, None)
        return self.effect.level if own is None else own

    def scalars(self) -> dict:
        out = dict(self.base.scalars())
        out.update(self.effect.outputs)
        if self.unavailable is None:
            m = self.current()
            out["analytic.with_error_terms_mean"] = float(m.mean)
            out["analytic.with_error_terms_sd"] = float(m.sd)
        samples = self.samples()
        if samples is not None:
            s = sample_moments(samples)
            out["montecarlo.with_error_terms_mean"] = s["mean"]
            out["montecarlo.with_error_terms_sd"] = float(np.sqrt(max(s["variance"], 0.0)))
            out["montecarlo.with_error_terms_mean_se"] = s["mean_se"]
        return out


class WrappedErrorModel(_Wrapped, EvaluatedOnce, ErrorModel):
    """A single-channel model with one more source (module docstring)."""

    @property
    def value(self) -> float:
        return self.base.value

    def moments(self, **levels) -> Moments:
        level = self._level(levels)
        # at the base's own levels, a wrapped base's memo: its current() is its moments(), kept (a model wrapped
        # k times evaluated its base k times for each of its contributions)
        m = self.base.current() if not levels and type(self.base) is WrappedErrorModel else self.base.moments(**levels)
        mean, cov = self.effect.joint(np.asarray(m.mean)[..., None], np.asarray(m.variance)[..., None, None],
                                      np.array([self.value], dtype=float), level)
        return Moments(mean[..., 0], cov[..., 0, 0])

    def contributions(self) -> dict:
        parts = dict(self.base.contributions())
        m, m0 = self.current(), self.base.current()
        parts[self.effect.source] = Contribution(float(m.mean) - float(m0.mean), float(m.variance)
                                                 - float(m0.variance), self.effect.description)
        return parts

    def relative_samples(self) -> np.ndarray | None:
        x = self.base.relative_samples()
        if x is None or self.effect.draws is None:
            return x
        return self.effect.sampled(x[..., None], np.array([self.value], dtype=float))[..., 0]


class WrappedMultiChannelErrorModel(_Wrapped, JointEvaluatedOnce, MultiChannelErrorModel):
    """A multi-channel model with one more source, for every channel at once (module docstring)."""

    def __init__(self, base: MultiChannelErrorModel, effect):
        super().__init__(base, effect)
        self.channels = base.channels

    @property
    def values(self) -> np.ndarray:
        return self.base.values

    def joint_moments(self, **levels) -> JointMoments:
        level = self._level(levels)
        j = self.base.joint_moments(**levels)
        mean, cov = self.effect.joint(np.asarray(j.mean), np.asarray(j.covariance),
                                      np.asarray(self.values, dtype=float), level)
        return JointMoments(tuple(self.channels), mean, cov)

    @cached_property
    def evaluated(self) -> JointMoments:
        """``current_joint()``, evaluated once per wrapped model (the retrieval and every requirement ask for it)."""
        return self.joint_moments()

    def joint_contributions(self) -> dict:
        parts = dict(self.base.joint_contributions())
        j, j0 = self.current_joint(), self.base.current_joint()
        parts[self.effect.source] = JointContribution(np.asarray(j.mean) - np.asarray(j0.mean),
                                                      np.asarray(j.covariance) - np.asarray(j0.covariance),
                                                      self.effect.description)
        return parts

    def joint_relative_samples(self) -> np.ndarray | None:
        x = self.base.joint_relative_samples()
        if x is None or self.effect.draws is None:
            return x
        return self.effect.sampled(x, np.asarray(self.values, dtype=float))

    def speckle_correlation(self):
        return self.base.speckle_correlation()


def wrapped(base: ErrorModel, effect) -> ErrorModel:
    """``base`` with the error source ``effect``: multi-channel when ``base`` is."""
    kind = WrappedMultiChannelErrorModel if isinstance(base, MultiChannelErrorModel) else WrappedErrorModel
    return kind(base, effect)


def with_notes(model, notes: tuple):
    """The wrapped ``model`` with ``notes`` added to its own (a stage's remarks on how the case ran); a model that a
    plug-in's ``wrap`` made some other way is left as it is."""
    if isinstance(model, _Wrapped):
        model.added_notes = (*model.added_notes, *notes)
    return model


def base_samples_shape(model: ErrorModel) -> tuple | None:
    """(M, N, C) of the model's Monte Carlo relative errors (C = 1 for a single channel), or None."""
    if isinstance(model, MultiChannelErrorModel):
        x = model.joint_relative_samples()
        return None if x is None else np.shape(x)
    x = model.relative_samples()
    return None if x is None else (*np.shape(x), 1)


def innermost(model: ErrorModel) -> ErrorModel:
    """The propagation's own model under any error terms."""
    while isinstance(model, _Wrapped):
        model = model.base
    return model


__all__ = ["SCALARS", "WrappedErrorModel", "WrappedMultiChannelErrorModel", "base_samples_shape", "innermost",
           "with_notes", "wrapped"]
