"""From a scenario's sections and its sweep to the plan of its modules (``e2esim.runner.plan.SweepPlan``).

Every section of a registered kind (``e2esim.runner.sections``) is a slot, every item of a list section one slot
each, and the ``simulation`` settings the last slot. Each slot's module is built once per combination of the
sweep groups that set values in it, every sweep key is checked against the parameters of the modules it sets,
and the chain of every case is found (``SweepPlan.find_templates``).
"""

from __future__ import annotations

from e2esim import registry
from e2esim.errors import ConfigError, Location, ModuleLookupError
from e2esim.limits import check_monte_carlo
from e2esim.params import find_param, iter_params, validate_section
from e2esim.runner.overrides import dotted_path, set_path
from e2esim.runner.plan import Slot, SweepPlan, combinations, number_shapes
from e2esim.runner.sections import (
    NOT_SWEEPABLE,
    PRISTINE,
    build_module,
    items_allowed,
    kind_of,
    object_ids,
    section_kinds,
    top_level_keys,
)
from e2esim.runner.sweep import NOT_SET
from e2esim.settings import SIMULATION_PARAMS, SimulationSettings


class PlanBuilder:
    """Builds the ``SweepPlan`` of a scenario's raw data ``raw`` (read from ``source``; ``lines``: the line of
    every key path, for messages; ``services``: the resolve's ``Services``, handed to the modules' ``setup``
    where it takes them)."""

    def __init__(self, raw: dict, source: str, lines: dict, services=None):
        self.raw, self.source, self.lines, self.services = raw, source, lines, services

    def plan(self, table, root: Location) -> SweepPlan:
        """Build every distinct module and settings of the sweep, check every sweep key, and find the chain of
        every case."""
        keys = []  # (key, key path, group, position in the group)
        for g, group in enumerate(table.groups):
            for p, key in enumerate(group.keys):
                path = dotted_path(key)
                if path[0] in NOT_SWEEPABLE or path[0] not in top_level_keys():
                    raise ConfigError(Location(self.source, ("sweep", key), self.lines), f"cannot sweep over {key!r}",
                                      "sweep keys start with a module section, requirements or simulation")
                value = next((v[p] for v in group.values if v[p] is not NOT_SET), None)
                set_path(dict(self.raw), path, value, Location(self.source, path, self.lines), copy_on_write=True)
                keys.append((key, path, g, p))
        cache: dict = {PRISTINE: object_ids(self.raw)}
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
                                  items_allowed(self.raw.get(path[0]), path[0]))
            self._check_key(key, path, slot, plan)
        plan.find_templates()
        return plan

    def _slot_paths(self, keys: list, root: Location) -> list:
        """(kind, section path) of every slot: the module sections present (or defaulted, or set by a sweep key),
        one per item of a list section, and the simulation settings (last)."""
        out = []
        for kind in section_kinds():
            section = kind.section
            if kind.composite is not None:  # a list of members, or nothing
                items = self.raw.get(section, [])
                if not isinstance(items, list):
                    raise ConfigError(root.child(section), "is not a list",
                                      f"expected a list of {kind.name} sections, each with a type")
                out += [(kind.name, (section, i)) for i in range(len(items))]
                continue
            raw = self.raw.get(section, kind.default)
            if raw is None and not any(k[1][0] == section for k in keys):
                continue
            if isinstance(raw, list) and kind.many:
                out += [(kind.name, (section, i)) for i in range(len(raw))]
            else:
                out.append((kind.name, (section,)))
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
                    and all(v[k[3]] is not NOT_SET for v in table.groups[k[2]].values)]
        for _, key_path, g, p in per_case:
            param = find_param(cls.params, key_path[-1])
            where = Location(self.source, key_path[:-1], self.lines)
            for value in {repr(v[p]): v[p] for v in table.groups[g].values}.values():  # each distinct value once
                validate_section((param,), {param.name: value}, where)
        return per_case

    def _build_object(self, slot: Slot, keys: list, combo, first: int, table, cache: dict, per_case=()):
        """The module (or settings) of ``slot`` for one combination of its sweep groups' positions; ``first`` is
        the first case that has it (named in messages) and gives the values of the keys read ``per_case``."""
        config = dict(self.raw)  # sections a case overrides are copied on the way down (set_path, copy=True)
        lines = dict(self.lines)
        codes = table.codes([first])[0] if per_case else None
        for key, path, g, p in [*keys, *per_case]:
            position = combo[slot.groups.index(g)] if g in slot.groups else codes[g]
            value = table.groups[g].values[position][p]
            if value is NOT_SET:
                continue
            set_path(config, path, value, Location(self.source, path, lines), copy_on_write=True)
            lines[path] = f"sweep case {first}: {key}={value!r}"
        case_root = Location(self.source, (), lines)
        if slot.kind == "simulation":
            settings = SimulationSettings(
                **validate_section(SIMULATION_PARAMS, config.get("simulation"), case_root.child("simulation")))
            check_monte_carlo(settings, case_root.child("simulation").describe())
            return settings
        section = slot.path[0]
        kind = registry.kind(slot.kind)
        raw = config.get(section, kind.default)
        if kind.composite is not None and not isinstance(raw, list):
            raise ConfigError(case_root.child(section), "is not a list",
                              f"expected a list of {kind.name} sections, each with a type")
        if len(slot.path) == 2:
            return build_module(slot.kind, raw[slot.path[1]], case_root.child(section).child(slot.path[1]), cache,
                                self.services)
        return build_module(slot.kind, raw, case_root.child(section), cache, self.services)

    def _check_key(self, key: str, path: tuple, slot: Slot, plan: SweepPlan) -> None:
        """Every module a sweep key sets a value in has that parameter (each class once)."""
        where = Location(self.source, ("sweep", "parameters", key), self.lines)
        if slot.kind == "simulation":
            check_sweep_key(key, self.raw, [], where)
            return
        position = plan.slots.index(slot)
        base = [s.objects[0] for s in plan.module_slots]
        seen = set()
        for module in slot.objects:
            if type(module) in seen:
                continue
            seen.add(type(module))
            check_sweep_key(key, self.raw, base[:position] + [module] + base[position + 1:], where)


def check_sweep_key(key: str, config: dict, modules: list, where: Location) -> None:
    """``key`` names a parameter of the module (one of ``modules``) or settings it sets."""
    path = dotted_path(key)
    head = path[0]
    kind = kind_of(head)
    if head == "simulation":
        params = SIMULATION_PARAMS
        rest = path[1:]
    elif kind is not None and (kind.composite is not None or isinstance(config.get(head), list)):
        if len(path) < 3 or not isinstance(path[1], int):
            raise ConfigError(where, f"{key!r} does not name a parameter of a module in the list {head!r}",
                              f"expected {head}.<index>.<parameter>")
        params = [m for m in modules if m.kind == kind.name][path[1]].params
        rest = path[2:]
    else:
        module = next(m for m in modules if m.kind == kind.name)
        params = module.params
        rest = path[1:]
    if rest == ("type",) and kind is not None:
        return
    dotted = ".".join(str(p) for p in rest)
    if not rest or find_param(params, dotted) is None:
        names = sorted(name for name, _ in iter_params(params))
        raise ConfigError(where, f"no parameter {dotted or head!r} to sweep over in section {head!r}",
                          "parameters here: " + ", ".join(names))
