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

import e2esim
from e2esim.errors import UserError
from e2esim.runner.auto_workers import AUTO, run_auto
from e2esim.runner.case_results import BlockResult, CaseResult
from e2esim.runner.cases import case_generator, default_services, run_block, run_case
from e2esim.runner.executors import run_blocks
from e2esim.runner.no_effect import findings
from e2esim.runner.progress import CaseProgress
from e2esim.runner.provenance import dependency_versions, source_commit
from e2esim.runner.result_table import ResultTable
from e2esim.runner.scenario import ResolvedScenario
from e2esim.runner.scenario_files import scenario_input_files
from e2esim.runner.sensitivity import parameter_sensitivity
from e2esim.runner.spill import SPILL_ABOVE_CASES, SpilledBlock, SpillFile, spill_block
from e2esim.runner.stage_products import checked_products

__all__ = [  # the runner's public names, those of its parts included (cases, case_results, stage_products)
    "BLOCK_CASES", "ENGINES", "KEEP_PRODUCTS_UP_TO", "MONTE_CARLO_BLOCK_CASES", "BlockResult", "CaseResult",
    "ScenarioResult", "block_tasks", "case_generator", "checked_products", "default_services", "run_block",
    "run_case", "run_scenario",
]

ENGINES = ("batched", "per_case")
BLOCK_CASES = 4096
"""Cases per block of an analytic sweep: large enough that numpy's per-call overhead vanishes, small enough
that a block's arrays stay in the CPU caches' neighbourhood (a few MB) and the progress bar moves."""
MONTE_CARLO_BLOCK_CASES = 4
"""Cases per block when cases run a Monte Carlo: each takes long on its own, and their samples are large."""
POOL_BLOCKS_PER_WORKER = 8
"""Blocks per worker, at least, when several share a run's cases (``block_tasks``): each gets several, so that they
finish near one another."""
POOL_BLOCK_MIN_CASES = 2
"""Cases per block, at least, when several workers share a run's cases: a block's stages ask their levels for all
its cases at once (``e2esim.requirements.level_search``), and a pool of one-case blocks costs a tenth more CPU than
one of two-case blocks (biomass_ground_cancelled_tomographic's 12 cases after the first block: about 0.5 s)."""
KEEP_PRODUCTS_UP_TO = 2000
"""Runs of at most this many cases keep every case's products (for the report's per-case plots and for
``CaseResult.get``); larger runs keep their columns only."""


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

    blocks : the ``BlockResult``s (columns of every case); ``cases``: the one-case view of them. What is derived
    from a run once (``cases``, ``table``, ``no_effect``, ``map_dataset``) is kept with it, never in another object.
    """

    scenario: ResolvedScenario
    blocks: list
    provenance: dict = field(default_factory=dict)
    sensitivity: dict | None = None
    """The elasticities of the checked values (``output.sensitivity``; ``e2esim.runner.sensitivity``), or None."""
    answer: dict | None = None
    """The answer to the scenario's solve or allocate section (``e2esim.flowdown.answer``), when ``e2esim run``
    computed it, or None."""
    map_dataset: object = field(default=None, init=False, repr=False, compare=False)
    """The map of a map sweep (an xarray Dataset), made on first ask by ``e2esim.maps.netcdf.map_dataset_of`` (the
    writers sit above the runner, which cannot make it) and kept for results.nc, the summary and the report's maps.
    Not an argument: ``dataclasses.replace`` starts a copy without it; nothing encodes or journals a run's result."""

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

    @cached_property
    def no_effect(self) -> list:
        """The settings that change nothing in this run (``e2esim.runner.no_effect.NoEffect``s), found once: the
        summary, the report, the command line and ``Results`` all read them."""
        return findings(self)

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


def block_tasks(resolved: ResolvedScenario, todo: np.ndarray, workers: int = 1) -> list:
    """The blocks to run: the cases ``todo`` (sorted) split by chain template, in runs of at most the block
    size, small enough that every worker gets several (``POOL_BLOCKS_PER_WORKER``), but not below
    ``POOL_BLOCK_MIN_CASES``."""
    plan = resolved.plan
    montecarlo = any(getattr(s, "montecarlo", False) for s in plan.settings_slot.objects)
    size = MONTE_CARLO_BLOCK_CASES if montecarlo else BLOCK_CASES
    if workers > 1:
        size = min(size, max(POOL_BLOCK_MIN_CASES, math.ceil(len(todo) / (workers * POOL_BLOCKS_PER_WORKER))))
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
    workers: int | str = 1,
    scheduler: str | None = None,
    journal=None,
    finished=None,
    engine: str = "batched",
    keep_products: bool | None = None,
    spill: bool | None = None,
    spill_folder=None,
    cache=None,
    memo=None,
    after_forks=None,
) -> ScenarioResult:
    """Run every case (serially, on ``workers`` local processes, on as many as are worth it with ``workers="auto"``
    (``e2esim.runner.auto_workers``) or on the dask cluster at ``scheduler``) with a progress bar; return the
    results with their provenance.

    journal : a ``Journal`` that records each block as it finishes; finished : blocks already done (an iterable of
        ``BlockResult``, from an interrupted run: each is spilled before the next is taken), whose cases are not run
        again. engine : "batched" or
        "per_case" (the reference). keep_products : keep every case's products (default: for runs of at most
        ``KEEP_PRODUCTS_UP_TO`` cases). spill : keep the finished blocks on disk (``e2esim.runner.spill``;
        default: for runs of more than ``SPILL_ABOVE_CASES`` cases that keep no products), in a temporary file
        in ``spill_folder`` (default: the system's temporary folder). cache : ``cache(setting)`` -> the array cache
        of a module's cache setting, handed to the stages through their services (``e2esim.case.Services``; the
        front doors give ``e2esim.io.array_cache.open_cache``); None: every table is computed afresh. memo : the
        ``KernelMemo`` of the run's blocks, kept by a caller that runs the same geometry again (a solve's engine
        runs; other processes get an empty one with its settings); None: the process's own (``process_memo``).
        after_forks : called once no worker process will be forked any more (``workers="auto"``: once the pool's
        workers have started, or once the run stays in this process), for a thread that must not run at a fork.
    """
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
    auto = workers == AUTO and not scheduler
    if scheduler or auto:
        workers = 1  # a cluster's blocks are sized for 8 workers; auto starts in this process
    bar = CaseProgress(n, int(done.sum()), resolved.name, progress, workers)
    def take(block, frame):  # a finished block: saved, kept, counted (Ctrl-C waits for it: run_blocks)
        if journal is not None:
            journal.record(block, frame)
        blocks.append(kept(block))
        bar.update(len(block))

    options = {"engine": engine, "keep_products": keep, "frames": journal is not None, "progress": progress,
               "cache": cache, "memo": memo}
    try:
        if auto:
            choice = run_auto(resolved, todo, lambda cases, w: block_tasks(resolved, cases, w), take, options,
                              after_forks, on_pool=bar.pool_started)
            workers = choice.workers
        else:
            run_blocks(resolved, block_tasks(resolved, todo, workers if not scheduler else 8), take, workers,
                       scheduler, **options)
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
    if auto:
        provenance["workers"] = choice.describe()
    if workers > 1 or scheduler:
        provenance["executor"] = f"dask {scheduler}" if scheduler else f"{workers} local processes"
    if resumed:
        provenance["resumed_cases"] = int(resumed)
    files = journal.input_files if journal is not None else scenario_input_files(resolved)
    if files:
        provenance["input_files"] = files
    result = ScenarioResult(resolved, blocks, provenance)
    result.sensitivity = parameter_sensitivity(result, run_scenario)
    return result


__all__ = ["BLOCK_CASES", "ENGINES", "BlockResult", "CaseResult", "ResultCases", "ScenarioResult",
           "case_generator", "run_block", "run_case", "run_scenario"]
