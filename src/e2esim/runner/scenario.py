"""Scenario files: reading, command-line overrides, complete validation, sweep expansion.

A scenario has one section per stage kind (``scene``, ``instrument``, ...; each with ``type:`` and
the module's parameters; a plug-in's stage kind is a section too), a ``requirements`` list, and the
``simulation``, ``sweep`` and ``output`` sections declared below. ``Scenario.resolve()`` checks everything a
run needs, for every sweep case, without running anything: that is ``e2esim validate``.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from e2esim import registry
from e2esim.errors import ConfigError, Location, ModuleLookupError, ScenarioFileError
from e2esim.module import KIND_ORDER, Module, Stage
from e2esim.params import Param, find_param, unknown_key_error, validate_section
from e2esim.runner.limits import check_monte_carlo, check_plain, shorten
from e2esim.runner.overrides import (
    NOT_GIVEN,
    check_not_swept,
    parse_value,
    remove_from_sweep,
    split_assignment,
    value_at,
)
from e2esim.runner.plan import CaseSpec, CaseSpecs, Slot, SweepPlan, combinations, number_shapes
from e2esim.runner.plugins import plugin_list
from e2esim.runner.sweep import _ABSENT, CaseLabels, sweep_table
from e2esim.runner.yaml_loader import load_yaml, read_scenario_text
from e2esim.settings import MODES, SEED_MAX, SimulationSettings

BUILT_IN_SECTIONS = tuple(k for k in KIND_ORDER if k != "requirement")
"""Module sections of e2esim's own kinds, in section order (the ``requirement`` kind is the
``requirements`` list)."""


def module_sections() -> tuple:
    """Sections that hold modules: e2esim's own, then every stage kind a plug-in registers."""
    extra = [r.kind for r in registry.available() if issubclass(r.cls, Stage) and r.kind not in KIND_ORDER]
    return BUILT_IN_SECTIONS + tuple(dict.fromkeys(extra))


def top_level_keys() -> tuple:
    return ("name", "description", "plugins", *module_sections(), "requirements", "simulation", "sweep", "output")


DEFAULT_MODULES = {
    "ionosphere": {"type": "constant_faraday"},
    "propagation": {"type": "hv_backscatter_error"},
    "retrieval": {"type": "power_law"},
}
"""Module used when a section is absent (orbit and calibration are simply left out)."""

REQUIRED_SECTIONS = ("scene", "instrument")

SINGLE_SECTIONS = ("orbit", "scene", "instrument", "ionosphere", "retrieval")
"""Sections that hold one module; every other module section may hold a list, applied in order (e.g.
Faraday-rotation correction, then crosstalk calibration; the polarimetric error, then the backscatter
error budget)."""

PLOT_TYPES = (
    "auto",
    "verdicts",
    "backscatter_vs_sweep",
    "error_histograms",
    "tradeoff",
    "contributions",
    "agb_error_vs_sweep",
    "faraday_distributions",
    "faraday_climatology",
    "error_budget",
    "site_map",
    "estimator_comparison",
    "agb_error_vs_faraday_difference",
    "global_maps",
    "map_fraction",
)

SIMULATION_PARAMS = (
    Param("mode", "str", "what to compute: analytic moments, Monte Carlo, or both", default="both",
          choices=MODES),
    Param("seed", "int", "root seed of all random draws (case i uses SeedSequence(seed, spawn_key=(i,))); at most "
          "2^64 - 1, the largest integer results.h5 stores", default=0, minimum=0, maximum=SEED_MAX),
    Param("looks", "int", "L: independent pixels averaged into one sigma estimate (Men et al. 2021, eq. 17)",
          default=100_000, minimum=1),
    Param("realisations", "int", "M: system-error and Faraday-rotation realisations", default=10_000,
          minimum=2),
    Param("noise_realisations", "int", "N: noise realisations per system-error realisation", default=1,
          minimum=1),
    Param("keep_samples", "bool", "store the Monte Carlo error samples in results.h5", default=True),
)

OUTPUT_PARAMS = (
    Param("folder", "str", "output folder, relative to the working directory (null: runs/<scenario name>)",
          default=None, nullable=True),
    Param("title", "str", "report title (null: the scenario name)", default=None, nullable=True),
    Param("plots", "str", "plots in the report (the error budget is always drawn when there are requirements, the "
          "site map when the sweep varies the site)", default=("auto",), variable_length=True, choices=PLOT_TYPES),
    Param("plot_x", "str", "sweep key on the x axis of sweep plots (null: the first numeric sweep key)",
          default=None, nullable=True),
    Param("plot_group_by", "str", "sweep key that makes the series of sweep plots (null: the next key that tells "
          "cases apart); the other swept keys make the panels",
          default=None, nullable=True),
    Param("histogram_cases", "int", "at most this many cases get an error histogram", default=12, minimum=1),
)

NOT_SWEEPABLE = ("name", "description", "plugins", "sweep", "output")


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
        _set_path(self.raw, path, parse_value(text, "--set", key), Location(self.source, path, self.lines))
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
        _set_path(self.raw, path, parse_value(text, "--replace-sweep", key), Location(self.source, path, self.lines))
        self.lines[path] = f"--replace-sweep {shorten(key)}"

    # ------------------------------------------------------------------------------------------
    def resolve(self) -> ResolvedScenario:
        """Validate every section and every sweep case; build the modules. Raises ConfigError.

        ``type: package.module:Class`` may import the packages of the scenario's ``plugins:`` list and of
        ``allow_imports`` besides installed distributions (e2esim.registry, docs/security.md)."""
        root = Location(self.source, (), self.lines)
        check_plain(self.raw, root)
        with registry.allowed_imports(plugin_list(self.raw.get("plugins"), root.child("plugins"))
                                      + tuple(getattr(self, "allow_imports", ()))):
            return self._resolve(root)

    def _resolve(self, root: Location) -> ResolvedScenario:
        top_level = top_level_keys()
        for key in self.raw:
            if key not in top_level:
                raise unknown_key_error(root.child(key), key, top_level)
        for key in REQUIRED_SECTIONS:
            if key not in self.raw:
                kinds = ", ".join(r.type_name for r in registry.available(key))
                raise ConfigError(
                    root.child(key), "section is missing", f"add a '{key}:' section with a type ({kinds})"
                )
        name = self.raw.get("name", Path(self.source).stem)
        for key in ("name", "description"):
            if key in self.raw and not isinstance(self.raw[key], str):
                raise ConfigError(root.child(key), f"{self.raw[key]!r} is not text", "expected a string")
        output = validate_section(OUTPUT_PARAMS, self.raw.get("output"), root.child("output"))
        table = sweep_table(self.raw.get("sweep"), root.child("sweep"), self.raw)
        sweep_keys = table.keys
        for key in ("plot_x", "plot_group_by"):
            if output[key] is not None and output[key] not in sweep_keys:
                raise ConfigError(root.child("output").child(key), f"{output[key]!r} is not a sweep key",
                                  "sweep keys: " + (", ".join(sweep_keys) or "none (no sweep)"))
        plan = self._plan(table, root)
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

    def _plan(self, table, root: Location) -> SweepPlan:
        """Build every distinct module and settings of the sweep (``e2esim.runner.plan``), check every sweep
        key, and find the chain of every case."""
        keys = []  # (key, key path, group, position in the group)
        for g, group in enumerate(table.groups):
            for p, key in enumerate(group.keys):
                path = _dotted_to_path(key)
                if path[0] in NOT_SWEEPABLE or path[0] not in top_level_keys():
                    raise ConfigError(Location(self.source, ("sweep", key), self.lines), f"cannot sweep over {key!r}",
                                      "sweep keys start with a module section, requirements or simulation")
                value = next((v[p] for v in group.values if v[p] is not _ABSENT), None)
                _set_path(dict(self.raw), path, value, Location(self.source, path, self.lines), copy_on_write=True)
                keys.append((key, path, g, p))
        cache: dict = {_PRISTINE: _object_ids(self.raw)}
        slots = []
        for kind, path in self._slot_paths(keys, root):
            mine = [k for k in keys if k[1][:len(path)] == path]
            per_case = self._case_keys(kind, path, mine, table)
            built = [k for k in mine if k not in per_case]  # keys that make a module per value
            groups = tuple(sorted({k[2] for k in built}))
            slot = Slot(kind, path, tuple(k[0] for k in mine), groups, tuple(table.sizes[g] for g in groups),
                        case_keys=tuple(k[0] for k in per_case))
            combos, firsts, slot.index = combinations(table, groups)
            for combo, first in zip(combos, firsts):
                slot.objects.append(self._build_object(slot, built, combo, int(first), table, cache, per_case))
            slots.append(slot)
        plan = SweepPlan(table, slots, root)
        for slot in plan.module_slots:
            number_shapes(slot)
        for key, path, _, _ in keys:
            slot = next((s for s in slots if path[:len(s.path)] == s.path), None)
            if slot is None:  # an item of a list section the scenario does not have (requirements.2 of one)
                raise ConfigError(Location(self.source, ("sweep", key), self.lines),
                                  f"sweep key {key!r} sets an item of {path[0]!r} that the scenario does not have",
                                  _items_allowed(self.raw.get(path[0]), path[0]))
            self._check_key(key, path, slot, plan)
        plan.find_templates()
        return plan

    def _slot_paths(self, keys: list, root: Location) -> list:
        """(kind, section path) of every slot: the module sections present (or defaulted, or set by a sweep key),
        the items of list sections, the requirements, and the simulation settings (last)."""
        out = []
        for section in module_sections():
            raw = self.raw.get(section, DEFAULT_MODULES.get(section))
            if raw is None and not any(k[1][0] == section for k in keys):
                continue
            if isinstance(raw, list) and section not in SINGLE_SECTIONS:
                out += [(section, (section, i)) for i in range(len(raw))]
            else:
                out.append((section, (section,)))
        reqs = self.raw.get("requirements", [])
        if not isinstance(reqs, list):
            raise ConfigError(root.child("requirements"), "is not a list",
                              "expected a list of requirement sections, each with a type")
        out += [("requirement", ("requirements", i)) for i in range(len(reqs))]
        return out + [("simulation", ("simulation",))]

    def _case_keys(self, kind: str, path: tuple, mine: list, table) -> list:
        """The keys of ``mine`` that the slot's module reads per case (``Stage.case_params``; none when a key
        sets the module's type; not a key some case of ``cases`` leaves unset, whose value would then be the first
        case's), each distinct value checked against its parameter."""
        rest = [k[1][len(path):] for k in mine]
        raw = self.raw.get(path[0])
        if len(path) == 2:
            raw = raw[path[1]] if isinstance(raw, list) and path[1] < len(raw) else None
        if not mine or ("type",) in rest or not isinstance(raw, dict) or not isinstance(raw.get("type"), str):
            return []
        try:
            cls = registry.lookup(kind, raw["type"])
        except ModuleLookupError:
            return []  # reported where the section is built
        per_case = [k for k, r in zip(mine, rest) if len(r) == 1 and r[0] in getattr(cls, "case_params", ())
                    and all(v[k[3]] is not _ABSENT for v in table.groups[k[2]].values)]
        for _, key_path, g, p in per_case:
            param = find_param(cls.params, key_path[-1])
            where = Location(self.source, key_path[:-1], self.lines)
            for value in {repr(v[p]): v[p] for v in table.groups[g].values}.values():  # each distinct value once
                validate_section((param,), {param.name: value}, where)
        return per_case

    def _build_object(self, slot: Slot, keys: list, combo, first: int, table, cache: dict, per_case=()):
        """The module (or settings) of ``slot`` for one combination of its sweep groups' positions; ``first`` is
        the first case that has it (named in messages) and gives the values of the keys read ``per_case``."""
        config = dict(self.raw)  # sections a case overrides are copied on the way down (_set_path, copy=True)
        lines = dict(self.lines)
        codes = table.codes([first])[0] if per_case else None
        for key, path, g, p in [*keys, *per_case]:
            position = combo[slot.groups.index(g)] if g in slot.groups else codes[g]
            value = table.groups[g].values[position][p]
            if value is _ABSENT:
                continue
            _set_path(config, path, value, Location(self.source, path, lines), copy_on_write=True)
            lines[path] = f"sweep case {first}: {key}={value!r}"
        case_root = Location(self.source, (), lines)
        if slot.kind == "simulation":
            settings = SimulationSettings(
                **validate_section(SIMULATION_PARAMS, config.get("simulation"), case_root.child("simulation")))
            check_monte_carlo(settings, case_root.child("simulation").describe())
            return settings
        section = slot.path[0]
        if slot.kind == "requirement":
            reqs = config.get("requirements", [])
            if not isinstance(reqs, list):
                raise ConfigError(case_root.child("requirements"), "is not a list",
                                  "expected a list of requirement sections, each with a type")
            return _build_module("requirement", reqs[slot.path[1]], case_root.child(section).child(slot.path[1]),
                                 cache)
        raw = config.get(section, DEFAULT_MODULES.get(section))
        if len(slot.path) == 2:
            return _build_module(section, raw[slot.path[1]], case_root.child(section).child(slot.path[1]), cache)
        return _build_module(section, raw, case_root.child(section), cache)

    def _check_key(self, key: str, path: tuple, slot: Slot, plan: SweepPlan) -> None:
        """Every module a sweep key sets a value in has that parameter (each class once)."""
        where = Location(self.source, ("sweep", "parameters", key), self.lines)
        if slot.kind == "simulation":
            _check_sweep_key(key, self.raw, [], where)
            return
        position = plan.slots.index(slot)
        base = [s.objects[0] for s in plan.module_slots]
        seen = set()
        for module in slot.objects:
            if type(module) in seen:
                continue
            seen.add(type(module))
            _check_sweep_key(key, self.raw, base[:position] + [module] + base[position + 1:], where)


_PRISTINE = "ids of the scenario's own mappings and lists"  # cache entry: sections no case has changed


def _object_ids(value) -> set:
    """ids of every mapping and list inside ``value`` (the scenario as read, which stays alive)."""
    out = set()
    if isinstance(value, (dict, list)):
        out.add(id(value))
        for item in (value.values() if isinstance(value, dict) else value):
            out |= _object_ids(item)
    return out


def _build_module(kind_or_section: str, raw: Any, where: Location, cache: dict) -> Module:
    kind = "requirement" if kind_or_section == "requirement" else kind_or_section
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
    if kind not in ("calibration", "requirement", "error_terms") and not issubclass(cls, Stage):
        raise ConfigError(where.child("type"), f"{type_name!r} is a {kind} module but not a stage of the chain",
                          "a scenario section names a Stage subclass (docs/writing-a-module.md)")
    # A section no sweep case changes is the scenario's own object: key it by identity (cheap); a changed
    # one by its content, so cases with equal sections share one module.
    pristine = cache.get(_PRISTINE, ())
    key = (kind, cls, id(raw)) if id(raw) in pristine else (kind, cls, json.dumps(raw, sort_keys=True, default=str))
    if key not in cache:
        cache[key] = cls.from_config(raw, where)
    return cache[key]


def _check_sweep_key(key: str, config: dict, modules: list, where: Location) -> None:
    path = _dotted_to_path(key)
    head = path[0]
    if head == "simulation":
        params = SIMULATION_PARAMS
        rest = path[1:]
    elif head == "requirements":
        if len(path) < 3 or not isinstance(path[1], int):
            raise ConfigError(where, f"{key!r} does not name a requirement parameter",
                              "expected requirements.<index>.<parameter>")
        params = [m for m in modules if m.kind == "requirement"][path[1]].params
        rest = path[2:]
    elif isinstance(config.get(head), list):
        if len(path) < 3 or not isinstance(path[1], int):
            raise ConfigError(where, f"{key!r} does not name a parameter of a module in the list {head!r}",
                              f"expected {head}.<index>.<parameter>")
        params = [m for m in modules if m.kind == head][path[1]].params
        rest = path[2:]
    else:
        module = next(m for m in modules if m.kind == head)
        params = module.params
        rest = path[1:]
    if rest == ("type",) and head in module_sections():
        return
    dotted = ".".join(str(p) for p in rest)
    if not rest or find_param(params, dotted) is None:
        names = sorted(_leaf_names(params))
        raise ConfigError(where, f"no parameter {dotted or head!r} to sweep over in section {head!r}",
                          "parameters here: " + ", ".join(names))


def _leaf_names(params) -> list:
    from e2esim.params import iter_params

    return [name for name, _ in iter_params(params)]


def _dotted_to_path(key: str) -> tuple:
    return tuple(int(p) if p.isdigit() else p for p in key.split("."))


def _set_path(data: dict, path: tuple, value: Any, where: Location, copy_on_write: bool = False) -> None:
    """Set ``data[path] = value``, creating mappings on the way; with ``copy_on_write`` every mapping or
    list on the path is replaced by a copy first, so the scenario's own objects are never changed."""
    node = data
    for i, key in enumerate(path[:-1]):
        if copy_on_write and isinstance(node, (dict, list)):
            child = node[key] if (isinstance(node, dict) and key in node) or (
                isinstance(node, list) and isinstance(key, int) and key < len(node)) else None
            if isinstance(child, (dict, list)):
                node[key] = copy.copy(child)
        if isinstance(node, list):
            if not isinstance(key, int) or key >= len(node):
                raise ConfigError(Location(where.source, path[: i + 1], where.lines), "no such list item",
                                  f"the list has {len(node)} items")
            node = node[key]
            continue
        if not isinstance(node, dict):
            raise ConfigError(Location(where.source, path[:i], where.lines), "is not a mapping",
                              "cannot set a key inside it")
        if key not in node or node[key] is None:
            node[key] = {}
        node = node[key]
    last = path[-1]
    if isinstance(node, list):
        if not isinstance(last, int) or last >= len(node):
            raise ConfigError(where, "no such list item", f"the list has {len(node)} items")
        node[last] = value
    elif isinstance(node, dict):
        node[last] = value
    else:
        raise ConfigError(Location(where.source, path[:-1], where.lines), "is not a mapping",
                          "cannot set a key inside it")


def _resolved_config(raw: dict, case: CaseSpec, output: dict) -> dict:
    """The scenario with every module's defaults filled in (first case), for provenance."""
    resolved = {k: copy.deepcopy(v) for k, v in raw.items() if k in ("name", "description", "plugins", "sweep")}
    reqs = []
    for module in case.modules:
        entry = {"type": module.type_name, **_jsonable(module.config)}
        if module.kind == "requirement":
            reqs.append(entry)
        elif isinstance(raw.get(module.kind), list):
            resolved.setdefault(module.kind, []).append(entry)
        else:
            resolved[module.kind] = entry
    resolved["requirements"] = reqs
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


def _items_allowed(items, section: str) -> str:
    """What a sweep key may name in the list section ``section`` (its items ``items``)."""
    count = len(items) if isinstance(items, list) else 0
    if count == 0:
        return f"the scenario has no {section}: add them to the scenario before sweeping their settings"
    return f"{section}.0 to {section}.{count - 1} (the scenario has {count})"


__all__ = ["CaseSpec", "ResolvedScenario", "Scenario"]

