"""One registry for every module kind, filled from the entry-point group ``e2esim.modules``.

Built-in modules are declared in e2esim's own pyproject.toml exactly as a third-party package declares
its modules, under ``[project.entry-points."e2esim.modules"]`` with names ``"<kind>.<type_name>"``. Kinds
are open: a plug-in may register modules of a kind e2esim does not know (a new stage kind, which then is
a scenario section of that name).
A scenario may also name a class directly, ``type: package.module:ClassName`` (model: xarray's backend
plug-ins; the error for an unknown name lists the valid ones), of an installed distribution or of a
package the user allows explicitly; see ``lookup`` and docs/security.md.

Plug-in code is imported defensively (``e2esim.plugin_import``): an installed plug-in whose import raises,
exits or takes more than 10 s, or whose entry point names no e2esim module, is left out with a
``PluginWarning`` naming its distribution and entry point (``broken_plugins``); every other module works.
e2esim's own entry points are imported directly: a failure there is a bug of e2esim and keeps its traceback.

Two more groups extend the frame the same way: ``e2esim.kinds`` declares module kinds (``e2esim.kinds.Kind``: a
scenario section, its order, its default, a composite stage of its list) and ``e2esim.plots`` the report's plot
types (name: the ``output.plots`` value; value: ``function(result, folder, options) -> [(file, caption)]``,
imported only when drawn). A plug-in's declaration that cannot be loaded or is not valid is left out with a
``PluginWarning``, like a module.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import re
import sys
import threading
import warnings
from contextvars import ContextVar
from dataclasses import dataclass
from importlib.metadata import entry_points, packages_distributions

from e2esim.errors import ModuleLookupError
from e2esim.kinds import Kind, undeclared
from e2esim.module import Module
from e2esim.plugin_import import PluginImportFailed, PluginWarning, guarded_import

ENTRY_POINT_GROUP = "e2esim.modules"
KIND_GROUP = "e2esim.kinds"
PLOT_GROUP = "e2esim.plots"


class Registration:
    """A registered module: kind, type name, distribution ("e2esim" for built-ins) and class. e2esim's own classes
    are imported when first asked for (``cls``): a run imports the modules its chain names, not all of them."""

    __slots__ = ("_cls", "_entry", "distribution", "kind", "type_name")

    def __init__(self, kind: str, type_name: str, cls: type | None, distribution: str, entry=None):
        self.kind, self.type_name, self.distribution, self._cls, self._entry = kind, type_name, distribution, cls, entry

    @property
    def cls(self) -> type:
        if self._cls is None:
            cls = self._entry.load()
            _check_class(cls, f"entry point {self._entry.name!r} of {self.distribution}", self.kind, self.type_name)
            self._cls = cls
        return self._cls

    @property
    def package(self) -> str:
        """The top-level package of the class (of its entry point while it is not imported)."""
        module = self._cls.__module__ if self._cls is not None else self._entry.value.partition(":")[0]
        return module.split(".")[0]


@dataclass(frozen=True)
class BrokenPlugin:
    """An entry point of an installed plug-in that could not be loaded, and why."""

    name: str  # "<kind>.<type_name>"
    value: str  # "package.module:Class"
    distribution: str
    problem: str
    group: str = ENTRY_POINT_GROUP

    def message(self) -> str:
        where = "" if self.group == ENTRY_POINT_GROUP else f" of {self.group}"
        return (f"plug-in {self.distribution}, entry point {self.name}{where} = {self.value}, is not available: "
                f"{self.problem}; e2esim goes on without it")


_cache: dict[tuple[str, str], Registration] | None = None
_broken: tuple = ()


def _load() -> dict[tuple[str, str], Registration]:
    global _cache, _broken
    if _cache is not None:
        return _cache
    found: dict[tuple[str, str], Registration] = {}
    broken: list = []
    names: dict = {}  # distribution name by distribution object: reading it parses its metadata file
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        kind, _, type_name = ep.name.partition(".")
        dist = _distribution(ep, names)
        if dist.lower() == "e2esim":
            registration = Registration(kind, type_name, None, dist, ep)  # imported when first asked for
        else:
            cls = _load_plugin(ep, dist, kind, type_name, broken)
            if cls is None:
                continue
            registration = Registration(kind, type_name, cls, dist)
        key = (kind, type_name)
        if key in found and not _same_entry(found[key], registration) and found[key].cls is not registration.cls:
            raise ModuleLookupError(
                f"two installed packages register {kind} type {type_name!r}: "
                f"{found[key].distribution} and {dist}"
            )
        found[key] = registration
    if not any(r.distribution.lower() == "e2esim" for r in found.values()):
        raise ModuleLookupError(
            "no built-in e2esim modules are registered: e2esim must be installed "
            "(pip install -e . from the repository) so that its entry points exist"
        )
    _cache, _broken = found, tuple(broken)
    for plugin in broken:
        warnings.warn(plugin.message(), PluginWarning, stacklevel=3)
    return found


def _same_entry(a: Registration, b: Registration) -> bool:
    """Whether two registrations name the same class by the same entry point (nothing to import to tell)."""
    return a._entry is not None and b._entry is not None and a._entry.value == b._entry.value


def _distribution(ep, names: dict) -> str:
    """The name of the distribution that declares ``ep`` (``names`` caches them by distribution object)."""
    source = getattr(ep, "dist", None)
    if source is not None and id(source) not in names:
        names[id(source)] = source.name
    return names[id(source)] if source is not None else "?"


def _load_plugin(ep, dist: str, kind: str, type_name: str, broken: list) -> type | None:
    """The class of a plug-in's entry point, or None (appended to ``broken``) if importing it raised, exited or
    hung, or it is not the e2esim module it says. A distribution whose import hung is not tried again."""
    if any(b.distribution == dist and "did not finish" in b.problem for b in broken):
        problem = "not imported: an earlier entry point of the same plug-in did not finish importing"
    else:
        try:
            cls = guarded_import(ep.load)
            _check_class(cls, f"entry point {ep.name!r} of {dist}", kind, type_name)
            return cls
        except (PluginImportFailed, ModuleLookupError) as exc:
            problem = str(exc)
    broken.append(BrokenPlugin(ep.name, ep.value, dist, problem))
    return None


def broken_plugins() -> tuple:
    """The ``BrokenPlugin`` entry points left out of the registry (each also warned about once): modules, kinds
    and plot types."""
    _load()
    return _broken + _load_kinds()[1] + _plot_entries()[1]


def refresh() -> None:
    """Forget the cached registry and installed packages (after installing a plug-in in the same process)."""
    global _cache, _installed, _broken, _kinds, _plots
    _cache = None
    _installed = None
    _broken = ()
    _kinds = _plots = None


# Kinds ---------------------------------------------------------------------------------------------------------
_kinds: tuple | None = None  # ({name: Kind}, broken, {name: distribution})


def _load_kinds() -> tuple:
    global _kinds
    if _kinds is not None:
        return _kinds
    found: dict = {}
    broken: list = []
    names: dict = {}
    dists: dict = {}
    for ep in sorted(entry_points(group=KIND_GROUP), key=lambda e: _distribution(e, names).lower() != "e2esim"):
        dist = _distribution(ep, names)
        if dist.lower() == "e2esim":
            found[ep.name], dists[ep.name] = ep.load(), dist
            continue
        try:
            declared = guarded_import(ep.load)
        except PluginImportFailed as exc:
            broken.append(BrokenPlugin(ep.name, ep.value, dist, str(exc), KIND_GROUP))
            continue
        problem = declared.problem(ep.name) if isinstance(declared, Kind) else (
            "is not an e2esim Kind (e2esim.kinds.Kind)")
        if problem is None and ep.name in found:
            problem = f"the kind {ep.name!r} is declared already (by e2esim or another plug-in)"
        taken = next((k.name for k in found.values() if declared.section is not None and k.section == declared.section),
                     None) if problem is None else None
        if taken is not None:
            problem = f"section {declared.section!r} belongs to the kind {taken!r} already"
        if problem is not None:
            broken.append(BrokenPlugin(ep.name, ep.value, dist, problem, KIND_GROUP))
        else:
            found[ep.name], dists[ep.name] = declared, dist
    _kinds = (found, tuple(broken), dists)
    for plugin in broken:
        warnings.warn(plugin.message(), PluginWarning, stacklevel=3)
    return _kinds


def kind(name: str) -> Kind:
    """The declaration of kind ``name`` (a kind only a plug-in's modules name: ``e2esim.kinds.undeclared``)."""
    return _load_kinds()[0].get(name) or undeclared(name)


def section_kinds(distribution: str | None = None) -> list:
    """The kinds that are scenario sections, in section order: the declared ones, then the stage kinds that
    plug-ins' modules name without declaring them (only those one distribution declares: ``distribution``)."""
    from e2esim.module import Stage

    declared, _, dists = _load_kinds()
    if distribution is not None:
        return sorted((k for n, k in declared.items() if k.section is not None and dists[n].lower() == distribution),
                      key=lambda k: (k.order, k.name))
    extra = [undeclared(r.kind) for r in _load().values()
             if r.kind not in declared and issubclass(r.cls, Stage)]
    out = [k for k in declared.values() if k.section is not None] + list({k.name: k for k in extra}.values())
    return sorted(out, key=lambda k: (k.order, k.name))


# Plot types ----------------------------------------------------------------------------------------------------
_plots: tuple | None = None  # ({name: entry point}, broken)


def _plot_entries() -> tuple:
    global _plots
    if _plots is None:
        found: dict = {}
        broken: list = []
        names: dict = {}
        for ep in sorted(entry_points(group=PLOT_GROUP), key=lambda e: _distribution(e, names).lower() != "e2esim"):
            dist = _distribution(ep, names)
            problem = (f"plot name {ep.name!r} is not a name" if not ep.name.isidentifier() or ep.name == "auto"
                       else f"the plot type {ep.name!r} is registered already" if ep.name in found else None)
            if problem is None:
                found[ep.name] = (ep, dist)
            else:
                broken.append(BrokenPlugin(ep.name, ep.value, dist, problem, PLOT_GROUP))
        _plots = (found, tuple(broken))
        for plugin in broken:
            warnings.warn(plugin.message(), PluginWarning, stacklevel=3)
    return _plots


def plot_types(distribution: str | None = None) -> tuple:
    """The names of the registered plot types (of one distribution, e.g. "e2esim"), e2esim's own first; nothing
    is imported."""
    return tuple(n for n, (_, d) in _plot_entries()[0].items() if distribution is None or d.lower() == distribution)


def plot(name: str):
    """The drawing function of plot type ``name``: ``function(result, folder, options) -> [(file, caption)]``.
    Raises ModuleLookupError for an unknown name or a plug-in's plot that cannot be imported."""
    entry = _plot_entries()[0].get(name)
    if entry is None:
        raise ModuleLookupError(f"unknown plot type {name!r}; registered plot types: {', '.join(plot_types())}")
    ep, dist = entry
    if dist.lower() == "e2esim":
        return ep.load()
    try:
        function = guarded_import(ep.load)
    except PluginImportFailed as exc:
        raise ModuleLookupError(f"plot type {name!r} of the plug-in {dist} ({ep.value}) could not be loaded: "
                                f"{exc}") from exc
    if not callable(function):
        raise ModuleLookupError(f"plot type {name!r} of the plug-in {dist} ({ep.value}) is not a function "
                                "(result, folder, options) -> [(file name, caption)]")
    return function


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
    return kind(r.kind).order, r.kind, r.type_name


def kinds() -> list:
    """Every registered kind, e2esim's own first."""
    return list(dict.fromkeys(r.kind for r in available()))


def lookup(kind: str, type_name: str) -> type:
    """The module class for ``type_name`` (a registered name or ``package.module:Class``).

    Registered names come first. A ``package.module:Class`` path is imported only if its syntax is right
    and its top-level package belongs to an installed distribution or is allowed explicitly
    (``allowed_imports``: the scenario's ``plugins:`` list, ``--allow-import``); the current working
    directory and relative path entries are never searched (docs/security.md).
    """
    reg = _load().get((kind, type_name))
    if reg is not None:
        return reg.cls
    if ":" in type_name:
        cls = _import_class(type_name)
        _check_class(cls, repr(type_name))
        if cls.kind != kind:
            raise ModuleLookupError(f"{type_name!r} is a {cls.kind} module, not a {kind} module")
        return cls
    for plugin in broken_plugins():
        if plugin.name == f"{kind}.{type_name}":
            raise ModuleLookupError(f"{kind} type {type_name!r} is registered by the plug-in {plugin.distribution} "
                                    f"({plugin.name} = {plugin.value}), which could not be loaded: {plugin.problem}")
    names = [r.type_name for r in available(kind)]
    raise ModuleLookupError(
        f"unknown {kind} type {_short(type_name)!r}; registered {kind} types: {', '.join(names) or 'none'} "
        "(or give package.module:ClassName)"
    )


_CLASS_PATH = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*):([A-Za-z_][A-Za-z0-9_]*)$")
_allowed: ContextVar[frozenset] = ContextVar("e2esim_allowed_imports", default=frozenset())
_import_lock = threading.Lock()


@contextlib.contextmanager
def allowed_imports(packages):
    """Within the block, ``package.module:Class`` may also import these top-level packages."""
    token = _allowed.set(_allowed.get() | frozenset(packages))
    try:
        yield
    finally:
        _allowed.reset(token)


def _import_class(type_name: str) -> type:
    match = _CLASS_PATH.match(type_name)
    if not match:
        raise ModuleLookupError(f"{_short(type_name)!r} is not a class path; expected package.module:ClassName "
                                "with Python names (e.g. my_instruments.radar:MyRadar)")
    module_name, class_name = match.groups()
    top = module_name.split(".")[0]
    if top not in _allowed.get() and top not in _installed_packages():
        raise ModuleLookupError(
            f"will not import {module_name!r} for {type_name!r}: {top!r} is not an installed distribution; "
            f"install it (pip install), or allow it with 'plugins: [{top}]' in the scenario or --allow-import {top}"
        )
    with _import_lock, _without_working_directory():
        try:
            module = guarded_import(lambda: importlib.import_module(module_name))
        except PluginImportFailed as exc:
            reason = exc.__cause__ if isinstance(exc.__cause__, ImportError) else exc
            raise ModuleLookupError(f"cannot import {type_name!r}: {reason}") from exc
    try:
        return getattr(module, class_name)
    except AttributeError as exc:
        raise ModuleLookupError(f"cannot import {type_name!r}: module {module_name!r} has no {class_name!r}") from exc


def _installed_packages() -> frozenset:
    """Top-level packages of the installed distributions (importlib.metadata; read once, like the entry points,
    and again after ``refresh``)."""
    global _installed
    if _installed is None:
        _installed = frozenset(packages_distributions())
    return _installed


_installed: frozenset | None = None


@contextlib.contextmanager
def _without_working_directory():
    """``sys.path`` without the entries that mean the current working directory ('' and '.', and the folder
    itself, which ``python -m`` puts first), so that no file there is imported by a scenario."""
    cwd = os.path.realpath(os.getcwd())
    saved = list(sys.path)
    sys.path[:] = [p for p in saved if p not in ("", ".") and os.path.realpath(p) != cwd]
    try:
        yield
    finally:
        sys.path[:] = saved


def _short(text: str, limit: int = 80) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit] + "..."
