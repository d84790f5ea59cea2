"""Parameter declarations: each module declares its parameters once, here is what checks them.

A module class lists ``Param`` and ``ParamGroup`` objects in its ``params`` attribute, together with the
constraints between them (``ExactlyOneOf``, ``AtMostOneOf``, ``Requires``, ``Ordered``: ``e2esim.param_constraints``,
imported from here). The same
declaration validates a YAML section and a Python call (``Module(**values)``), fills in defaults and
generates docs/scenario-reference.md. Values are checked for type, bounds, choices and length, and
every complaint is a ``ConfigError`` naming the key path, the value and what is allowed (the models are
astropy.modeling's ``Parameter`` and scikit-learn's ``_parameter_constraints``, without their magic).

Units: a value is written in YAML in the unit its name ends with (``mean_deg``, ``nesz_db``,
``bandwidth_mhz``, ``bound_percent``); ``to_si`` converts every value once, and modules read the SI
values under SI names (``mean_rad``, ``nesz_linear``, ``bandwidth_hz``, ``bound_fraction``): see
``SI_UNITS``. A parameter of a formula or a distribution defined in dB itself (the SD of a log-normal gain,
an ISLR in Ahmed et al. 2014) is declared with ``convert=False`` and keeps its dB value and name.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from e2esim.errors import ConfigError, Location
from e2esim.param_components import build_component, validate_component
from e2esim.param_constraints import AtMostOneOf, Constraint, ExactlyOneOf, Ordered, Requires
from e2esim.units import db_to_linear
from e2esim.value_text import LARGEST_NUMBER, number_text, value_text

__all__ = [  # the constraints live in e2esim.param_constraints; this is where modules import them from
    "REQUIRED", "SI_UNITS", "AtMostOneOf", "Constraint", "ExactlyOneOf", "Ordered", "Param", "ParamGroup", "Requires",
    "SIUnit", "find_param", "iter_constraints", "iter_params", "to_si", "unknown_key_error", "validate_section",
    "with_defaults",
]


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED = _Required()
"""Marker for a parameter that has no default and must be given."""

_TYPE_NAMES = {"float": "a number", "int": "an integer", "bool": "true or false", "str": "a string",
               "module": "a module type name or a mapping with a 'type' key",
               "mapping": "a mapping of names to numbers"}


@dataclass(frozen=True)
class SIUnit:
    """How a YAML unit converts to SI: the ending of a parameter name in that unit, the ending of its SI
    name, and the conversion of a value (numbers, or arrays of them)."""

    suffix: str
    si_suffix: str
    convert: Callable


SI_UNITS = {
    "deg": SIUnit("_deg", "_rad", np.radians),
    "mrad": SIUnit("_mrad", "_rad", lambda x: x * 1e-3),
    "MHz": SIUnit("_mhz", "_hz", lambda x: x * 1e6),
    "km": SIUnit("_km", "_m", lambda x: x * 1e3),
    "%": SIUnit("_percent", "_fraction", lambda x: x / 100.0),
    "dB": SIUnit("_db", "_linear", db_to_linear),  # a power ratio
    "TECU": SIUnit("_tecu", "_el_m2", lambda x: x * 1e16),  # 1 TECU = 1e16 electrons/m^2
}
"""YAML units that have an SI counterpart. Other units (t/ha, m, m2, m2/m2, sfu, h, day) are kept: the
field states AGB in t/ha, and local time and repeat intervals in hours and days, with the unit in the name."""


@dataclass(frozen=True)
class Param:
    """One parameter of a module or scenario section.

    name : key in YAML and keyword in Python; the unit goes in the name at the YAML edge
        (``level_db``, ``mean_deg``).
    type : "float", "int", "bool", "str", "module" or "mapping" ({name: number}, each number within the bounds).
    doc : one line saying what it is.
    default : value used when the key is absent; ``REQUIRED`` if it must be given.
    unit : unit of the value as written in YAML ("dB", "deg", "t/ha", "m2/m2", "" if none).
    minimum, maximum : inclusive bounds; ``exclusive_minimum``/``exclusive_maximum`` for strict ones.
    choices : allowed values for a "str" parameter.
    length : if set, the value is a list of exactly this many items of ``type``.
    variable_length : the value is a list of one or more items of ``type`` (``length`` unset).
    may_be_empty : with ``variable_length``, the empty list is allowed too (it means "none", as ``doc`` says).
    nullable : ``null`` is allowed (it means "not given" or "automatic", as ``doc`` says).
    convert : convert to SI (``SI_UNITS``); False keeps a value whose formula is written in its own unit.
    kind : for type "module": the registry kind of the component named (e.g. "faraday_estimator").
    lookup : for type "module": ``lookup(kind, type_name) -> class`` (``e2esim.registry.lookup``), handed in by the
        module that declares the parameter, so that parameters (below the registry) never import it.
    input_file : for type "str": the value names a file the module reads (relative to the scenario file's folder);
        its path, size and SHA-256 go into the provenance and the resume journal's identity
        (``e2esim.runner.scenario_files``), so that a file changed since an interrupted run is noticed.
    """

    name: str
    type: str
    doc: str
    default: Any = REQUIRED
    unit: str = ""
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: float | None = None
    exclusive_maximum: float | None = None
    choices: tuple | None = None
    length: int | None = None
    variable_length: bool = False
    may_be_empty: bool = False
    nullable: bool = False
    convert: bool = True
    kind: str | None = None
    lookup: Callable | None = field(default=None, compare=False, repr=False)
    input_file: bool = False

    def __post_init__(self):
        if self.type not in _TYPE_NAMES:
            raise TypeError(f"Param {self.name!r}: unknown type {self.type!r}")
        if (self.type == "module") != (self.kind is not None):
            raise TypeError(f"Param {self.name!r}: a 'module' parameter needs a kind, and only it has one")
        if (self.type == "module") != (self.lookup is not None):
            raise TypeError(f"Param {self.name!r}: a 'module' parameter needs a lookup (e2esim.registry.lookup), "
                            "and only it has one")
        if self.input_file and self.type != "str":
            raise TypeError(f"Param {self.name!r}: only a 'str' parameter names an input file")
        unit = SI_UNITS.get(self.unit)
        if unit is not None and self.convert and not self.name.endswith(unit.suffix):
            raise TypeError(f"Param {self.name!r} in {self.unit} must end with {unit.suffix!r} (or set convert=False)")

    @property
    def si_name(self) -> str:
        """Name of the SI value (``mean_deg`` -> ``mean_rad``); the name itself if nothing converts."""
        unit = SI_UNITS.get(self.unit)
        if unit is None or not self.convert:
            return self.name
        return self.name[: -len(unit.suffix)] + unit.si_suffix

    def to_si(self, value: Any) -> Any:
        """The validated ``value`` in SI (a float, a tuple of floats, or the built component)."""
        if value is None:
            return None
        if self.type == "module":
            return build_component(self, value)
        unit = SI_UNITS.get(self.unit)
        if unit is None or not self.convert:
            return value
        if isinstance(value, tuple):
            return tuple(float(x) for x in np.ravel(unit.convert(np.asarray(value, dtype=float))))
        return float(unit.convert(value))

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def with_default(self, default: Any) -> Param:
        return _replace(self, default=default)

    # ----------------------------------------------------------------------------------------
    def describe_allowed(self) -> str:
        """What is allowed, in words: "expected a number in [-60, 0] dB"."""
        item = _TYPE_NAMES[self.type]
        if self.type == "module":
            return f"expected {item} of a registered {self.kind} type" + (" (or null)" if self.nullable else "")
        if self.choices is not None:
            text = "expected one of " + ", ".join(repr(c) for c in self.choices)
        else:
            text = f"expected {item}"
            bounds = self._bounds_text()
            if bounds:
                text += f" {bounds}"
        if self.length is not None:
            text = f"expected a list of {self.length} items, each {text[len('expected '):]}"
        elif self.variable_length:
            text = f"expected a {'' if self.may_be_empty else 'non-empty '}list, each item {text[len('expected '):]}"
        if self.nullable:
            text += " (or null)"
        return text

    def _bounds_text(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        lo = self.minimum if self.minimum is not None else self.exclusive_minimum
        hi = self.maximum if self.maximum is not None else self.exclusive_maximum
        lo_sym = "<=" if self.minimum is not None else "<"
        hi_sym = "<=" if self.maximum is not None else "<"
        if lo is not None and hi is not None:
            return f"with {number_text(lo)} {lo_sym} value {hi_sym} {number_text(hi)}{unit}"
        if lo is not None:
            return f"{'>=' if lo_sym == '<=' else '>'} {number_text(lo)}{unit}"
        if hi is not None:
            return f"{hi_sym} {number_text(hi)}{unit}"
        return f"in {self.unit}" if self.unit else ""

    def validate(self, value: Any, where: Location) -> Any:
        """Return the checked (and normalised) value, or raise ``ConfigError``."""
        if value is None:
            if self.nullable:
                return None
            raise ConfigError(where, "null is not allowed", self.describe_allowed())
        if self.length is not None or self.variable_length:
            if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
                raise ConfigError(where, f"{value_text(value)} is not a list", self.describe_allowed())
            if (self.length is not None and len(value) != self.length) or (len(value) == 0 and not self.may_be_empty):
                raise ConfigError(
                    where, f"{value_text(value)} has {len(value)} items", self.describe_allowed()
                )
            return tuple(self._validate_item(v, where.child(i)) for i, v in enumerate(value))
        return self._validate_item(value, where)

    def _validate_item(self, value: Any, where: Location) -> Any:
        if self.type == "module":
            return validate_component(self, value, where)
        if self.type == "mapping":  # {name: number}, each number checked as a "float" of the same bounds
            if not isinstance(value, Mapping):
                raise ConfigError(where, f"{value_text(value)} is not a mapping", self.describe_allowed())
            number = _replace(self, type="float")
            for key in value:
                if not isinstance(key, str):
                    raise ConfigError(where, f"the name {value_text(key)} is not a string", self.describe_allowed())
            return {key: number._validate_item(v, where.child(key)) for key, v in value.items()}
        if self.type == "bool":
            if not isinstance(value, bool):
                raise ConfigError(where, f"{value_text(value)} has the wrong type", self.describe_allowed())
            return value
        if self.type == "str":
            if not isinstance(value, str):
                raise ConfigError(where, f"{value_text(value)} has the wrong type", self.describe_allowed())
            if self.choices is not None and value not in self.choices:
                hint = difflib.get_close_matches(value, [str(c) for c in self.choices], n=1)
                problem = f"{value_text(value)} is not allowed"
                if hint:
                    problem += f" (did you mean {hint[0]!r}?)"
                raise ConfigError(where, problem, self.describe_allowed())
            return value
        # numbers
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(where, f"{value_text(value)} has the wrong type", self.describe_allowed())
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(where, f"{value_text(value)} is not a finite number", self.describe_allowed())
        if isinstance(value, int) and not -LARGEST_NUMBER < value < LARGEST_NUMBER:
            raise ConfigError(where, f"{value_text(value)} is too large", self.describe_allowed())
        if self.type == "int":
            if isinstance(value, float):
                if not value.is_integer():
                    raise ConfigError(where, f"{value_text(value)} is not an integer", self.describe_allowed())
                value = int(value)
        else:
            value = float(value)
        if (
            (self.minimum is not None and value < self.minimum)
            or (self.maximum is not None and value > self.maximum)
            or (self.exclusive_minimum is not None and value <= self.exclusive_minimum)
            or (self.exclusive_maximum is not None and value >= self.exclusive_maximum)
        ):
            raise ConfigError(where, f"{value_text(value)} is out of range", self.describe_allowed())
        if self.choices is not None and value not in self.choices:
            raise ConfigError(where, f"{value_text(value)} is not allowed", self.describe_allowed())
        return value


@dataclass(frozen=True)
class ParamGroup:
    """A nested mapping of parameters, e.g. ``crosstalk: {level_db: ..., convention: ...}``."""

    name: str
    doc: str
    params: tuple = field(default_factory=tuple)

    @property
    def required(self) -> bool:
        return any(p.required for p in self.params if not isinstance(p, Constraint))

    @property
    def default(self) -> dict:
        return {p.name: p.default for p in self.params if not isinstance(p, Constraint) and not p.required}


def with_defaults(params: Iterable, overrides: Mapping[str, Any]) -> tuple:
    """Copy of a parameter declaration with some defaults changed (for presets).

    ``overrides`` keys are dotted names: ``{"crosstalk.level_db": -30.0, "nesz_db": -27.0}``.
    """
    overrides = dict(overrides)
    result = tuple(_override(p, overrides, "") for p in params)
    if overrides:
        raise KeyError(f"with_defaults: no parameters named {sorted(overrides)}")
    return result


def _override(p, overrides: dict, prefix: str):
    if isinstance(p, Constraint):
        return p
    name = prefix + p.name
    if isinstance(p, ParamGroup):
        return ParamGroup(p.name, p.doc, tuple(_override(q, overrides, name + ".") for q in p.params))
    if name in overrides:
        return p.with_default(overrides.pop(name))
    return p


def validate_section(
    params: Sequence, values: Mapping | None, where: Location, ignore: Iterable[str] = ()
) -> dict:
    """Check a mapping against a parameter declaration; return it complete with defaults.

    Unknown keys, missing required keys, bad values and broken constraints raise ``ConfigError`` at
    their key path. Keys listed in ``ignore`` (e.g. ``type``) are skipped.
    """
    if values is None:
        values = {}
    if not isinstance(values, Mapping):
        raise ConfigError(where, f"{value_text(values)} is not a mapping", "expected key: value pairs")
    known = {p.name: p for p in params if not isinstance(p, Constraint)}
    ignore = set(ignore)
    for key in values:
        if key in ignore:
            continue
        if key not in known:
            raise unknown_key_error(where.child(key), key, list(known))
    resolved: dict = {}
    for name, p in known.items():  # a plain default needs no location: a sweep's 10,000 modules have dozens each
        if isinstance(p, ParamGroup):
            resolved[name] = validate_section(p.params, values.get(name), where.child(name))
        elif name in values:
            resolved[name] = p.validate(values[name], where.child(name))
        elif p.required:
            raise ConfigError(where.child(name), "is required but missing", p.describe_allowed())
        elif p.type == "module" and p.default is not None:
            resolved[name] = p.validate(p.default, where.child(name))  # the complete mapping, as if given
        else:
            resolved[name] = p.default
    for rule in params:
        if isinstance(rule, Constraint):
            rule.check(resolved, where)
    return resolved


def to_si(params: Sequence, config: Mapping) -> dict:
    """The SI values of a validated section (``validate_section``), under their SI names (``Param.si_name``);
    groups stay nested."""
    out: dict = {}
    for p in params:
        if isinstance(p, ParamGroup):
            out[p.name] = to_si(p.params, config[p.name])
        elif isinstance(p, Param):
            out[p.si_name] = p.to_si(config[p.name])
    return out


def unknown_key_error(where: Location, key: Any, valid: Sequence[str]) -> ConfigError:
    problem = f"unknown key {key!r}"
    hint = difflib.get_close_matches(str(key), [str(v) for v in valid], n=1)
    if hint:
        problem += f" (did you mean {hint[0]!r}?)"
    allowed = "valid keys here: " + (", ".join(sorted(map(str, valid))) if valid else "none")
    return ConfigError(where, problem, allowed)


def iter_params(params: Sequence, prefix: str = ""):
    """Yield ``(dotted_name, Param)`` for every leaf parameter, groups flattened (constraints skipped)."""
    for p in params:
        if isinstance(p, ParamGroup):
            yield from iter_params(p.params, prefix + p.name + ".")
        elif isinstance(p, Param):
            yield prefix + p.name, p


def iter_constraints(params: Sequence, prefix: str = ""):
    """Yield ``(group prefix, Constraint)`` for every constraint, groups included."""
    for p in params:
        if isinstance(p, ParamGroup):
            yield from iter_constraints(p.params, prefix + p.name + ".")
        elif isinstance(p, Constraint):
            yield prefix, p


def find_param(params: Sequence, dotted: str):
    """The Param (or ParamGroup) at a dotted name, or None."""
    head, _, rest = dotted.partition(".")
    for p in params:
        if isinstance(p, Constraint):
            continue
        if p.name == head:
            if not rest:
                return p
            if isinstance(p, ParamGroup):
                return find_param(p.params, rest)
            return None
    return None


def _replace(p: Param, **changes) -> Param:
    return dataclasses.replace(p, **changes)
