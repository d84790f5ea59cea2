"""Run every sweep case of a resolved scenario through its chain of stages, block by block.

Each case gets its own generator, ``numpy.random.Generator(PCG64(SeedSequence(seed, spawn_key=(i,))))``,
so its numbers depend only on the seed and its index, not on the order in which cases run, how many run at
once, or which other cases share its block (numpy's parallel random-number guide; Scientific Python SPEC 7).

Blocks of cases (``e2esim.runner.blocks``) are the unit of work: of the executors (serial, local processes,
dask), of the resume journal and of the outputs. ``engine="per_case"`` runs the same blocks one case at a time
through ``run_case``, the reference the batched engine is checked and timed against (``--per-case``).
"""

from __future__ import annotations

import math
import platform
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from functools import cached_property

import numpy as np
from tqdm.auto import tqdm

import e2esim
from e2esim.block import Values
from e2esim.case import Case, Products, Services
from e2esim.errors import UserError
from e2esim.io.array_cache import open_cache
from e2esim.runner.columns import (
    RequirementColumns,
    case_notes,
    dict_columns,
    requirement_columns,
    scalar_columns,
    source_group_column,
)
from e2esim.runner.progress import CaseProgress
from e2esim.runner.provenance import dependency_versions, source_commit
from e2esim.runner.records import case_scalars
from e2esim.runner.result_table import ResultTable
from e2esim.runner.scenario import ResolvedScenario
from e2esim.runner.spill import SPILL_ABOVE_CASES, SpilledBlock, SpillFile, spill_block

ENGINES = ("batched", "per_case")
BLOCK_CASES = 4096
"""Cases per block of an analytic sweep: large enough that numpy's per-call overhead vanishes, small enough
that a block's arrays stay in the CPU caches' neighbourhood (a few MB) and the progress bar moves."""
MONTE_CARLO_BLOCK_CASES = 4
"""Cases per block when cases run a Monte Carlo: each takes long on its own, and their samples are large."""
KEEP_PRODUCTS_UP_TO = 2000
"""Runs of at most this many cases keep every case's products (for the report's per-case plots and for
``CaseResult.get``); larger runs keep their columns only."""


@dataclass
class CaseResult:
    """Outcome of one case: its inputs, the products its stages made (when kept) and the flattened scalars
    (``e2esim.runner.records``)."""

    index: int
    inputs: dict
    label: str
    products: Products
    scalars: dict
    verdict_list: tuple | None = None
    note_list: tuple | None = None
    groups: dict | None = None

    def get(self, name: str, default=None):
        """The product ``name`` of this case, or ``default``."""
        return self.products.get(name, default)

    @property
    def verdicts(self) -> tuple:
        """The requirement verdicts, in scenario order (empty without requirements)."""
        if self.verdict_list is not None:
            return self.verdict_list
        verdicts = self.products.get("verdicts")
        return tuple(verdicts) if verdicts is not None else ()

    @property
    def notes(self) -> tuple:
        """Remarks of the propagation's error model (e.g. why the analytic model was not used)."""
        if self.note_list is not None:
            return self.note_list
        model = self.products.get("backscatter.error")
        return tuple(getattr(model, "notes", ())) if model is not None else ()


@dataclass
class BlockResult:
    """The results of a block of cases as columns (``e2esim.runner.columns``).

    indices : the cases (B,). scalars : {name: Column}. requirements : ``RequirementColumns`` per requirement.
    notes : the error model's notes per case. groups : {source: group} of the AGB error's contributions per
    case (``Values``). products : every case's ``Products`` when kept, else None.
    """

    indices: np.ndarray
    scalars: dict
    requirements: list
    notes: Values
    groups: Values
    products: list | None = None

    def __len__(self) -> int:
        return len(self.indices)

    def case(self, k: int, inputs: dict, label: str) -> CaseResult:
        """The ``CaseResult`` of the block's k-th case."""
        scalars = {name: float(c.values[k]) for name, c in self.scalars.items() if c.has(k)}
        return CaseResult(int(self.indices[k]), inputs, label,
                          self.products[k] if self.products is not None else Products(), scalars,
                          tuple(r.verdict(k) for r in self.requirements), tuple(self.notes[k]), self.groups[k])

    def without_products(self) -> BlockResult:
        return BlockResult(self.indices, self.scalars, self.requirements, self.notes, self.groups)

    @classmethod
    def from_cases(cls, results: list) -> BlockResult:
        """From one-case results of the per-case runner (``run_case``)."""
        n = len(results)
        scalars = dict_columns([r.scalars for r in results])
        count = len(results[0].verdicts) if results else 0
        requirements = [RequirementColumns.from_verdicts([r.verdicts[j] for r in results]) for j in range(count)]
        groups = [{c.name: c.group for c in getattr(r.products.get("agb.error"), "contributions", ())}
                  for r in results]
        return cls(np.array([r.index for r in results], dtype=np.int64), scalars, requirements,
                   Values.of([tuple(r.notes) for r in results]), Values(groups, np.arange(n)),
                   [r.products for r in results])


REMEMBER_CASES_UP_TO = 10_000
"""Runs of at most this many cases keep each ``CaseResult`` once made: the report and summary.json of such a run
read every case some twenty times (e2esim.io.summary.LARGE_RUN_CASES), larger runs not at all."""


class ResultCases(Sequence):
    """The cases of a run as ``CaseResult``s, made from the blocks when asked for (and kept in a run of at most
    ``REMEMBER_CASES_UP_TO`` cases)."""

    def __init__(self, scenario: ResolvedScenario, blocks: list):
        self.scenario = scenario
        self.blocks = blocks
        n = len(scenario.cases)
        self._made: dict | None = {} if n <= REMEMBER_CASES_UP_TO else None
        self._last: tuple = (None, None)  # (number, BlockResult) of the spilled block read back last
        starts = np.array([int(b.indices[0]) for b in blocks], dtype=np.int64)
        ranges = all(int(b.indices[-1]) - int(b.indices[0]) == len(b) - 1 for b in blocks)
        if ranges and np.all(np.diff(starts) > 0):  # blocks of consecutive cases (the rule): found by their start
            self._starts, self._block, self._position = starts, None, None
            return
        self._starts = None
        self._block = np.empty(n, dtype=np.int32)
        self._position = np.empty(n, dtype=np.int64)
        for b, block in enumerate(blocks):
            self._block[block.indices] = b
            self._position[block.indices] = np.arange(len(block))

    def __len__(self) -> int:
        return len(self.scenario.cases)

    def _locate(self, index: int) -> tuple:
        """(block number, position in the block) of case ``index``."""
        if self._starts is None:
            return int(self._block[index]), int(self._position[index])
        b = int(np.searchsorted(self._starts, index, side="right")) - 1
        return b, index - int(self._starts[b])

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        index = range(len(self))[index]
        if self._made is not None and index in self._made:
            return self._made[index]
        number, position = self._locate(index)
        block = self._in_memory(number)
        plan = self.scenario.plan
        label = self.scenario.cases.labels[index] if plan is not None else self.scenario.cases[index].label
        inputs = plan.table.inputs(index) if plan is not None else self.scenario.cases[index].inputs
        case = block.case(position, inputs, label)
        if self._made is not None:
            self._made[index] = case
        return case

    def _in_memory(self, number: int):
        """Block ``number``, read back from disk if it was spilled (``e2esim.runner.spill``; the last one kept, as
        cases are mostly asked for in order)."""
        block = self.blocks[number]
        if not isinstance(block, SpilledBlock):
            return block
        if self._last[0] != number:
            self._last = (number, block.load())
        return self._last[1]


@dataclass
class ScenarioResult:
    """All cases of a run, with provenance (package version, seed, time, resolved scenario).

    blocks : the ``BlockResult``s (columns of every case); ``cases``: the one-case view of them.
    """

    scenario: ResolvedScenario
    blocks: list
    provenance: dict = field(default_factory=dict)

    @cached_property
    def cases(self) -> ResultCases:
        return ResultCases(self.scenario, self.blocks)

    @property
    def requirement_names(self) -> list:
        return self.scenario.requirement_names

    @cached_property
    def table(self) -> ResultTable:
        """Every case's scalars and verdicts as columns in case order (``e2esim.runner.result_table``)."""
        return ResultTable.of(self.blocks, len(self.scenario.cases))

    @property
    def keeps_products(self) -> bool:
        """Whether the cases' products (Monte Carlo samples, acquisitions, distributions) were kept."""
        return bool(self.blocks) and all(b.products is not None for b in self.blocks)

    @property
    def labels(self):
        """One label per case (``e2esim.runner.sweep.CaseLabels``: made when asked for)."""
        if self.scenario.plan is not None:
            return self.scenario.cases.labels
        return [c.label for c in self.scenario.cases]

    def input_columns(self) -> dict:
        """{sweep key: [value in every case]}."""
        if self.scenario.plan is not None:
            return self.scenario.plan.table.input_columns()
        return {k: [c.inputs.get(k) for c in self.scenario.cases] for k in self.scenario.sweep_keys}


def case_generator(seed: int, index: int) -> np.random.Generator:
    """The random generator of case ``index`` for root ``seed``."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(index,))))


def default_services(progress: bool = False) -> Services:
    """What the runner hands to stages: the array cache of a module's setting, and a progress bar for long
    kernels on the command line."""
    return Services(cache=open_cache, progress=_progress_bar if progress else None)


def _progress_bar(iterable, total=None, description=""):
    return tqdm(iterable, total=total, desc=description, leave=False)


def run_case(spec, services: Services | None = None) -> CaseResult:
    """Pass one case through its chain of stages (``e2esim.module.Stage``): each stage reads the products it
    needs and returns its own, which are added to the case (never overwritten)."""
    case = Case(index=spec.index, inputs=spec.inputs, settings=spec.settings,
                rng=case_generator(spec.settings.seed, spec.index), services=services or default_services())
    for stage in spec.chain:
        case = case.adding(checked_products(stage, stage.forward(case)))
    declared = {p.name: p for stage in spec.chain for p in stage.provides}  # plug-in products included
    return CaseResult(spec.index, spec.inputs, spec.label, case.products, case_scalars(case.products, declared))


def checked_products(stage, new) -> dict:
    """``new`` if it holds exactly the products ``stage`` declares, each of its declared type."""
    declared = {p.name: p for p in stage.provides}
    if not isinstance(new, dict) or set(new) != set(declared):
        got = ", ".join(new) if isinstance(new, dict) else type(new).__name__
        raise TypeError(f"{stage.identity} returned {got or 'nothing'}; it declares {', '.join(declared) or 'nothing'}")
    for name, value in new.items():
        declared[name].check(value, stage.identity)
    return new


def run_block(resolved: ResolvedScenario, indices, engine: str = "batched", keep_products: bool = False,
              services: Services | None = None, memo=None) -> BlockResult:
    """The results of the cases ``indices`` (one chain template) of ``resolved``."""
    from e2esim.runner.blocks import BlockRun

    services = services or default_services()
    if engine == "per_case":
        result = BlockResult.from_cases([run_case(resolved.cases[int(i)], services) for i in indices])
        return result if keep_products else result.without_products()
    run = BlockRun(resolved.plan, indices, services, memo)
    products = run.run()
    n = len(run.indices)
    declared = {p.name: p for step in run.template.steps
                for p in resolved.plan.stage(step, run.objects[0]).provides}
    kept = None
    if keep_products:
        kept = [Products({name: value.item(k) for name, value in products.items()}) for k in range(n)]
    return BlockResult(run.indices, scalar_columns(products, n, declared),
                       requirement_columns(products.get("verdicts"), n),
                       case_notes(products.get("backscatter.error"), n),
                       source_group_column(products.get("agb.error"), n), kept)


def block_tasks(resolved: ResolvedScenario, todo: np.ndarray, workers: int = 1) -> list:
    """The blocks to run: the cases ``todo`` (sorted) split by chain template, in runs of at most the block
    size, small enough that every worker gets several."""
    plan = resolved.plan
    montecarlo = any(getattr(s, "montecarlo", False) for s in plan.settings_slot.objects)
    size = MONTE_CARLO_BLOCK_CASES if montecarlo else BLOCK_CASES
    if workers > 1:
        size = max(1, min(size, math.ceil(len(todo) / (workers * 8))))
    tasks = []
    templates = plan.template[todo]
    for t in np.unique(templates):
        cases = todo[templates == t]
        tasks += [cases[i:i + size] for i in range(0, len(cases), size)]
    tasks.sort(key=lambda c: int(c[0]))
    return tasks


def run_scenario(
    resolved: ResolvedScenario,
    progress: bool = True,
    command: str | None = None,
    workers: int = 1,
    scheduler: str | None = None,
    journal=None,
    finished=None,
    engine: str = "batched",
    keep_products: bool | None = None,
    spill: bool | None = None,
    spill_folder=None,
) -> ScenarioResult:
    """Run every case (serially, on ``workers`` local processes or on the dask cluster at ``scheduler``)
    with a progress bar; return the results with their provenance.

    journal : a ``Journal`` that records each block as it finishes; finished : blocks already done (an iterable of
        ``BlockResult``, from an interrupted run: each is spilled before the next is taken), whose cases are not run
        again. engine : "batched" or
        "per_case" (the reference). keep_products : keep every case's products (default: for runs of at most
        ``KEEP_PRODUCTS_UP_TO`` cases). spill : keep the finished blocks on disk (``e2esim.runner.spill``;
        default: for runs of more than ``SPILL_ABOVE_CASES`` cases that keep no products), in a temporary file
        in ``spill_folder`` (default: the system's temporary folder).
    """
    from e2esim.runner.executors import run_blocks

    if engine not in ENGINES:
        raise UserError(f"engine {engine!r}: expected one of {', '.join(ENGINES)}")
    n = len(resolved.cases)
    keep = n <= KEEP_PRODUCTS_UP_TO if keep_products is None else keep_products
    if keep and spill:
        raise ValueError("a run that keeps its cases' products keeps its blocks in memory (spill=False)")
    spill_file = SpillFile(spill_folder) if (n > SPILL_ABOVE_CASES and not keep if spill is None else spill) else None
    kept = (lambda block: block) if spill_file is None else (lambda block: spill_block(block, spill_file))
    blocks = []
    for block in finished or ():
        blocks.append(kept(block))
        del block  # not held while the next is read from the journal
    resumed = sum(len(block) for block in blocks)
    done = np.zeros(n, dtype=bool)
    for block in blocks:
        done[block.indices] = True
    todo = np.flatnonzero(~done)
    bar = CaseProgress(n, int(done.sum()), resolved.name, progress, workers if not scheduler else 1)
    def take(block, frame):  # a finished block: saved, kept, counted (Ctrl-C waits for it: run_blocks)
        if journal is not None:
            journal.record(block, frame)
        blocks.append(kept(block))
        bar.update(len(block))

    try:
        run_blocks(resolved, block_tasks(resolved, todo, workers if not scheduler else 8), take, workers, scheduler,
                   engine=engine, keep_products=keep, frames=journal is not None, progress=progress)
    finally:
        bar.close()
    blocks.sort(key=lambda b: int(b.indices[0]))
    seeds = sorted({s.seed for s in resolved.plan.settings_slot.objects})
    provenance = {
        "e2esim_version": e2esim.__version__,
        "created_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "seed": seeds[0] if len(seeds) == 1 else seeds,
        "scenario_file": resolved.source,
        "command": command or " ".join(sys.argv),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "versions": dependency_versions(),
        "source_commit": source_commit(),
    }
    if engine != "batched":
        provenance["engine"] = engine
    if workers > 1 or scheduler:
        provenance["executor"] = f"dask {scheduler}" if scheduler else f"{workers} local processes"
    if resumed:
        provenance["resumed_cases"] = int(resumed)
    return ScenarioResult(resolved, blocks, provenance)


__all__ = ["BLOCK_CASES", "ENGINES", "BlockResult", "CaseResult", "ResultCases", "ScenarioResult",
           "case_generator", "run_block", "run_case", "run_scenario"]
