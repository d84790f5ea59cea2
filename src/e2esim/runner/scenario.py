"""Scenario files: reading, command-line overrides, complete validation, sweep expansion.

A scenario has one section per registered kind (``scene``, ``instrument``, ...; each with ``type:`` and the
module's parameters; the ``calibration`` and ``requirements`` lists; a plug-in's kind is a section too:
``e2esim.runner.sections``), and the ``simulation`` (``e2esim.settings``), ``sweep`` (``e2esim.runner.sweep``)
and ``output`` sections. ``Scenario.resolve()`` checks everything a run needs, for every sweep case, without
running anything (``e2esim.runner.plan_builder``): that is ``e2esim validate``.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from e2esim import registry
from e2esim.case import Services
from e2esim.errors import ConfigError, Location, ScenarioFileError
from e2esim.limits import check_plain, shorten
from e2esim.params import unknown_key_error, validate_section
from e2esim.runner.overrides import (
    NOT_GIVEN,
    check_not_swept,
    parse_value,
    remove_from_sweep,
    set_path,
    split_assignment,
    value_at,
)
from e2esim.runner.plan import CaseSpec, CaseSpecs, SweepPlan
from e2esim.runner.plan_builder import PlanBuilder
from e2esim.runner.plugins import plugin_list
from e2esim.runner.sections import NOT_SWEEPABLE, output_params, section_kinds, top_level_keys
from e2esim.runner.sweep import CaseLabels, sweep_table
from e2esim.runner.yaml_loader import load_yaml, read_scenario_text
from e2esim.settings import SimulationSettings


@dataclass
class ResolvedScenario:
    """A completely validated scenario: everything ``e2esim run`` needs."""

    name: str
    description: str
    source: str
    raw: dict
    resolved: dict
    output: dict
    cases: Sequence = field(default_factory=list)
    sweep_keys: tuple = ()
    plan: SweepPlan | None = None
    overrides: tuple = ()  # (key, key path, given before, value before) of every --set (e2esim.runner.no_effect)

    @property
    def requirement_names(self) -> list:
        return [m.label for m in self.cases[0].modules if m.kind == "requirement"] if self.cases else []


class Scenario:
    """A scenario as read from YAML (or given as a dict), with command-line overrides applied."""

    def __init__(self, data: Any, source: str = "<scenario>", lines: dict | None = None):
        self.source = source
        self.lines = dict(lines or {})
        if data is None:
            raise ScenarioFileError(f"{source}: the scenario is empty; it needs at least 'scene' and 'instrument'")
        if not isinstance(data, dict):
            raise ConfigError(Location(source, (), self.lines), "the scenario must be a mapping of sections",
                              "expected e.g. 'scene: {type: table1_forest}'")
        self.raw = data

    @classmethod
    def load(cls, path: str | Path, overrides=(), allow_imports=(), replace_sweep=()) -> Scenario:
        """Read a scenario file and apply ``--replace-sweep`` then ``--set`` assignments (``KEY=VALUE``).

        allow_imports : top-level packages that ``type: package.module:Class`` may import besides installed
            distributions (``--allow-import``; e2esim.registry).
        """
        source = str(path)
        text = read_scenario_text(path, source)
        if not text.strip():
            raise ScenarioFileError(f"{source}: the scenario file is empty")
        data, lines = load_yaml(text, source)
        scenario = cls(data, source, lines)
        scenario.allow_imports = tuple(allow_imports)
        for item in replace_sweep:
            scenario.replace_sweep(item)
        set_keys = [scenario.override(item) for item in overrides]
        check_not_swept(scenario.raw, set_keys, source)
        return scenario

    def override(self, assignment: str) -> tuple:
        """Apply one ``--set dotted.key=value`` (value parsed as YAML); return (key, key path)."""
        key, text, path = split_assignment(assignment, "--set", Location(self.source, (), self.lines))
        top_level = top_level_keys()
        if path[0] not in top_level:
            raise unknown_key_error(Location(f"{self.source} (--set)", path[:1]), path[0], top_level)
        previous = value_at(self.raw, path)
        set_path(self.raw, path, parse_value(text, "--set", key), Location(self.source, path, self.lines))
        self.lines[path] = f"--set {shorten(key)}"
        given = previous is not NOT_GIVEN  # what the value was before: e2esim.runner.no_effect
        self.overrides = [*getattr(self, "overrides", ()), (key, path, given, previous if given else None)]
        return key, path

    def replace_sweep(self, assignment: str) -> None:
        """Apply one ``--replace-sweep dotted.key=value``: the key leaves the sweep and has ``value`` in every
        case (e2esim.runner.overrides)."""
        where = Location(self.source, (), self.lines)
        key, text, path = split_assignment(assignment, "--replace-sweep", where)
        top_level = top_level_keys()
        if path[0] not in top_level or path[0] in NOT_SWEEPABLE:
            raise unknown_key_error(Location(f"{self.source} (--replace-sweep)", path[:1]), path[0], top_level)
        remove_from_sweep(self.raw, key, Location(f"{self.source} (--replace-sweep)", ("sweep",)))
        set_path(self.raw, path, parse_value(text, "--replace-sweep", key), Location(self.source, path, self.lines))
        self.lines[path] = f"--replace-sweep {shorten(key)}"

    # ------------------------------------------------------------------------------------------
    def resolve(self, services: Services | None = None) -> ResolvedScenario:
        """Validate every section and every sweep case; build the modules. Raises ConfigError.

        ``services`` (an ``e2esim.case.Services``; None: ``Services()``, which holds the process's kernel memo) is
        handed to the configuration code that reads a user's file before any case runs: a map sweep's forest
        hook (``Stage.map_cells``) and the ``setup`` of modules that take it (the AGB map, read once per file
        version through ``services.memo``).

        ``type: package.module:Class`` may import the packages of the scenario's ``plugins:`` list and of
        ``allow_imports`` besides installed distributions (e2esim.registry, docs/security.md)."""
        root = Location(self.source, (), self.lines)
        check_plain(self.raw, root)
        with registry.allowed_imports(plugin_list(self.raw.get("plugins"), root.child("plugins"))
                                      + tuple(getattr(self, "allow_imports", ()))):
            return self._resolve(root, Services() if services is None else services)

    def _resolve(self, root: Location, services: Services) -> ResolvedScenario:
        top_level = top_level_keys()
        for key in self.raw:
            if key not in top_level:
                raise unknown_key_error(root.child(key), key, top_level)
        for kind in section_kinds():
            if kind.required and kind.section not in self.raw:
                types = ", ".join(r.type_name for r in registry.available(kind.name))
                raise ConfigError(root.child(kind.section), "section is missing",
                                  f"add a '{kind.section}:' section with a type ({types})")
        name = self.raw.get("name", Path(self.source).stem)
        for key in ("name", "description"):
            if key in self.raw and not isinstance(self.raw[key], str):
                raise ConfigError(root.child(key), f"{self.raw[key]!r} is not text", "expected a string")
        output = validate_section(output_params(), self.raw.get("output"), root.child("output"))
        table = sweep_table(self.raw.get("sweep"), root.child("sweep"), self.raw, services)
        sweep_keys = table.keys
        for key in ("plot_x", "plot_group_by"):
            if output[key] is not None and output[key] not in sweep_keys:
                raise ConfigError(root.child("output").child(key), f"{output[key]!r} is not a sweep key",
                                  "sweep keys: " + (", ".join(sweep_keys) or "none (no sweep)"))
        plan = PlanBuilder(self.raw, self.source, self.lines, services).plan(table, root)
        cases = CaseSpecs(plan, CaseLabels(table))
        return ResolvedScenario(
            name=str(name),
            description=str(self.raw.get("description", "")),
            source=self.source,
            raw=copy.deepcopy(self.raw),
            resolved=_resolved_config(self.raw, cases[0], output),
            output=output,
            cases=cases,
            sweep_keys=sweep_keys,
            plan=plan,
            overrides=tuple(getattr(self, "overrides", ())),
        )


def _resolved_config(raw: dict, case: CaseSpec, output: dict) -> dict:
    """The scenario with every module's defaults filled in (first case), for provenance."""
    resolved = {k: copy.deepcopy(v) for k, v in raw.items() if k in ("name", "description", "plugins", "sweep")}
    for module in case.modules:
        kind = registry.kind(module.kind)
        entry = {"type": module.type_name, **_jsonable(module.config)}
        if kind.composite is not None or isinstance(raw.get(kind.section), list):
            resolved.setdefault(kind.section, []).append(entry)
        else:
            resolved[kind.section] = entry
    resolved.setdefault("requirements", [])  # always listed, none included (as results.h5 has always written it)
    resolved["simulation"] = {
        f.name: getattr(case.settings, f.name) for f in SimulationSettings.__dataclass_fields__.values()
    }
    resolved["output"] = _jsonable(output)
    return resolved


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return value


__all__ = ["CaseSpec", "ResolvedScenario", "Scenario"]

