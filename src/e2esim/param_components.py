"""Components named by a parameter (type "module"): a module type name, or a mapping with a 'type' key and the
component's own parameters, looked up in the registry of module types."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from e2esim.errors import ConfigError, Location, ModuleLookupError
from e2esim.value_text import value_text


def validate_component(param, value: Any, where: Location) -> dict:
    """A component given by its type name or a mapping ``{type: ..., <its parameters>}``; returned as the
    complete mapping (its defaults filled in), so the configuration stays plain data."""
    section = {"type": value} if isinstance(value, str) else value
    if not isinstance(section, Mapping) or not isinstance(section.get("type"), str):
        raise ConfigError(where, f"{value_text(value)} is not a {param.kind} type", param.describe_allowed())
    cls = _lookup_component(param, section["type"], where.child("type") if not isinstance(value, str) else where)
    module = cls.from_config(section, where)
    return {"type": section["type"], **module.config}


def _lookup_component(param, type_name: str, where: Location):
    try:
        return param.lookup(param.kind, type_name)
    except ModuleLookupError as exc:
        raise ConfigError(where, str(exc)) from exc


def build_component(param, section: Mapping | str):
    section = {"type": section} if isinstance(section, str) else section
    cls = _lookup_component(param, section["type"], Location(f"parameter {param.name}"))
    return cls(**{k: v for k, v in section.items() if k != "type"})
