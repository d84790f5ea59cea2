"""A resolved sweep in factored form: each module of the scenario built once per distinct configuration, not once
per case.

A scenario's modules sit in *slots*: a section (``scene``), an item of a list section (``calibration.1``,
``requirements.0``), and the ``simulation`` settings. A sweep key sets a value inside one slot, so a slot has as
many distinct configurations as the combinations of the sweep groups (``e2esim.runner.sweep.KeyGroup``) that
touch it: a grid of 100 AGB levels x 100 crosstalk levels x 100 imbalance levels has 100 scenes, 10 000
instruments and one of everything else, however many of its million cases run. ``SweepPlan`` builds and
validates those modules (``e2esim validate`` checks every configuration any case uses), and gives for any cases
the number of each slot's module (``object_codes``). The chain of stages of a case follows from its modules
(``e2esim.runner.chain``); cases whose modules have the same classes and declarations share a chain *template*,
whose steps are a slot's module or a composite stage of several slots (the list of a composite kind,
``e2esim.kinds.Kind``: the calibration strategy, the requirement set), built once per distinct combination of
members.

``CaseSpecs`` gives the classic one-case view (``CaseSpec``: inputs, label, settings, modules, chain) of any
case, made when asked for, for the per-case runner and for code that looks at one case.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from e2esim import registry
from e2esim.distinct import distinct_rows
from e2esim.errors import ConfigError, Location
from e2esim.runner.chain import absorbed_at, composite_kinds, composite_stage, order

SETTINGS = "simulation"
_CHUNK = 1 << 20  # cases whose template is found in one vectorised pass


@dataclass
class Slot:
    """One place of the scenario that holds a module (or the simulation settings).

    kind : the module kind ("scene", "calibration", "requirement", ...) or "simulation". path : the key path
    of its section in the scenario (("scene",), ("calibration", 1), ("requirements", 0)). keys : the sweep keys
    that set values in it. case_keys : those of them its module reads per case (``Stage.case_params``), which
    make no module per value. groups : indices of the sweep groups of the other keys. objects : the distinct modules (or
    ``SimulationSettings``), one per combination of the groups' positions. index : for a table sweep (zip or
    cases), the object number of every case; None for a grid, where it is the C-order position of the
    groups' positions in ``sizes`` (every combination occurs).
    """

    kind: str
    path: tuple
    keys: tuple = ()
    groups: tuple = ()
    sizes: tuple = ()
    objects: list = field(default_factory=list)
    index: np.ndarray | None = None
    shapes: np.ndarray | None = None  # chain-shape number of every object (modules only)
    case_keys: tuple = ()

    def object_codes(self, codes: np.ndarray, indices: np.ndarray) -> np.ndarray:
        """Object number of each case, from the sweep positions ``codes`` of the cases ``indices``."""
        if not self.groups:
            return np.zeros(len(indices), dtype=np.int64)
        if self.index is not None:
            return self.index[indices]
        return np.ravel_multi_index(tuple(codes[:, g] for g in self.groups), self.sizes).astype(np.int64)


@dataclass(frozen=True)
class ChainStep:
    """One stage of a chain template: the module of slot ``slots[0]`` (``composite`` None), or the stage of the
    composite kind ``composite`` ("calibration": the calibration strategy; "requirement": the requirement set)
    made of the modules of ``slots`` (``slots[0]`` the module it takes in when the kind ``absorbs`` a product)."""

    slots: tuple
    composite: str | None = None


@dataclass
class Template:
    """Cases whose modules chain the same way: their steps in chain order."""

    steps: tuple


@dataclass
class SweepPlan:
    """Everything needed to run any case of a sweep (module docstring).

    table : the ``SweepTable``. slots : module slots, in section order, then the settings slot (last).
    templates : chain templates; template : the template number of every case (int32, n).
    """

    table: object
    slots: list
    root: Location
    templates: list = field(default_factory=list)
    template: np.ndarray | None = None
    composites: dict = field(default_factory=dict, repr=False)

    @property
    def n(self) -> int:
        return self.table.n

    @property
    def module_slots(self) -> list:
        return self.slots[:-1]

    @property
    def settings_slot(self) -> Slot:
        return self.slots[-1]

    def object_codes(self, indices) -> np.ndarray:
        """(len(indices), slots) object number of every slot in each case."""
        indices = np.asarray(indices, dtype=np.int64)
        codes = self.table.codes(indices)
        return np.stack([s.object_codes(codes, indices) for s in self.slots], axis=-1) if self.slots else \
            np.zeros((len(indices), 0), dtype=np.int64)

    def modules_of(self, objects) -> list:
        """The modules of a case (in section order) from its row of ``object_codes``."""
        return [slot.objects[int(o)] for slot, o in zip(self.module_slots, objects)]

    def settings_of(self, objects):
        return self.settings_slot.objects[int(objects[-1])]

    def stage(self, step: ChainStep, objects):
        """The stage object of ``step`` for a case's row of ``object_codes`` (composites built once per
        distinct members)."""
        members = tuple(self.slots[s].objects[int(objects[s])] for s in step.slots)
        return members[0] if step.composite is None else self._composite(step, members)[0]

    def _composite(self, step: ChainStep, members: tuple) -> tuple:
        """(composite stage, its number in this run) of ``members``."""
        key = (step.composite, tuple(id(m) for m in members))
        if key not in self.composites:
            kind = registry.kind(step.composite)
            stage = composite_stage(kind, list(members), self.root) if kind.absorbs is None else \
                composite_stage(kind, list(members[1:]), self.root, members[0])  # the stage it takes in, first
            # members kept, so that their ids stay theirs; the number identifies the composite in a run
            self.composites[key] = (stage, members, len(self.composites))
        stage, _, number = self.composites[key]
        return stage, number

    def stage_codes(self, step: ChainStep, objects: np.ndarray) -> tuple:
        """(number of each case's stage object, {number: stage}) for cases with rows ``objects`` of
        ``object_codes``: a slot's object number, or a composite's number in this run."""
        if step.composite is None:
            slot = self.slots[step.slots[0]]
            codes = objects[:, step.slots[0]]
            return codes, {int(c): slot.objects[int(c)] for c in distinct_rows(codes[:, None])[0][:, 0]}
        rows, _, inverse = distinct_rows(objects[:, list(step.slots)])
        stages, numbers = {}, []
        for row in rows:
            members = tuple(self.slots[s].objects[int(o)] for s, o in zip(step.slots, row))
            stage, number = self._composite(step, members)
            stages[number] = stage
            numbers.append(number)
        return np.asarray(numbers, dtype=np.int64)[inverse], stages

    def products(self) -> tuple:
        """The ``Product`` declarations of everything the chains of this plan can provide (a plug-in's too), each
        once: what gives the output scalars their units (``e2esim.io.scalar_units``)."""
        found: dict = {}
        for slot in self.module_slots:
            for module in {int(shape): m for shape, m in zip(slot.shapes, slot.objects)}.values():
                for product in getattr(module, "provides", ()):
                    found.setdefault(product.name, product)
        for kind in composite_kinds():
            for product in getattr(kind.composite, "provides", ()):
                found.setdefault(product.name, product)
        return tuple(found.values())

    def chain(self, index: int) -> list:
        objects = self.object_codes([index])[0]
        return [self.stage(step, objects) for step in self.templates[int(self.template[index])].steps]

    # Templates -------------------------------------------------------------------------------------------------
    def find_templates(self) -> None:
        """Give every case its chain template; assemble each template once (``ConfigError`` for a chain that
        cannot be built: a product nobody provides, a cycle; or one that cannot back a requirement's ``sources:
        all``, ``e2esim.requirements.source_check``)."""
        from e2esim.requirements.source_check import check_error_sources

        self._find_templates()
        check_error_sources(self)

    def _find_templates(self) -> None:
        found: dict = {}
        if all(int(slot.shapes.max()) == 0 for slot in self.module_slots):  # one chain for every case
            self.templates.append(self._assemble(self.object_codes([0])[0]))
            self.template = np.zeros(self.n, dtype=np.int32)
            return
        self.template = np.empty(self.n, dtype=np.int32)
        for start in range(0, self.n, _CHUNK):
            indices = np.arange(start, min(start + _CHUNK, self.n))
            objects = self.object_codes(indices)
            shapes = np.stack([s.shapes[objects[:, j]] for j, s in enumerate(self.module_slots)], axis=-1) \
                if self.module_slots else np.zeros((len(indices), 0), dtype=np.int64)
            keys, first, inverse = distinct_rows(shapes)
            numbers = []
            for key, i in zip(map(tuple, keys), first):
                if key not in found:
                    found[key] = len(self.templates)
                    self.templates.append(self._assemble(objects[i]))
                numbers.append(found[key])
            self.template[indices] = np.asarray(numbers, dtype=np.int32)[inverse]

    def _assemble(self, objects) -> Template:
        modules = self.modules_of(objects)
        composites = {k.name: k for k in composite_kinds()}
        stages, steps = [], {}
        for j, module in enumerate(modules):
            if self.slots[j].kind not in composites:
                stages.append(module)
                steps[id(module)] = ChainStep((j,))
        for name, kind in composites.items():
            own = [j for j in range(len(modules)) if self.slots[j].kind == name]
            if not (own or kind.always):
                continue
            if kind.absorbs is None:
                stage = composite_stage(kind, [modules[j] for j in own], self.root)
                stages.append(stage)
                steps[id(stage)] = ChainStep(tuple(own), name)
                continue
            i = absorbed_at(kind, stages, [modules[j] for j in own], self.root)
            taken = steps[id(stages[i])]
            if taken.composite is not None:
                raise ConfigError(self.root.child(kind.section), f"the {kind.section} list refines a product of "
                                  f"{stages[i].identity}, itself a list", "a composite takes in one module's stage")
            stage = composite_stage(kind, [modules[j] for j in own], self.root, stages[i])
            steps[id(stage)] = ChainStep((*taken.slots, *own), name)
            stages[i] = stage
        return Template(tuple(steps[id(stage)] for stage in order(stages)))


def chain_shape(module) -> tuple:
    """What decides a module's place in a chain: its class and the products it needs, uses and provides."""
    return (type(module), tuple(module.needs), tuple(module.uses), tuple(p.name for p in module.provides)) \
        if hasattr(module, "provides") else (type(module), tuple(getattr(module, "needs", ())),
                                             tuple(getattr(module, "uses", ())), ())


def number_shapes(slot: Slot) -> None:
    shapes: dict = {}
    slot.shapes = np.array([shapes.setdefault(chain_shape(m), len(shapes)) for m in slot.objects], dtype=np.int64)


@dataclass
class CaseSpec:
    """One sweep case, ready to run: its inputs, label, settings, its modules (in section order) and the
    chain of stages they form (``e2esim.runner.chain``)."""

    index: int
    inputs: dict
    label: str
    settings: object
    modules: list
    chain: list


class CaseSpecs(Sequence):
    """Every case of a plan as a ``CaseSpec``, made when asked for (a million-case sweep keeps none)."""

    def __init__(self, plan: SweepPlan, labels):
        self.plan = plan
        self.labels = labels

    def __len__(self) -> int:
        return self.plan.n

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        index = range(len(self))[index]
        plan = self.plan
        objects = plan.object_codes([index])[0]
        chain = [plan.stage(step, objects) for step in plan.templates[int(plan.template[index])].steps]
        return CaseSpec(index, plan.table.inputs(index), self.labels[index], plan.settings_of(objects),
                        plan.modules_of(objects), chain)


def first_cases(table, groups: tuple, sizes: tuple) -> np.ndarray:
    """For a grid: the first case index of every combination of ``groups``' positions (C order over
    ``sizes``), the other groups at position 0."""
    strides = np.cumprod((1,) + table.sizes[::-1])[::-1][1:]
    combos = np.stack(np.unravel_index(np.arange(int(np.prod(sizes, dtype=np.int64))), sizes), -1) if groups \
        else np.zeros((1, 0), dtype=np.int64)
    return (combos * np.asarray([strides[g] for g in groups], dtype=np.int64)).sum(-1) if groups \
        else np.zeros(1, dtype=np.int64)


def combinations(table, groups: tuple):
    """(positions of ``groups`` per combination (m, len(groups)), first case of each, index of every case or
    None for a grid)."""
    if table.table is None:
        sizes = tuple(table.sizes[g] for g in groups)
        count = int(np.prod(sizes, dtype=np.int64)) if groups else 1
        combos = np.stack(np.unravel_index(np.arange(count), sizes), -1) if groups else np.zeros((1, 0), np.int64)
        return combos, first_cases(table, groups, sizes), None
    if not groups:
        return np.zeros((1, 0), dtype=np.int64), np.zeros(1, dtype=np.int64), None
    combos, first, inverse = distinct_rows(table.table[:, list(groups)])
    return combos, first, inverse.astype(np.int64)


__all__ = ["CaseSpec", "CaseSpecs", "ChainStep", "Slot", "SweepPlan", "Template"]
