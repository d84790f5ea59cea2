"""``HVErrorModel`` for a block of sweep cases: the same questions, answered for every case at once.

What the ``hv_backscatter_error`` stage provides as ``backscatter.error`` when it runs a block of analytic cases
(``HVBackscatterErrorPropagation.forward_block``): the moments of Men et al. (2021), eqs. (11)-(12) completed to
second order, through the same kernel (``e2esim.distortion.analytic.moments_of``) with a leading case axis, so
each case gets exactly the numbers its one-case ``HVErrorModel`` gets. Levels given to ``moments`` are aligned
on the case axis (shape (B, ...)); every answer has the case axis first.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from e2esim.block import Batched, Factor, Values, join
from e2esim.distortion.analytic import HVErrorMoments, MomentInputs, moments_of
from e2esim.distortion.error_model import (
    _LEVEL_SOURCES,
    LEVELS,
    HVErrorModel,
    SystemLevels,
    _row,
    analytic_scalars,
    split_contributions,
)
from e2esim.distortion.validity import VALIDITY, ValidityRange
from e2esim.error_model import ErrorModel
from e2esim.faraday.distribution import ConstantFaraday

_NO_ROTATION = ConstantFaraday(0.0)


def block_inputs(scene: Factor, system: Factor, faraday, form: str) -> MomentInputs:
    """``MomentInputs`` of every case of a block from its scene, residual system and Faraday-rotation products,
    each distinct value read once."""
    return MomentInputs.gather(scene, system, faraday, form)


@dataclass(frozen=True, eq=False)
class HVErrorModelBlock(Batched, SystemLevels, ErrorModel):
    """The ``HVErrorModel`` of B cases (``e2esim.block.Batched``).

    scene, system, faraday : the block's products (``Factor``s; the Faraday rotation may be batched), for
    ``item``. inputs : their ``MomentInputs`` with case axis (B,). form, looks, reference : as ``HVErrorModel``.
    removed : the source this model lacks relative to the block's model ("" for the model itself). inactive :
    (B,) where that source was not active (the one-case model is then its own variant: ``without`` returns it).
    """

    scene: Factor
    system: Factor
    faraday: Factor | Batched
    inputs: MomentInputs
    form: str = "complete"
    looks: int | None = None
    reference: str = "scene"
    removed: str = ""
    inactive: np.ndarray | None = None
    _memo: dict = field(default_factory=dict, repr=False, compare=False)

    channel = "hv"

    @property
    def validity(self) -> ValidityRange:
        """The measured validity range of the analytic form (docs/theory/validity.md)."""
        return VALIDITY["hv_" + self.form]
    unavailable = None
    notes = ()

    def __len__(self) -> int:
        return len(self.inputs.levels[0])

    @property
    def value(self) -> np.ndarray:
        return self.inputs.terms.sigma_hv

    @property
    def levels(self) -> dict:  # the block's arrays, not its system products'
        xs, es, ns = self.inputs.levels
        return {"crosstalk": xs, "channel_imbalance": es, "nesz": ns}

    def moments(self, crosstalk=None, channel_imbalance=None, nesz=None, **unknown) -> HVErrorMoments:
        if unknown:
            raise TypeError(f"unknown levels {', '.join(unknown)}; this model has {', '.join(LEVELS)}")
        return moments_of(self.inputs, self.form, self.looks, self.reference, crosstalk_level=crosstalk,
                          imbalance_level=channel_imbalance, noise_power=nesz)

    def current(self) -> HVErrorMoments:
        if "current" not in self._memo:
            self._memo["current"] = self.moments()
        return self._memo["current"]

    # Sources removed (``SystemLevels.without`` memoises each) ---------------------------------------------
    def _without(self, source: str) -> HVErrorModelBlock:
        """The block's models with ``source`` removed; ``inactive`` marks the cases where it was not active
        (their one-case ``without`` is the model itself)."""
        inp = self.inputs
        n = len(self)
        if source == "faraday_rotation":
            inactive = self.faraday.no_rotation() if isinstance(self.faraday, Batched) else self.faraday.table(
                "no rotation", lambda fr: fr.mean_rad == 0.0 and fr.sd_rad == 0.0)[self.faraday.index]
            rotation = _NO_ROTATION.trig_moments() if self.form == "paper" else _NO_ROTATION.even_quadrature()[1]
            averaging = ({k: np.full(n, v) for k, v in rotation.items()} if self.form == "paper"
                         else np.broadcast_to(rotation, (n, rotation.size)))
            return self._variant(source, inactive, dataclasses.replace(inp, averaging=averaging))
        if source == "gain":
            inactive = self.system.table("no gain error", lambda sy: not sy.has_gain_error)[self.system.index]
            return self._variant(source, inactive, dataclasses.replace(inp, gain=(np.ones(n), np.ones(n))))
        xs, es, ns = inp.levels
        if "level variants" not in self._memo:  # the three level sources in one evaluation, as HVErrorModel does
            z = np.zeros(n)
            self._memo["level variants"] = self.moments(crosstalk=np.stack([z, xs, xs], -1),
                                                        channel_imbalance=np.stack([es, z, es], -1),
                                                        nesz=np.stack([ns, ns, z], -1))
        row = _LEVEL_SOURCES[source]
        levels = [xs, es, ns]
        levels[row] = np.zeros(n)
        variant = self._variant(source, np.zeros(n, dtype=bool), dataclasses.replace(inp, levels=tuple(levels)))
        variant._memo["current"] = _row_block(self._memo["level variants"], row)
        return variant

    def _variant(self, source: str, inactive: np.ndarray, inputs: MomentInputs) -> HVErrorModelBlock:
        return dataclasses.replace(self, inputs=inputs, removed=source, inactive=inactive, _memo={})

    def contributions(self) -> dict:
        """``HVErrorModel.contributions`` of every case, arrays (B,)."""
        return split_contributions(self.current(), self.without("faraday_rotation").current())

    # Block behaviour -----------------------------------------------------------------------------------------
    def item(self, i: int) -> HVErrorModel:
        model = HVErrorModel(self.scene.item(i), self.system.item(i), self.faraday.item(i), self.form, self.looks,
                             self.reference)
        if "current" in self._memo:
            model._memo["current"] = _row(self._memo["current"], i)
        return model

    def take(self, positions) -> HVErrorModelBlock:
        return dataclasses.replace(self, scene=self.scene.take(positions), system=self.system.take(positions),
                                   faraday=self.faraday.take(positions), inputs=self.inputs.take(positions),
                                   inactive=None if self.inactive is None else self.inactive[positions], _memo={})

    @classmethod
    def concatenate(cls, parts: list) -> HVErrorModelBlock:
        first = parts[0]
        if any((p.form, p.looks, p.reference, p.removed) != (first.form, first.looks, first.reference, first.removed)
               for p in parts):
            raise ValueError("blocks of error models with different settings cannot be joined")
        inputs = MomentInputs.concatenate([p.inputs for p in parts])
        return dataclasses.replace(first, scene=Factor.concatenate([p.scene for p in parts]),
                                   system=Factor.concatenate([p.system for p in parts]),
                                   faraday=join([p.faraday for p in parts]), inputs=inputs,
                                   inactive=None if first.inactive is None else np.concatenate(
                                       [p.inactive for p in parts]), _memo={})

    def scalar_columns(self) -> dict:
        return dict(analytic_scalars(self.current()))

    def note_column(self) -> Values:
        return Values.repeated((), len(self))


def _row_block(moments: HVErrorMoments, k: int) -> HVErrorMoments:
    """Column ``k`` of the last axis of moments evaluated over (B, levels)."""
    values = {f.name: getattr(moments, f.name) for f in dataclasses.fields(moments)}
    return HVErrorMoments(**{name: (v[..., k] if isinstance(v, np.ndarray) and v.ndim == 2 else v)
                             for name, v in values.items()})


__all__ = ["HVErrorModelBlock", "block_inputs"]
