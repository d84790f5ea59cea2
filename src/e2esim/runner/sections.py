"""The top-level sections of a scenario, and the module a section names.

Module sections are the registered kinds (``e2esim.kinds.Kind``, entry-point group ``e2esim.kinds``): e2esim's
own (``scene``, ``instrument``, ..., the ``calibration`` and ``requirements`` lists) and a plug-in's, in their
section order. Beside them: ``name``, ``description``, ``plugins``, ``simulation`` (``e2esim.settings``),
``sweep`` (``e2esim.runner.sweep``) and ``output`` (below).
"""

from __future__ import annotations

import json
from typing import Any

from e2esim import registry
from e2esim.errors import ConfigError, Location, ModuleLookupError
from e2esim.kinds import Kind
from e2esim.module import Module, Stage
from e2esim.params import Param

NOT_SWEEPABLE = ("name", "description", "plugins", "sweep", "output", "solve", "allocate")


def section_kinds() -> list:
    """The kinds that are scenario sections, in section order (``e2esim.registry.section_kinds``)."""
    return registry.section_kinds()


def module_sections() -> tuple:
    """Sections that hold modules, in section order: e2esim's own kinds, then a plug-in's."""
    return tuple(k.section for k in section_kinds())


def kind_of(section: str) -> Kind | None:
    """The kind whose section is ``section``, or None."""
    return next((k for k in section_kinds() if k.section == section), None)


def top_level_keys() -> tuple:
    return ("name", "description", "plugins", *module_sections(), "simulation", "sweep", "output",
            "solve", "allocate")  # the questions of `e2esim solve` and `e2esim allocate` (e2esim.flowdown)


def output_params(distribution: str | None = None) -> tuple:
    """The ``output`` section's parameters; ``plots`` takes the registered plot types (of ``distribution``
    only: "e2esim" for the scenario reference)."""
    return (
        Param("folder", "str", "output folder, relative to the working directory (null: runs/<scenario name>)",
              default=None, nullable=True),
        Param("title", "str", "report title (null: the scenario name)", default=None, nullable=True),
        Param("plots", "str", "plots in the report (the error budget is always drawn when there are requirements, "
              "the site map when the sweep varies the site)", default=("auto",), variable_length=True,
              choices=("auto", *registry.plot_types(distribution))),
        Param("plot_x", "str", "sweep key on the x axis of sweep plots (null: the first numeric sweep key)",
              default=None, nullable=True),
        Param("plot_group_by", "str", "sweep key that makes the series of sweep plots (null: the next key that "
              "tells cases apart); the other swept keys make the panels",
              default=None, nullable=True),
        Param("histogram_cases", "int", "at most this many cases get an error histogram", default=12, minimum=1),
        Param("sensitivity", "bool", "elasticity of each requirement's checked value to every numeric parameter "
              "of the chain at its worst case, by central differences (two analytic runs of one case per parameter), "
              "with a tornado chart and the parameters that buy the most margin", default=False),
        Param("answer", "bool", "e2esim run answers the scenario's own question (its solve or allocate section, "
              "as e2esim solve / e2esim allocate do) and shows the answer first: report, summary.json, results.h5",
              default=True),
    )


PRISTINE = "ids of the scenario's own mappings and lists"  # cache entry: sections no case has changed


def object_ids(value) -> set:
    """ids of every mapping and list inside ``value`` (the scenario as read, which stays alive)."""
    out = set()
    if isinstance(value, (dict, list)):
        out.add(id(value))
        for item in (value.values() if isinstance(value, dict) else value):
            out |= object_ids(item)
    return out


def build_module(kind: str, raw: Any, where: Location, cache: dict, services=None) -> Module:
    """The module of kind ``kind`` that the section (or list item) ``raw`` at ``where`` names, built once per
    distinct section (``cache``); ``services`` (or None) go to its ``setup`` where it takes them."""
    if not isinstance(raw, dict):
        raise ConfigError(where, f"{raw!r} is not a mapping", f"expected a '{kind}' section with a 'type' key")
    type_name = raw.get("type")
    if type_name is None:
        names = ", ".join(r.type_name for r in registry.available(kind))
        raise ConfigError(where.child("type"), "is required but missing", f"registered {kind} types: {names}")
    if not isinstance(type_name, str):
        raise ConfigError(where.child("type"), f"{type_name!r} is not a module name", "expected a string")
    try:
        cls = registry.lookup(kind, type_name)
    except ModuleLookupError as exc:
        raise ConfigError(where.child("type"), str(exc)) from exc
    if registry.kind(kind).composite is None and not issubclass(cls, Stage):
        raise ConfigError(where.child("type"), f"{type_name!r} is a {kind} module but not a stage of the chain",
                          "a scenario section names a Stage subclass (docs/writing-a-module.md)")
    # A section no sweep case changes is the scenario's own object: key it by identity (cheap); a changed
    # one by its content, so cases with equal sections share one module.
    pristine = cache.get(PRISTINE, ())
    key = (kind, cls, id(raw)) if id(raw) in pristine else (kind, cls, json.dumps(raw, sort_keys=True, default=str))
    if key not in cache:
        cache[key] = cls.from_config(raw, where, services)
    return cache[key]


def items_allowed(items, section: str) -> str:
    """What a sweep key may name in the list section ``section`` (its items ``items``)."""
    count = len(items) if isinstance(items, list) else 0
    if count == 0:
        return f"the scenario has no {section}: add them to the scenario before sweeping their settings"
    return f"{section}.0 to {section}.{count - 1} (the scenario has {count})"
