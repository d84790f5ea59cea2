"""The base classes of every pluggable module: ``Module`` (a validated configuration) and ``Stage`` (a module
the runner chains).

A module answers one physical question. It declares its parameters once (``params``) and is built from a
YAML section or a Python call with the same validation; the values are converted to SI once (``si``),
and ``derive`` may adjust them (an instrument with an extra loss, say) without touching the configuration
the user gave. A ``Stage`` also declares the products it ``needs``, may ``use`` and ``provides``
(``e2esim.products``) and has one method, ``forward``, that returns its new products. Modules that are
parts of a stage rather than stages themselves (calibration steps, requirements, Faraday-rotation
estimators) subclass ``Module`` directly. docs/writing-a-module.md walks through both.
"""

from __future__ import annotations

import inspect
from abc import ABC, abstractmethod
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np

from e2esim.errors import ConfigError, Location, PhysicsInputError
from e2esim.params import Param, ParamGroup, to_si, validate_section


class ParamReads(dict):
    """A module's parameter values that note which top-level names are read (``[]`` and ``get``): how a sweep or
    an override of a key the module never read is reported as changing nothing (``e2esim.runner.no_effect``).
    Copies (``dict(...)``, ``**``), iteration and pickling do not note reads; a copy is an ordinary dict."""

    __slots__ = ("reads",)
    plain_as_dict = True  # e2esim.runner.plaindata writes it as the dict it is

    def __getitem__(self, key):
        self.reads.add(key)
        return dict.__getitem__(self, key)

    def get(self, key, default=None):
        self.reads.add(key)
        return dict.get(self, key, default)

    def __reduce__(self):
        return (dict, (dict(self),))


def _noting(values: dict, reads: set) -> ParamReads:
    out = ParamReads(values)
    out.reads = reads
    return out


def _frozen(values: dict, reads: set | None = None) -> Mapping:
    inner = {k: _frozen(v) if isinstance(v, dict) else v for k, v in values.items()}
    return MappingProxyType(inner if reads is None else _noting(inner, reads))


class Module:
    """Base class: a validated configuration, its SI values and what ``setup`` derives from them.

    Class attributes a subclass sets:

    kind : the registry kind (a scenario section for stages: "instrument", "propagation", ...).
    type_name : the name a scenario uses in ``type:`` (unique within the kind).
    summary : one line for ``e2esim modules`` and the scenario reference.
    params : tuple of ``Param``/``ParamGroup`` and constraints; the single declaration of the parameters.

    Instances carry ``config`` (the values as the user gave them, defaults filled in, YAML units),
    ``si`` (read-only: every value in SI under its SI name, ``Param.si_name``, after ``derive``) and
    ``location`` (where in the scenario the section is, for messages). Subclasses override ``derive``
    (adjust or add SI values) and ``setup`` (build physics objects; raise ``PhysicsInputError`` for
    impossible combinations).
    """

    kind: ClassVar[str] = ""
    type_name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    params: ClassVar[tuple] = ()

    def __init__(self, **values: Any):
        self._configure(values, Location(source=f"{type(self).__name__}(...)"))

    @classmethod
    def from_config(cls, section: Mapping | None, where: Location, services=None) -> Module:
        """Build from a scenario section (its ``type`` and ``name`` keys are ignored here). ``services`` (the
        resolve's ``e2esim.case.Services``, or None) go to ``setup`` where it takes them (``setup(self,
        services=None)``): what a set-up that reads a user's file keeps in ``services.memo``."""
        obj = cls.__new__(cls)
        obj._configure(section or {}, where, ignore=("type", "name"), services=services)
        return obj

    def _configure(self, values: Mapping, where: Location, ignore=(), services=None) -> None:
        config = validate_section(self.params, values, where, ignore=ignore)
        self.location = where
        self._reads: set = set()  # names read from ``config`` and ``si`` once built (``params_read``)
        try:
            si = self.derive(to_si(self.params, config))
            self.config = _noting(config, self._reads)
            self.si = _frozen(si, self._reads)
            if services is not None and takes_services(self.setup):
                self.setup(services=services)
            else:
                self.setup()
        except PhysicsInputError as exc:
            raise ConfigError(exc.location(where), str(exc)) from exc

    def params_read(self) -> set | None:
        """The names of the parameters (their ``config`` names) read from ``config`` or ``si`` since the module
        was built (in ``setup``, ``forward``, ...) in this process; None when it read a value ``derive`` made,
        which may stand for any parameter."""
        names = {}
        for p in self.params:
            if isinstance(p, (Param, ParamGroup)):
                names[p.name] = p.name
                names[getattr(p, "si_name", p.name)] = p.name
        reads = getattr(self, "_reads", None)
        if reads is None or any(key not in names for key in reads):
            return None
        return {names[key] for key in reads}

    def reads_noted(self) -> frozenset:
        """The names ``params_read`` works from, as read so far in this process (a worker sends them to the main
        process, which adds them to its own copy of the module with ``note_reads``)."""
        return frozenset(getattr(self, "_reads", ()))

    def note_reads(self, names) -> None:
        """Add ``names`` another process read (``reads_noted``) to this module's record (``params_read``)."""
        reads = getattr(self, "_reads", None)
        if reads is not None:
            reads.update(names)  # in place: ``config`` and ``si`` note into this very set

    def derive(self, si: dict) -> dict:
        """The SI values the module works with, from those of its parameters (override to adjust or add:
        call ``super().derive(si)`` first). ``config`` is left as the user gave it, so a module built from
        its own ``config`` is equal to it (``e2esim.testing.check_module``)."""
        return si

    def setup(self) -> None:
        """Derive physics objects from ``self.si`` (override)."""

    @property
    def identity(self) -> str:
        """How messages name this module: "propagation type 'hv_backscatter_error'"."""
        return f"{self.kind} type {self.type_name!r}"

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
        state["si"] = _thawed(state["si"]) if "si" in state else None
        if "location" in state:  # the line-number table can be large and is only for messages
            loc = state["location"]
            state["location"] = Location(loc.source, loc.key_path)
        return (_restore, (type(self), state))


def takes_services(method) -> bool:
    """Whether ``method`` (a module's ``setup`` or a stage's ``map_cells``) has a ``services`` parameter: only
    those are handed the resolve's ``Services``, so hooks written without it keep working."""
    return "services" in inspect.signature(method).parameters


def _thawed(values: Mapping) -> dict:
    return {k: _thawed(v) if isinstance(v, Mapping) else v for k, v in values.items()}


def _restore(cls, state):
    obj = cls.__new__(cls)
    reads = state.setdefault("_reads", set())
    if state.get("si") is not None:
        state["si"] = _frozen(state["si"], reads)
    if isinstance(state.get("config"), dict):
        state["config"] = _noting(state["config"], reads)
    obj.__dict__.update(state)
    return obj


class Stage(Module, ABC):
    """A module the runner chains: it needs products, provides products, and ``forward`` makes them.

    Class attributes (instances may narrow them as properties when a configuration changes what they need):

    needs : names of products that must be in the case before this stage runs.
    uses : names of products it reads when a stage of the chain provides them (optional inputs).
    provides : the ``Product`` declarations it adds (``e2esim.products``).

    ``forward(case)`` reads ``case[name]`` for what it needs, draws random numbers only from ``case.rng``
    and returns ``{product name: value}`` for every product it provides; it never changes what is in the
    case. Product values may carry a leading case axis (a block of sweep cases evaluated at once); a stage
    written for one case sees scalars there.
    """

    needs: ClassVar[tuple] = ()
    uses: ClassVar[tuple] = ()
    provides: ClassVar[tuple] = ()
    forward_takes_blocks: ClassVar[bool] = False
    """True when ``forward`` also takes a block of cases (``e2esim.block.Block``: products with a case axis, read
    with ``case.column``) and answers for all of them at once, or hands the block back (``case.per_case``); the
    batched engine then gives it whole blocks (``batched_run``). A subclass that overrides ``forward`` without
    saying so runs case by case."""
    fast_path_hooks: ClassVar[tuple] = ()
    """Methods besides ``forward`` that its answer for a block of cases relies on (where it reads them for a case
    alone only): a subclass that overrides one of them, or ``forward``, without saying again that its ``forward``
    takes blocks runs case by case (``fast_path``)."""
    case_params: ClassVar[tuple] = ()
    """Parameters a sweep may set without a module per value (the cell, month and pass of a map sweep): the
    runner builds one module, with the first case's values, and the stage reads each case's own value with
    ``case_values`` (one case) or ``block_values`` (a block), so a sweep over 200 000 cells builds no 200 000
    modules. Their values are checked against the parameters when the scenario is resolved."""

    @abstractmethod
    def forward(self, case) -> dict:
        """The products this stage adds to ``case``."""

    def insensitivity(self, owner, key: str) -> str | None:
        """Why no output of this stage can depend on the setting ``key`` of ``owner``, a stage before it whose
        products it reads, or None when it may (the default). Said where a sweep or an override of ``key`` is
        reported as changing nothing (``e2esim.runner.no_effect``), and enough for an override to be reported:
        e.g. sigma_hv and the settings of a Faraday-rotation correction."""
        return None

    @classmethod
    def map_cells(cls, section: Mapping, lat_deg, lon_deg, where: Location):
        """For a map sweep (``e2esim.maps.grid``), before any case runs: the cells (n_lat, n_lon) of the grid,
        cell centres ``lat_deg`` (n_lat,) and ``lon_deg`` (n_lon,) in deg, that this stage, configured by its raw
        ``section``, has something for (the forest of a scene), as a bool array; None (the default): every cell.
        Bad settings raise ``ConfigError`` at ``where``, the section's location. A hook that reads a file may add a
        parameter ``services=None``: it is then handed the resolve's ``e2esim.case.Services`` (``services.memo``
        keeps what it reads for the scene's ``setup``; ``takes_services``)."""
        return None

    @classmethod
    def map_latitudes_seen(cls, section: Mapping, lat_deg, passes: tuple, where: Location):
        """For a map sweep, before any case runs: {pass: bool (n_lat,)}, the latitudes ``lat_deg`` (deg) that each
        pass of the orbit this stage, configured by its raw ``section``, computes for sees; None (the default):
        the stage has no orbit, every latitude counts. Bad settings raise ``ConfigError`` at ``where``."""
        return None

    def sweep_key(self, name: str) -> str:
        """The dotted sweep key of parameter ``name`` of this stage's section (``ionosphere.month``)."""
        return ".".join(str(p) for p in (*self.location.key_path, name))

    def case_values(self, case) -> dict:
        """``{name: value}`` of every ``case_params`` entry in ``case``: its sweep value, else the configured one
        (values as configured, in the parameter's own unit)."""
        return {name: case.inputs.get(self.sweep_key(name), self.config[name]) for name in self.case_params}

    def block_values(self, block) -> dict:
        """``{name: (B,) array}`` of every ``case_params`` entry over the cases of ``block`` (``case_values``
        of each case)."""
        out = {}
        for name in self.case_params:
            values = block.sweep_values(self.sweep_key(name))
            out[name] = np.full(len(block), self.config[name]) if values is None else values
        return out


def _owner(cls: type, name: str) -> type | None:
    """The class of ``cls``'s method resolution order that defines ``name``, or None."""
    return next((c for c in cls.__mro__ if name in vars(c)), None)


def fast_path(obj, fast: str = "forward_takes_blocks", reference: str = "forward"):
    """``obj``'s fast (batched) member ``fast`` when it describes the ``reference`` in force, else None.

    A batched method is only the one-case method evaluated over a block when the class that defines the
    ``reference`` in force also defines the fast member (or a subclass of it does). A subclass that overrides
    ``forward`` but inherits its parent's ``forward_takes_blocks`` would otherwise get the parent's numbers from
    the batched engine. A class also names, in ``fast_path_hooks``, the methods its fast member relies on as
    ``reference`` does (``PowerLawRetrieval.case_exponent``, say): overriding one of them below the fast
    member's class turns the fast path off too. The case then runs per case (``reference``), which is the
    reference path."""
    cls = type(obj)
    fast_class = _owner(cls, fast)
    if fast_class is None or getattr(obj, fast, None) in (None, False):
        return None
    for name in (reference, *getattr(cls, "fast_path_hooks", ())):
        owner = _owner(cls, name)
        if owner is not None and not issubclass(fast_class, owner):
            return None
    return getattr(obj, fast)


def batched_run(stage):
    """How the batched engine runs ``stage`` on a ``Block``: ``block -> {product: Factor or Batched}``, or None
    from it when the stage hands the block back (its cases then run one by one); None when it runs case by case.
    That is ``forward`` itself where the class of the ``forward`` in force says it takes blocks
    (``forward_takes_blocks``, checked as ``fast_path`` checks)."""
    if fast_path(stage, "forward_takes_blocks", "forward") is None:
        return None

    def run(block):
        from e2esim.block import NotBatched  # the engine's types, needed only when it runs blocks

        try:
            return stage.forward(block)
        except NotBatched:
            return None

    return run


def fail(module: Module, problem: str, allowed: str | None = None, key: str | None = None) -> ConfigError:
    """A ``ConfigError`` at ``module``'s section (or at its parameter ``key``) for a problem met while the
    chain runs (e.g. a case the module cannot handle)."""
    where = module.location if key is None else module.location.child(key)
    return ConfigError(where, problem, allowed)
