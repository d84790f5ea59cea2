"""A block of single-channel error models, each with one more error source: what ``WrappedErrorModel`` is for a case
alone, over the leading case axis of a batched error model (``e2esim.block.Batched``).

``BlockWrappedModel(base, effects)``: ``base`` is the batched model of the block (the propagation's, or the previous
term's), ``effects`` the ``Effect`` of every case (``BlockEffects``: each distinct effect stored once, with what
derives from the effects alone). Every question
(moments at changed levels, ``without`` a source, contributions, output scalars) is answered with the one-case
equations of ``WrappedErrorModel`` (``e2esim.error_terms.effects``), evaluated once per distinct effect over the
cases that have it, with those cases' arrays in the shapes the one-case model gives them (the case axis in front,
then any axes of the levels asked, then the channel axis): each number is, bit for bit, what the case gets alone
(``item``; tests/test_error_terms_block.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from e2esim.block import Batched, Values
from e2esim.derived import EvaluatedOnce, RemovedOnce, knowing
from e2esim.error_model import Contribution, ErrorModel, Moments
from e2esim.error_terms.effect_stack import stack_groups, stacked, stacked_columns
from e2esim.error_terms.wrapped import wrapped


def _leading(x: np.ndarray, rows, ndim: int) -> np.ndarray:
    """The cases ``rows`` of ``x`` (case axis first) with trailing length-1 axes up to ``ndim`` axes; a value with no
    case axis (a level shared by every case) as it is."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 0:
        return x
    x = x[rows]
    return x.reshape(x.shape + (1,) * (ndim - x.ndim))


@dataclass(frozen=True, eq=False)
class BlockEffects:
    """The ``Effect`` of every case of a block (``cases``: each distinct effect stored once) and what derives from
    them alone, once (``cached_property``s): their levels, their stacks, the effects with their source removed. Every
    variant of a block model that keeps these effects (``BlockWrappedModel.without`` another source) holds this same
    object, so a Shapley split's 2^k variants stack and remove the effects once, not once each."""

    cases: Values

    values = property(lambda self: self.cases.values)  # the distinct effects, as in ``Values``
    index = property(lambda self: self.cases.index)

    @cached_property
    def level(self) -> np.ndarray:
        """The effect's level in every case, (B,)."""
        return np.array([e.level for e in self.values], dtype=float)[self.index]

    @cached_property
    def stacks(self) -> list:
        """[(effect, columns, rows)]: the cases ``rows`` whose effects are evaluated together, as ``effect`` alone
        (columns None: one distinct effect) or stacked with ``columns`` (``e2esim.error_terms.effect_stack``)."""
        values, index = self.values, self.index
        groups = stack_groups(values)
        out = []
        for group in groups:
            rows = slice(None) if len(groups) == 1 else np.flatnonzero(np.isin(index, group))
            if isinstance(rows, np.ndarray) and not len(rows):  # effects no case of this block has (``take``)
                continue
            if len(group) == 1:
                out.append((values[group[0]], None, rows))
                continue
            position = np.zeros(len(values), dtype=np.int64)
            position[group] = np.arange(len(group))
            table = stacked_columns([values[k] for k in group])
            out.append((values[group[0]], {name: c[position[index[rows]]] for name, c in table.items()}, rows))
        return out

    @cached_property
    def removed(self) -> tuple | None:
        """(the effects with their source removed, the cases where it was not active), or None where no case has
        it active."""
        active = np.array([e.active for e in self.values], dtype=bool)
        if not active.any():
            return None
        cases = Values([e.removed() if a else e for e, a in zip(self.values, active)], self.index)
        return BlockEffects(cases), ~active[self.index]


@dataclass(frozen=True, eq=False)
class BlockWrappedModel(Batched, RemovedOnce, EvaluatedOnce, ErrorModel):
    """A batched single-channel model with one more source per case (module docstring). effects : the cases'
    effects and what derives from them alone (``BlockEffects``, shared by the variants that keep them). inactive :
    for a model with a source removed (``without``), the cases where it was not active (their model is their own
    variant)."""

    base: object
    effects: BlockEffects
    inactive: object = None

    def __post_init__(self):
        first = self.effects.values[0]
        if first.source in self.base.levels or first.source in self.base.sources:
            raise ValueError(f"the error term {first.source!r} has the name of a level or source the model already "
                             f"has ({', '.join(dict.fromkeys((*self.base.levels, *self.base.sources)))})")

    # What the base model says ------------------------------------------------------------------------------------
    channel = property(lambda self: self.base.channel)
    unavailable = property(lambda self: self.base.unavailable)
    includes_speckle = property(lambda self: self.base.includes_speckle)
    notes = property(lambda self: self.base.notes)
    validity = property(lambda self: self.base.validity)
    value = property(lambda self: self.base.value)

    @property
    def source(self) -> str:
        return self.effects.values[0].source

    @property
    def level(self) -> np.ndarray:
        """The effect's level in every case, (B,)."""
        return self.effects.level

    @property
    def levels(self) -> dict:
        return {**self.base.levels, self.source: self.level}

    @property
    def sources(self) -> tuple:
        return (*self.base.sources, self.source)

    # Moments -------------------------------------------------------------------------------------------------------
    def moments(self, **levels) -> Moments:
        """``WrappedErrorModel.moments`` of every case (levels broadcast against the case axis)."""
        return self._moments(levels) if levels else self.own_moments

    @cached_property
    def own_moments(self) -> Moments:
        """``moments()`` at its own levels, derived once: the variants of a Shapley split
        (``ErrorModel.source_subsets``) that hold this model as their base ask it once, not once each."""
        return self._moments({})

    def _moments(self, levels: dict) -> Moments:
        own = levels.pop(self.source, None)
        level = self.level if own is None else np.asarray(own, dtype=float)
        m = self.base.moments(**levels)
        mean, variance = np.asarray(m.mean, dtype=float), np.asarray(m.variance, dtype=float)
        values = np.asarray(self.value, dtype=float)
        ndim = max(mean.ndim, variance.ndim, level.ndim, 1)
        shape = np.broadcast_shapes(*(x.shape + (1,) * (ndim - x.ndim) for x in (mean, variance, level) if x.ndim),
                                    (len(self),) + (1,) * (ndim - 1))
        out_mean, out_var = np.empty(shape), np.empty(shape)
        for first, columns, rows in self.effects.stacks:
            effect = first if columns is None else stacked(first, columns, ndim)
            new_mean, cov = effect.joint(_leading(mean, rows, ndim)[..., None], _leading(variance, rows, ndim)[
                ..., None, None], _leading(values, rows, ndim)[..., None], _leading(level, rows, ndim))
            out_mean[rows] = new_mean[..., 0]
            out_var[rows] = cov[..., 0, 0]
        return Moments(out_mean, out_var)

    # Sources (``RemovedOnce.without``) ---------------------------------------------------------------------------
    def _without(self, source: str) -> ErrorModel:
        if source == self.source:
            if self.effects.removed is None:
                return self
            return BlockWrappedModel(self.base, *self.effects.removed)
        variant = self.base.without(source)
        if variant is self.base:
            return self
        # the same effects (one object): stacked and removed as here, once
        return BlockWrappedModel(variant, self.effects, getattr(variant, "inactive", None))

    def contributions(self) -> dict:
        parts = dict(self.base.contributions())
        m, m0 = self.current(), self.base.current()
        parts[self.source] = Contribution(np.asarray(m.mean) - np.asarray(m0.mean, dtype=float),
                                          np.asarray(m.variance) - np.asarray(m0.variance, dtype=float),
                                          self.effects.values[0].description)
        return parts

    # A block of cases (``e2esim.block.Batched``) -------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self.effects.cases)

    def item(self, i: int) -> ErrorModel:
        """Case i's ``WrappedErrorModel``, with the moments the block computed for it."""
        model = wrapped(self.base.item(i), self.effects.cases[i])
        if "evaluated" in vars(self):
            knowing(model, evaluated=Moments(self.evaluated.mean[i], self.evaluated.variance[i]))
        return model

    def take(self, positions) -> BlockWrappedModel:
        return BlockWrappedModel(self.base.take(positions), BlockEffects(self.effects.cases.take(positions)),
                                 None if self.inactive is None else self.inactive[positions])

    @classmethod
    def concatenate(cls, parts: list) -> BlockWrappedModel:
        first = parts[0]
        inactive = None if first.inactive is None else np.concatenate([p.inactive for p in parts])
        return cls(type(first.base).concatenate([p.base for p in parts]),
                   BlockEffects(Values.concatenate([p.effects.cases for p in parts])), inactive)

    def scalar_columns(self) -> dict:
        """``WrappedErrorModel.scalars`` of every case: the base model's, the effect's outputs, the error with every
        error term (analytic: a block has no Monte Carlo)."""
        out = dict(self.base.scalar_columns())
        for k, (name, _) in enumerate(self.effects.values[0].outputs):
            out[name] = np.array([float(e.outputs[k][1]) for e in self.effects.values])[self.effects.index]
        m = self.current()
        out["analytic.with_error_terms_mean"] = np.asarray(m.mean, dtype=float)
        out["analytic.with_error_terms_sd"] = np.asarray(m.sd, dtype=float)
        return out

    def note_column(self) -> Values:
        return self.base.note_column()


def same_outputs(effects: list) -> bool:
    """Whether every effect reports the same output scalars, in the same order (one column per name)."""
    names = {tuple(name for name, _ in e.outputs) for e in effects}
    return len(names) == 1


def block_wrapped(base, effects: list) -> BlockWrappedModel:
    """``base`` (a batched single-channel model) with case i's effect ``effects[i]``."""
    return BlockWrappedModel(base, BlockEffects(Values.of(effects)))


__all__ = ["BlockEffects", "BlockWrappedModel", "block_wrapped", "same_outputs"]
