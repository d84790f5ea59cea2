"""The base class of every pluggable module, and the kinds of module a scenario chains.

A module answers one physical question. It declares its parameters once (``params``), is built from a
YAML section or a Python call with the same validation, and has one method, ``forward``, that takes the
case state (``e2esim.chain.CaseState``) and returns it with the field it provides filled in. To add an
instrument, subclass an existing instrument module or ``Module`` itself (docs/writing-a-module.md).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar, Mapping

from e2esim.errors import ConfigError, Location, PhysicsInputError
from e2esim.params import validate_section

KINDS = (
    "orbit",
    "scene",
    "instrument",
    "ionosphere",
    "calibration",
    "propagation",
    "retrieval",
    "requirement",
)
"""Module kinds in the order the runner chains them. The instrument comes before the ionosphere (unlike
the sketch in design.md) because Faraday rotation scales as 1/f^2 with the radar frequency."""

KIND_DOCS = {
    "orbit": "acquisition geometry: where and when the mission looks (AcquisitionGeometry)",
    "ionosphere": "Faraday rotation distribution seen by the case (FaradayDistribution)",
    "scene": "scattering covariance of the target for an AGB level and biome (ScatteringCovariance)",
    "instrument": "system-error statistics, noise and gain of the radar (SystemErrorModel)",
    "calibration": "what calibration leaves of the system errors and Faraday rotation",
    "propagation": "error of the backscattering coefficient (BackscatterError)",
    "retrieval": "relative AGB error through a backscatter-AGB model (AGBError)",
    "requirement": "verdict of a mission requirement on the AGB error (RequirementVerdict)",
}


class Module(ABC):
    """Base class: a validated configuration and a ``forward`` step of the chain.

    Class attributes a subclass sets:

    kind : one of ``KINDS``.
    type_name : the name a scenario uses in ``type:`` (unique within the kind).
    summary : one line for ``e2esim modules`` and the scenario reference.
    params : tuple of ``Param``/``ParamGroup``; the single declaration of the parameters.
    requires : names of ``CaseState`` fields the module reads (checked before a run).
    provides : names of ``CaseState`` fields it fills.

    Subclasses override ``setup`` (derive physics objects from ``self.config``; raise
    ``PhysicsInputError`` for impossible combinations) and ``forward``.
    """

    kind: ClassVar[str] = ""
    type_name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    params: ClassVar[tuple] = ()
    requires: ClassVar[tuple] = ()
    provides: ClassVar[tuple] = ()

    def __init__(self, **values: Any):
        self._configure(values, Location(source=f"{type(self).__name__}(...)"))

    @classmethod
    def from_config(cls, section: Mapping | None, where: Location) -> "Module":
        """Build from a scenario section (its ``type`` and ``name`` keys are ignored here)."""
        obj = cls.__new__(cls)
        obj._configure(section or {}, where, ignore=("type", "name"))
        return obj

    def _configure(self, values: Mapping, where: Location, ignore=()) -> None:
        self.config = validate_section(self.params, values, where, ignore=ignore)
        self.location = where
        try:
            self.setup()
        except PhysicsInputError as exc:
            raise ConfigError(exc.location(where), str(exc)) from exc

    def setup(self) -> None:
        """Derive physics objects from ``self.config`` (override)."""

    @abstractmethod
    def forward(self, state):
        """Return ``state`` with this module's result filled in."""

    # Plain-object behaviour: equality, repr and pickling go through the configuration.
    def __eq__(self, other: object) -> bool:
        return type(self) is type(other) and self.config == other.config  # type: ignore[attr-defined]

    def __hash__(self) -> int:
        return hash((type(self), repr(sorted(self.config.items()))))

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.config.items())
        return f"{type(self).__name__}({args})"

    def __reduce__(self):
        # Pickle the built module as it is (configuration, location and the physics objects ``setup``
        # made), so a worker process or a dask worker gets exactly this module without re-reading files.
        state = dict(self.__dict__)
        if "location" in state:  # the line-number table can be large and is only for messages
            loc = state["location"]
            state["location"] = Location(loc.source, loc.key_path)
        return (_restore, (type(self), state))


def _restore(cls, state):
    obj = cls.__new__(cls)
    obj.__dict__.update(state)
    return obj
