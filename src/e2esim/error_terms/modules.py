"""The ``error_terms`` modules: each adds one named error source to the propagation's error model.

A scenario lists them in its ``error_terms`` section; they wrap ``backscatter.error`` in order
(``e2esim.error_terms.stage``). A term is a ``Module`` (not a stage): it says which products it reads
(``needs``, ``uses``) and makes its ``Effect`` for a case (``effect``); the base class names the source
(``source``, default its type name), draws its random numbers when the model has Monte Carlo samples, and wraps.
A plug-in adds a term by subclassing ``ErrorTerm`` and registering it under the kind ``error_terms``
(docs/writing-a-module.md).
"""

from __future__ import annotations

import math
import re
from typing import ClassVar

from e2esim.error_terms.block_case import UNREAD_MODEL, case_of
from e2esim.error_terms.block_wrapped import block_wrapped, same_outputs
from e2esim.error_terms.effects import AddedPower, ExtraVariance, LogNormalGain
from e2esim.error_terms.wrapped import base_samples_shape, wrapped
from e2esim.errors import PhysicsInputError
from e2esim.module import Module, fail, fast_path
from e2esim.params import Param

_NAME = re.compile(r"^[a-z][a-z0-9_]*$")

MAP_CELL_KEYS = {"lat": "scene.lat_deg", "lon": "scene.lon_deg", "month": "ionosphere.month",
                 "pass": "ionosphere.pass", "solar": "ionosphere.solar"}
"""The sweep keys a map sweep sets for each cell (e2esim.maps.grid.MAP_KEYS; a test keeps the two equal): an error
term that depends on place and time reads its cell from them when the scenario gives none."""


def source_param(default: str) -> Param:
    """The ``source`` parameter every term has: the name of its level and source."""
    return Param("source", "str", "name of the error source and of its level (attribution, margins, coverage); "
                 "lower case, digits and _", default=default)


class ErrorTerm(Module):
    """Base class of an error term (module docstring). Subclasses set ``params`` (with ``source_param``),
    ``needs``/``uses`` and ``effect``."""

    kind = "error_terms"
    needs: tuple = ()
    uses: tuple = ()

    def setup(self) -> None:
        if not _NAME.match(self.si["source"]):
            raise PhysicsInputError(f"source {self.si['source']!r} is not a name: use lower case letters, digits "
                                    "and _, starting with a letter", key="source")

    @property
    def source(self) -> str:
        return self.si["source"]

    @property
    def sources(self) -> tuple:
        """The sources (and levels) the term adds: its ``source``; a term that adds several says which."""
        return (self.source,)

    effects_take_blocks: ClassVar[bool] = False
    """True when ``case_effects`` (and ``effect``) may be asked for each case of a block from its one-case view
    (``e2esim.error_terms.block_case``): they read the case only through its products, inputs and settings, and
    draw from ``case.rng`` only when they must (a draw hands the block back). The stage then wraps a block's
    batched error model at once (``wrap_block``). A subclass that overrides ``effect``, ``case_effects`` or
    ``wrap`` without saying so again runs case by case (``e2esim.module.fast_path``), and the run's notes say so."""
    fast_path_hooks: ClassVar[tuple] = ("effect", "wrap", "wrap_block", "block_case_effects")
    effects_ignore_model: ClassVar[bool] = False
    """True when ``case_effects`` does not read the model it wraps: a block then hands it no one-case model
    (``case_model``). Like ``effects_take_blocks`` it holds only for the class that declares it and the ``effect``
    it defines (``e2esim.module.fast_path``): a subclass that overrides ``effect`` reads the model again."""

    def effect(self, case, model):
        """The ``Effect`` of this term on ``model`` (the error model it wraps) in ``case``."""
        raise NotImplementedError

    def case_effects(self, case, model) -> tuple:
        """The ``Effect``s of this term in ``case``, wrapped in order: ``(effect(case, model),)``; a term that adds
        several sources gives one per source."""
        return (self.effect(case, model),)

    @property
    def takes_blocks(self) -> bool:
        """Whether this term's effects may be made from a block's cases (``effects_take_blocks``, as
        ``e2esim.module.fast_path`` checks it)."""
        return fast_path(self, "effects_take_blocks", "case_effects") is not None

    def wrap(self, model, case):
        """``model`` with this term's sources; their random numbers drawn from ``case.rng`` when the model has
        Monte Carlo samples."""
        effects = self.case_effects(case, model)
        shape = base_samples_shape(model)
        for effect in effects:
            if shape is not None:
                effect = effect.draw(case.rng, shape)
            model = self._wrapped(wrapped, model, effect)
        return model

    def wrap_block(self, model, block):
        """``model``, the batched single-channel error model of ``block``, with this term's sources in every case:
        each case's effects from its one-case view and model (``e2esim.error_terms.block_case``); the block is
        handed back (``NotBatched``) where an effect draws or the cases' effects report different scalars."""
        per_case = self.block_case_effects(block, model)
        for k in range(len(per_case[0])):
            effects = [effects[k] for effects in per_case]
            if not same_outputs(effects):
                block.per_case(f"{self.identity}: the cases' effects report different output scalars")
            model = self._wrapped(block_wrapped, model, effects)
        return model

    def block_case_effects(self, block, model) -> list:
        """``case_effects`` of every case of ``block``, each from its one-case view and model; a term may make them
        together (vectorised over the cases) where it gives each case, bit for bit, its one-case effects."""
        models = self.case_models(model)
        return [self.case_effects(case_of(block, i), models[i]) for i in range(len(block))]

    def case_models(self, model) -> list:
        """Every case's model of the block's ``model`` for ``case_effects``, or ``UNREAD_MODEL`` for each when the
        term does not read it (``effects_ignore_model``; ``e2esim.error_terms.block_case``); one case gets its model
        (a case alone cannot hand a block back)."""
        if len(model) > 1 and fast_path(self, "effects_ignore_model", "case_effects"):
            return [UNREAD_MODEL] * len(model)
        return [model.item(i) for i in range(len(model))]

    def _wrapped(self, make, model, effect):
        try:
            return make(model, effect)
        except ValueError as exc:
            raise fail(self, str(exc), "give the term another source name", key="source") from exc


class AddedNoise(ErrorTerm):
    """Additive circular Gaussian noise of a given power in every channel's looks (``AddedPower``), e.g. a noise
    floor the processor does not remove, or residual interference."""

    type_name = "added_noise"
    summary = "noise of a given power added to every channel's looks, subtracted or not (biased estimate)"
    params = (
        Param("power_db", "float", "noise power N as a backscattering coefficient, 10 log10(N) (like an NESZ)",
              unit="dB"),
        Param("subtracted", "bool", "the power's mean is known and subtracted (only its spread over the looks "
              "remains)", default=False),
        source_param("added_noise"),
    )

    effects_take_blocks = True
    effects_ignore_model = True

    def effect(self, case, model):
        return AddedPower(self.source, self.si["power_linear"], "added noise power (Ahmed et al. 2014, eq. 21)",
                          looks=case.settings.looks, subtracted=self.si["subtracted"])


class GainError(ErrorTerm):
    """A multiplicative gain error common to every channel, log-normal in dB (``LogNormalGain``), e.g. an
    uncorrected drift of the radiometric calibration. Its level is the variance of ln g."""

    type_name = "gain_error"
    summary = "multiplicative gain error, normal in dB (offset and SD), common to every channel"
    params = (
        Param("offset_db", "float", "mean of the gain error in dB", default=0.0, unit="dB", convert=False),
        Param("sd_db", "float", "standard deviation of the gain error in dB", default=0.0, unit="dB",
              convert=False, minimum=0.0),
        source_param("gain_error"),
    )

    effects_take_blocks = True
    effects_ignore_model = True

    def effect(self, case, model):
        s = self.si["sd_db"] * math.log(10.0) / 10.0
        return LogNormalGain(self.source, s * s, "multiplicative gain error (log-normal)",
                             offset_db=self.si["offset_db"])


class ExtraRelativeVariance(ErrorTerm):
    """A zero-mean random error of a given relative SD in every channel (``ExtraVariance``), e.g. an item of an
    error budget not modelled elsewhere (an extra amplitude error). Its level is the relative variance r^2."""

    type_name = "extra_variance"
    summary = "zero-mean random error of a given relative SD, independent in every channel"
    params = (
        Param("relative_sd_percent", "float", "standard deviation r of the error relative to sigma", unit="%",
              minimum=0.0),
        source_param("extra_variance"),
    )

    effects_take_blocks = True
    effects_ignore_model = True

    def effect(self, case, model):
        r = self.si["relative_sd_fraction"]
        return ExtraVariance(self.source, r * r, "extra zero-mean random error")


__all__ = ["AddedNoise", "ErrorTerm", "ExtraRelativeVariance", "GainError", "source_param"]
