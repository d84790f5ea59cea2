"""Parameter declarations: each module declares its parameters once, here is what checks them.

A module class lists ``Param`` and ``ParamGroup`` objects in its ``params`` attribute. The same
declaration validates a YAML section and a Python call (``Module(**values)``), fills in defaults and
generates docs/scenario-reference.md. Values are checked for type, bounds, choices and length, and
every complaint is a ``ConfigError`` naming the key path, the value and what is allowed (the models are
astropy.modeling's ``Parameter`` and scikit-learn's ``_parameter_constraints``, without their magic).
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping, Sequence

from e2esim.errors import ConfigError, Location


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED = _Required()
"""Marker for a parameter that has no default and must be given."""

_TYPE_NAMES = {"float": "a number", "int": "an integer", "bool": "true or false", "str": "a string"}


@dataclass(frozen=True)
class Param:
    """One parameter of a module or scenario section.

    name : key in YAML and keyword in Python; the unit goes in the name at the YAML edge
        (``level_db``, ``mean_deg``).
    type : "float", "int", "bool" or "str".
    doc : one line saying what it is.
    default : value used when the key is absent; ``REQUIRED`` if it must be given.
    unit : unit of the value as written in YAML ("dB", "deg", "t/ha", "m2/m2", "" if none).
    minimum, maximum : inclusive bounds; ``exclusive_minimum``/``exclusive_maximum`` for strict ones.
    choices : allowed values for a "str" parameter.
    length : if set, the value is a list of exactly this many items of ``type``.
    variable_length : the value is a list of one or more items of ``type`` (``length`` unset).
    nullable : ``null`` is allowed (it means "not given" or "automatic", as ``doc`` says).
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
    nullable: bool = False

    def __post_init__(self):
        if self.type not in _TYPE_NAMES:
            raise TypeError(f"Param {self.name!r}: unknown type {self.type!r}")

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def with_default(self, default: Any) -> "Param":
        return _replace(self, default=default)

    # ----------------------------------------------------------------------------------------
    def describe_allowed(self) -> str:
        """What is allowed, in words: "expected a number in [-60, 0] dB"."""
        item = _TYPE_NAMES[self.type]
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
            text = f"expected a non-empty list, each item {text[len('expected '):]}"
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
            return f"with {_fmt(lo)} {lo_sym} value {hi_sym} {_fmt(hi)}{unit}"
        if lo is not None:
            return f"{'>=' if lo_sym == '<=' else '>'} {_fmt(lo)}{unit}"
        if hi is not None:
            return f"{hi_sym} {_fmt(hi)}{unit}"
        return f"in {self.unit}" if self.unit else ""

    def validate(self, value: Any, where: Location) -> Any:
        """Return the checked (and normalised) value, or raise ``ConfigError``."""
        if value is None:
            if self.nullable:
                return None
            raise ConfigError(where, "null is not allowed", self.describe_allowed())
        if self.length is not None or self.variable_length:
            if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
                raise ConfigError(where, f"{_show(value)} is not a list", self.describe_allowed())
            if (self.length is not None and len(value) != self.length) or len(value) == 0:
                raise ConfigError(
                    where, f"{_show(value)} has {len(value)} items", self.describe_allowed()
                )
            return tuple(self._validate_item(v, where.child(i)) for i, v in enumerate(value))
        return self._validate_item(value, where)

    def _validate_item(self, value: Any, where: Location) -> Any:
        allowed = self.describe_allowed()
        if self.type == "bool":
            if not isinstance(value, bool):
                raise ConfigError(where, f"{_show(value)} has the wrong type", allowed)
            return value
        if self.type == "str":
            if not isinstance(value, str):
                raise ConfigError(where, f"{_show(value)} has the wrong type", allowed)
            if self.choices is not None and value not in self.choices:
                hint = difflib.get_close_matches(value, [str(c) for c in self.choices], n=1)
                problem = f"{_show(value)} is not allowed"
                if hint:
                    problem += f" (did you mean {hint[0]!r}?)"
                raise ConfigError(where, problem, allowed)
            return value
        # numbers
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(where, f"{_show(value)} has the wrong type", allowed)
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(where, f"{_show(value)} is not a finite number", allowed)
        if isinstance(value, int) and not -_LARGEST < value < _LARGEST:
            raise ConfigError(where, f"{_show(value)} is too large", allowed)
        if self.type == "int":
            if isinstance(value, float):
                if not value.is_integer():
                    raise ConfigError(where, f"{_show(value)} is not an integer", allowed)
                value = int(value)
        else:
            value = float(value)
        if (
            (self.minimum is not None and value < self.minimum)
            or (self.maximum is not None and value > self.maximum)
            or (self.exclusive_minimum is not None and value <= self.exclusive_minimum)
            or (self.exclusive_maximum is not None and value >= self.exclusive_maximum)
        ):
            raise ConfigError(where, f"{_show(value)} is out of range", allowed)
        if self.choices is not None and value not in self.choices:
            raise ConfigError(where, f"{_show(value)} is not allowed", allowed)
        return value


@dataclass(frozen=True)
class ParamGroup:
    """A nested mapping of parameters, e.g. ``crosstalk: {level_db: ..., convention: ...}``."""

    name: str
    doc: str
    params: tuple = field(default_factory=tuple)

    @property
    def required(self) -> bool:
        return any(p.required for p in self.params)

    @property
    def default(self) -> dict:
        return {p.name: p.default for p in self.params if not p.required}


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

    Unknown keys, missing required keys and bad values raise ``ConfigError`` at their key path.
    Keys listed in ``ignore`` (e.g. ``type``) are skipped.
    """
    if values is None:
        values = {}
    if not isinstance(values, Mapping):
        raise ConfigError(where, f"{_show(values)} is not a mapping", "expected key: value pairs")
    known = {p.name: p for p in params}
    ignore = set(ignore)
    for key in values:
        if key in ignore:
            continue
        if key not in known:
            raise unknown_key_error(where.child(key), key, list(known))
    resolved: dict = {}
    for name, p in known.items():
        here = where.child(name)
        if isinstance(p, ParamGroup):
            resolved[name] = validate_section(p.params, values.get(name), here)
        elif name in values:
            resolved[name] = p.validate(values[name], here)
        elif p.required:
            raise ConfigError(here, "is required but missing", p.describe_allowed())
        else:
            resolved[name] = p.default
    return resolved


def unknown_key_error(where: Location, key: Any, valid: Sequence[str]) -> ConfigError:
    problem = f"unknown key {key!r}"
    hint = difflib.get_close_matches(str(key), [str(v) for v in valid], n=1)
    if hint:
        problem += f" (did you mean {hint[0]!r}?)"
    allowed = "valid keys here: " + (", ".join(sorted(map(str, valid))) if valid else "none")
    return ConfigError(where, problem, allowed)


def iter_params(params: Sequence, prefix: str = ""):
    """Yield ``(dotted_name, Param)`` for every leaf parameter, groups flattened."""
    for p in params:
        if isinstance(p, ParamGroup):
            yield from iter_params(p.params, prefix + p.name + ".")
        else:
            yield prefix + p.name, p


def find_param(params: Sequence, dotted: str):
    """The Param (or ParamGroup) at a dotted name, or None."""
    head, _, rest = dotted.partition(".")
    for p in params:
        if p.name == head:
            if not rest:
                return p
            if isinstance(p, ParamGroup):
                return find_param(p.params, rest)
            return None
    return None


def _replace(p: Param, **changes) -> Param:
    from dataclasses import replace

    return replace(p, **changes)


def _fmt(x: float) -> str:
    return f"{x:g}"


_LARGEST = 10**300  # integers beyond this are not numbers a scenario means (and overflow a float)
_SHOW_CHARS = 80  # a value quoted in a message is cut to about this length


def _show(value: Any) -> str:
    """A value as a message quotes it: YAML-like, on one line, cut to ``_SHOW_CHARS``."""
    if isinstance(value, str):
        text = repr(value)
    elif isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, (list, tuple)):
        text = "[" + ", ".join(_show(v) for v in value[:20]) + (", ...]" if len(value) > 20 else "]")
    elif isinstance(value, Mapping):
        text = "a mapping"
    elif isinstance(value, int) and not -_LARGEST < value < _LARGEST:
        text = f"an integer of {len(str(abs(value))) if abs(value) < 10**4000 else 'over 4000'} digits"
    else:
        text = repr(value) if not isinstance(value, (int, float)) else f"{value:g}"
    return text if len(text) <= _SHOW_CHARS else text[:_SHOW_CHARS] + "..."
