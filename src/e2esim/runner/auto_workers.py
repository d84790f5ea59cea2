"""``--workers auto`` (the default of ``e2esim run`` and ``e2esim.run``): a run starts in this process and hands
its remaining blocks to worker processes when they are worth it.

The first block runs here. Its time, scaled to the cases left, estimates the rest; the first block carries the
run's one-time work (tables built, caches filled), so the estimate errs long. When the estimate exceeds the
threshold (``AUTO_PARALLEL_ABOVE_S``, or the environment variable ``E2ESIM_AUTO_WORKERS_ABOVE_S`` in seconds)
and this process may use more than one core (``os.sched_getaffinity``, else ``os.cpu_count``), the rest runs on
min(cores, blocks left) worker processes (``e2esim.runner.executors.run_blocks``: the journal, Ctrl-C and a lost
worker behave as with ``--workers N``; none from a daemonic process, which may have no children), split into
blocks small enough that each worker gets several. Forked workers start with this process's warm caches and its
stage memo. Below the threshold a pool's start (forking, each worker's first block) would cost about what it
saves, so short runs stay in this process. The numbers are the same either way: each case draws from its own
generator, and a block gives each case's numbers bit for bit.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import time
from dataclasses import dataclass

import numpy as np

from e2esim.errors import UserError
from e2esim.runner.blocks import StageMemo
from e2esim.runner.executors import run_blocks

AUTO = "auto"
AUTO_PARALLEL_ABOVE_S = 2.0
"""The rest of a run goes to worker processes only when it is estimated to take longer than this (seconds): a
pool's start and each worker's first block cost a few tenths of a second."""
THRESHOLD_VARIABLE = "E2ESIM_AUTO_WORKERS_ABOVE_S"


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the system tells it, else the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def may_start_processes() -> bool:
    """Whether this process may have worker processes: not a daemonic one (a worker of someone's
    ``multiprocessing`` pool running ``e2esim.run``), which Python forbids children."""
    return not multiprocessing.current_process().daemon


def parallel_threshold_s() -> float:
    """``AUTO_PARALLEL_ABOVE_S``, or the seconds ``E2ESIM_AUTO_WORKERS_ABOVE_S`` gives (0: always, where the cores
    and the blocks allow)."""
    text = os.environ.get(THRESHOLD_VARIABLE, "").strip()
    if not text:
        return AUTO_PARALLEL_ABOVE_S
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or value < 0:
        raise UserError(f"{THRESHOLD_VARIABLE}={text!r}: expected a number of seconds >= 0 (the estimated time "
                        f"left above which --workers auto starts worker processes; default {AUTO_PARALLEL_ABOVE_S})")
    return value


@dataclass(frozen=True)
class AutoChoice:
    """What ``--workers auto`` chose: ``workers`` processes for the blocks after the first ``first_blocks`` run here
    (1: all in this process), from the rest's estimate ``estimate_s`` (None: not estimated, every block run here), the
    threshold and the cores."""

    workers: int
    threshold_s: float
    cores: int
    first_blocks: int = 0
    rest_blocks: int = 0
    estimate_s: float | None = None
    daemonic: bool = False

    def describe(self) -> str:
        """The run's provenance entry ``workers``."""
        if self.workers > 1:
            return (f"auto: {self.workers} local processes after the first block (the {self.rest_blocks} blocks "
                    f"left estimated at {self.estimate_s:.1f} s, above {self.threshold_s:g} s; "
                    f"{self.cores} cores usable)")
        if self.estimate_s is None:
            why = "nothing left to run" if not self.first_blocks else "one block" if self.first_blocks == 1 else \
                "a daemonic process, which may have no workers" if self.daemonic else "one core usable"
        elif self.estimate_s > self.threshold_s:
            why = "one case left after the first block"
        else:
            why = f"the rest estimated at {self.estimate_s:.1f} s, not above {self.threshold_s:g} s"
        return f"auto: this process ({why})"


def run_auto(resolved, todo: np.ndarray, split, take, options: dict, after_forks=None,
             clock=time.monotonic, on_pool=None) -> AutoChoice:
    """Run the cases ``todo`` as the module docstring says; hand each finished block to ``take`` (as
    ``run_blocks``). ``split(cases, workers)`` -> the blocks of ``cases`` for that many workers
    (``e2esim.runner.run.block_tasks``); ``options``: ``run_blocks``'s keywords; ``after_forks()``: called once no
    worker process will be forked any more (the pool's workers started, or the rest staying here), for what must
    not run while this process forks (a thread importing modules); ``on_pool(workers)``: called once when the rest
    goes to that many workers (the progress bar measures their rate afresh)."""
    threshold, cores, daemonic = parallel_threshold_s(), usable_cores(), not may_start_processes()
    after_forks = after_forks or (lambda: None)
    tasks = split(todo, 1)
    memo = StageMemo()  # shared by this process's blocks and inherited by forked workers
    if len(tasks) < 2 or cores < 2 or daemonic:
        after_forks()
        run_blocks(resolved, tasks, take, 1, stage_memo=memo, **options)
        return AutoChoice(1, threshold, cores, len(tasks), daemonic=daemonic)
    start = clock()
    run_blocks(resolved, tasks[:1], take, 1, stage_memo=memo, **options)
    rest = np.sort(np.concatenate(tasks[1:]))
    estimate = (clock() - start) * len(rest) / len(tasks[0])
    if estimate <= threshold or len(rest) < 2:
        after_forks()
        run_blocks(resolved, tasks[1:], take, 1, stage_memo=memo, **options)
        return AutoChoice(1, threshold, cores, 1, len(tasks) - 1, estimate)
    rest_tasks = split(rest, cores)
    workers = min(cores, len(rest_tasks))
    if on_pool is not None:
        on_pool(workers)
    run_blocks(resolved, rest_tasks, take, workers, stage_memo=memo, started=after_forks, **options)
    return AutoChoice(workers, threshold, cores, 1, len(rest_tasks), estimate)


__all__ = ["AUTO", "AUTO_PARALLEL_ABOVE_S", "THRESHOLD_VARIABLE", "AutoChoice", "parallel_threshold_s", "run_auto",
           "usable_cores"]
