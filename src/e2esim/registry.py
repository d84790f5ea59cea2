"""One registry for every module kind, filled from the entry-point group ``e2esim.modules``.

Built-in modules are declared in e2esim's own pyproject.toml exactly as a third-party package declares
its modules, under ``[project.entry-points."e2esim.modules"]`` with names ``"<kind>.<type_name>"``. Kinds
are open: a plug-in may register modules of a kind e2esim does not know (a new stage kind, which then is
a scenario section of that name).
A scenario may also name a class directly, ``type: package.module:ClassName`` (model: xarray's backend
plug-ins; the error for an unknown name lists the valid ones).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Dict, Tuple

from e2esim.errors import ModuleLookupError
from e2esim.module import KIND_ORDER, Module

ENTRY_POINT_GROUP = "e2esim.modules"


@dataclass(frozen=True)
class Registration:
    kind: str
    type_name: str
    cls: type
    distribution: str  # installed distribution that declared it ("e2esim" for built-ins)


_cache: Dict[Tuple[str, str], Registration] | None = None


def _load() -> Dict[Tuple[str, str], Registration]:
    global _cache
    if _cache is not None:
        return _cache
    found: Dict[Tuple[str, str], Registration] = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        kind, _, type_name = ep.name.partition(".")
        cls = ep.load()
        dist = ep.dist.name if getattr(ep, "dist", None) is not None else "?"
        _check_class(cls, f"entry point {ep.name!r} of {dist}", kind, type_name)
        key = (kind, type_name)
        if key in found and found[key].cls is not cls:
            raise ModuleLookupError(
                f"two installed packages register {kind} type {type_name!r}: "
                f"{found[key].distribution} and {dist}"
            )
        found[key] = Registration(kind, type_name, cls, dist)
    if not any(r.distribution.lower() == "e2esim" for r in found.values()):
        raise ModuleLookupError(
            "no built-in e2esim modules are registered: e2esim must be installed "
            "(pip install -e . from the repository) so that its entry points exist"
        )
    _cache = found
    return found


def refresh() -> None:
    """Forget the cached registry (after installing a plug-in in the same process)."""
    global _cache
    _cache = None


def _check_class(cls, origin: str, kind: str | None = None, type_name: str | None = None) -> None:
    if not (isinstance(cls, type) and issubclass(cls, Module)):
        raise ModuleLookupError(f"{origin} is not an e2esim Module subclass")
    if not (isinstance(cls.kind, str) and cls.kind.isidentifier()):
        raise ModuleLookupError(f"{origin}: kind {cls.kind!r} is not a name (e.g. 'propagation', 'interferometry')")
    if kind is not None and (cls.kind != kind or cls.type_name != type_name):
        raise ModuleLookupError(
            f"{origin} names {kind}.{type_name} but the class says {cls.kind}.{cls.type_name}"
        )


def available(kind: str | None = None) -> list[Registration]:
    """Registered modules, optionally of one kind, sorted by kind then name."""
    regs = _load().values()
    return sorted((r for r in regs if kind is None or r.kind == kind), key=_sort_key)


def _sort_key(r: Registration) -> tuple:
    rank = KIND_ORDER.index(r.kind) if r.kind in KIND_ORDER else len(KIND_ORDER)
    return rank, r.kind, r.type_name


def kinds() -> list:
    """Every registered kind, e2esim's own first."""
    return list(dict.fromkeys(r.kind for r in available()))


def lookup(kind: str, type_name: str) -> type:
    """The module class for ``type_name`` (a registered name or ``package.module:Class``)."""
    if ":" in type_name:
        module_name, _, class_name = type_name.partition(":")
        try:
            cls = getattr(importlib.import_module(module_name), class_name)
        except (ImportError, AttributeError) as exc:
            raise ModuleLookupError(f"cannot import {type_name!r}: {exc}") from exc
        _check_class(cls, repr(type_name))
        if cls.kind != kind:
            raise ModuleLookupError(f"{type_name!r} is a {cls.kind} module, not a {kind} module")
        return cls
    reg = _load().get((kind, type_name))
    if reg is None:
        names = [r.type_name for r in available(kind)]
        raise ModuleLookupError(
            f"unknown {kind} type {type_name!r}; registered {kind} types: {', '.join(names) or 'none'} "
            "(or give package.module:ClassName)"
        )
    return reg.cls
