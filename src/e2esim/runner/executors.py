"""Where sweep cases run: in this process, on local worker processes, or on a dask.distributed cluster.

Every case carries its own seed (``run.case_generator``), so the numbers are the same whichever executor
runs it and in whatever order. The unit of work is a block of cases (``e2esim.runner.run.block_tasks``); the
resolved scenario goes to each worker once, and results come back as each block finishes. Local worker
processes end with the main process, however it ends (``exit_with_parent``). Ctrl-C is the main process's to
handle: it keeps every finished block and stops the workers without waiting for the blocks in flight
(``run_blocks``); a worker that dies ends the run with a message (``WorkerLost``), not a traceback.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import pickle
import re
import signal
import sys
import threading
import time
import weakref
from concurrent.futures import FIRST_COMPLETED, InvalidStateError, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from e2esim.errors import UserError
from e2esim.extras import optional_import
from e2esim.runner.blocks import StageMemo
from e2esim.runner.cases import default_services, run_block
from e2esim.runner.interrupts import interrupts_deferred, worker_signals
from e2esim.runner.journal import encode_block
from e2esim.runner.plaindata import allowed_packages

_PR_SET_PDEATHSIG = 1  # linux/prctl.h
_PARENT_POLL_S = 0.5
_LOST_AFTER_S = 5.0  # a dead worker whose blocks the pool has not marked lost by then died while sending a result

_WORKER: dict = {}  # in a worker process: the scenario it runs blocks of, and its stage memo


def run_blocks(resolved, tasks: list, take, workers: int = 1, scheduler: str | None = None,
               engine: str = "batched", keep_products: bool = False, packages: frozenset | None = None,
               frames: bool = True, progress: bool = False, cache=None, memo=None,
               stage_memo: StageMemo | None = None, started=None) -> None:
    """Run the blocks ``tasks`` and hand each to ``take(BlockResult, journal frame or None)`` as it finishes (not
    necessarily in case order); frames come from other processes, made with ``packages``
    (e2esim.runner.plaindata.allowed_packages), and only when ``frames`` (a run with a journal).

    Ctrl-C (``KeyboardInterrupt``) drops the blocks in flight at once and keeps every finished one: the blocks
    that finished meanwhile are handed to ``take`` too, the workers are stopped without waiting for their blocks,
    and the interrupt is raised again. A ``take`` is never cut short by Ctrl-C (it waits until the block is kept),
    and no block is handed over twice. A worker that dies (killed, out of memory) ends the run with a
    ``WorkerLost`` error; the blocks handed over stay kept. ``progress``: blocks run in this process hand their
    stages a progress bar for long kernels (a global climatology's months); other processes cannot draw one.
    ``cache``: the array cache opener every process hands its stages (``e2esim.runner.cases.default_services``).
    ``memo``: the ``KernelMemo`` of the run's blocks (None: each process's own, ``e2esim.case.process_memo``); another
    process gets an empty one with the same settings. ``stage_memo``: the ``StageMemo`` of the run's blocks in this
    process (None: a new one), which forked workers start from (``--workers auto``: the blocks run here before).
    ``started()``: called once the workers have started (at once where the blocks run here), before any block is
    handed over: from then on this process forks no worker.
    """
    if not tasks:
        return
    if scheduler:
        check_scheduler_address(scheduler)
    if packages is None and frames and (scheduler or workers > 1):
        packages = allowed_packages()
    options = (engine, keep_products, packages, cache, memo)  # a memo sent to a worker arrives empty, with its
    # settings (a solve's ``repeated_geometry``: every process takes the same kernel path, so the same numbers)
    taken: set = set()

    def hand_over(number, block, frame):
        with interrupts_deferred():
            take(block, frame)
            taken.add(number)

    source = None
    try:
        if scheduler:
            source = _DaskBlocks(resolved, tasks, scheduler, options)
        elif workers > 1:
            # Ctrl-C while the pool forks its workers is raised once it is made, so that ``close`` stops them (cut
            # short in there, the pool would be left with workers waiting for blocks, which the interpreter's exit
            # waits for)
            with interrupts_deferred():
                source = _ProcessBlocks(resolved, tasks, workers, options, stage_memo)
        else:
            source = _SerialBlocks(resolved, tasks, options, progress, stage_memo)
        if started is not None:
            started()
        for number, block, frame in source:
            hand_over(number, block, frame)
    except (KeyboardInterrupt, WorkerLost):
        for number, block, frame in source.finished() if source is not None else ():
            if number not in taken:
                hand_over(number, block, frame)
        raise
    finally:
        if source is not None:
            source.close()


class WorkerLost(UserError):
    """A worker process of ``--workers`` or of a dask cluster died while it ran a block."""


class _SerialBlocks:
    """The blocks run one after the other in this process (Ctrl-C drops the one in flight)."""

    def __init__(self, resolved, tasks: list, options: tuple, progress: bool = False, memo: StageMemo | None = None):
        self.resolved, self.tasks, self.options, self.progress, self.memo = resolved, tasks, options, progress, memo

    def __iter__(self):
        engine, keep_products, _, cache, kernel_memo = self.options
        services, memo = default_services(self.progress, cache, kernel_memo), self.memo or StageMemo()
        for number, indices in enumerate(self.tasks):
            yield number, run_block(self.resolved, indices, engine, keep_products, services, memo), None

    def finished(self) -> list:
        return []

    def close(self) -> None:
        pass


class _ProcessBlocks:
    """The blocks run on local worker processes; results as they finish. ``close`` stops the workers at once when
    blocks are still running (Ctrl-C, an error): they ignore SIGINT, which the main process handles."""

    def __init__(self, resolved, tasks: list, workers: int, options: tuple, memo: StageMemo | None = None):
        context = multiprocessing.get_context()  # the pool's default
        # A forked worker inherits the scenario (and the stage memo of the blocks run here before) as they are in
        # memory; other start methods get the scenario pickled once here (not once per worker), and a new memo.
        # Pickling and unpickling a million-case sweep's 10,000 modules costs about a second.
        method = context.get_start_method()
        forked = method == "fork"
        scenario = resolved if forked else pickle.dumps(resolved, protocol=pickle.HIGHEST_PROTOCOL)
        self.resolved = resolved
        # The parent a worker must have: this process, unless a forkserver starts the workers (it ends with this one).
        parent = os.getpid() if method in ("fork", "spawn") else None
        self.pool = ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=_start_worker,
                                        initargs=(scenario, memo if forked else None, parent))
        self.number = {self.pool.submit(run_block_remote, indices, options): k for k, indices in enumerate(tasks)}
        # the worker processes, started by the submits (the pool forgets them once it is broken)
        self.processes = list((getattr(self.pool, "_processes", None) or {}).values())

    def __iter__(self):
        pending, dead_since = set(self.number), None
        while pending:
            done, pending = wait(pending, timeout=_PARENT_POLL_S, return_when=FIRST_COMPLETED)
            for future in done:
                yield self._result(future)
            if not done and any(getattr(p, "exitcode", None) is not None for p in self.processes):
                # The pool marks its blocks lost within milliseconds of a worker's death, unless the worker died
                # while it sent a result: then the pool's reader waits for the rest for ever (see ``close``).
                dead_since = dead_since or time.monotonic()
                if time.monotonic() - dead_since > _LOST_AFTER_S:
                    raise self._lost()

    def _result(self, future) -> tuple:
        try:
            data, frame, reads = future.result()
        except BrokenProcessPool as exc:
            raise self._lost() from exc
        note_worker_reads(self.resolved, reads)
        return self.number[future], pickle.loads(data), frame

    def _lost(self) -> WorkerLost:
        return WorkerLost(f"a worker process ended abruptly ({_how_it_ended(self.processes)}); the blocks it was "
                          "running are lost")

    def finished(self) -> list:
        """The blocks that finished without error (handed over or not)."""
        done = [f for f in self.number if f.done() and not f.cancelled() and f.exception() is None]
        return [self._result(f) for f in sorted(done, key=self.number.get)]

    def close(self) -> None:
        for future in self.number:
            future.cancel()
        if all(f.done() for f in self.number):
            self.pool.shutdown(wait=True)
            return
        processes = self.processes + [p for p in (getattr(self.pool, "_processes", None) or {}).values()
                                      if p not in self.processes]
        results = getattr(self.pool, "_result_queue", None)  # the pool forgets it on shutdown
        quiet_cancelled_future_race(getattr(self.pool, "_executor_manager_thread", None))
        self.pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:  # the blocks in flight are dropped, not waited for (a worker writes no file)
            with contextlib.suppress(OSError, ValueError, AttributeError):
                process.kill()
        for process in processes:
            with contextlib.suppress(OSError, ValueError, AttributeError, AssertionError):
                process.join(timeout=5)
        # A worker killed while it sent a result (over 16 KiB: header, then body) leaves the pool's result reader
        # waiting for the rest for ever: this process holds the pipe's writing end too, so no end of file comes,
        # and the interpreter's exit joins that reader (the rare hang on SIGTERM). With the workers dead, closing
        # that end ends the read; the pool then ends as for a lost worker.
        with contextlib.suppress(OSError, AttributeError):
            results._writer.close()


def quiet_cancelled_future_race(thread) -> None:
    """Keep the pool's own ``thread`` quiet where Python's pool races with a cancel: a worker that dies of the Ctrl-C
    its process group got makes that thread mark the blocks in flight as broken, and Python 3.11 then sets an
    exception on a future this process has just cancelled, which raises ``InvalidStateError`` in that thread
    (``concurrent.futures.process``, ``terminate_broken``): a traceback after the run's one message. Only that
    error of the pools this process closes is left unsaid (any other pool's, a program's own, is printed); the
    blocks are dropped either way."""
    if thread is None:
        return
    _CLOSED_POOL_THREADS.add(thread)
    previous = threading.excepthook
    if getattr(previous, "quiets_cancelled_futures", False):
        return

    def hook(args) -> None:
        if not (isinstance(args.exc_value, InvalidStateError) and args.thread in _CLOSED_POOL_THREADS):
            previous(args)

    hook.quiets_cancelled_futures = True
    threading.excepthook = hook


_CLOSED_POOL_THREADS: weakref.WeakSet = weakref.WeakSet()
"""The manager threads of the pools being closed (``quiet_cancelled_future_race``), held weakly."""


def _how_it_ended(processes: list) -> str:
    """'killed by SIGKILL, ...' and the like, for the message. The pool's own thread may be reaping the dead worker
    just now (its exit code then reads None for a moment): asked again for up to a second."""
    deadline = time.monotonic() + 1.0
    while True:
        codes = sorted({p.exitcode for p in processes if getattr(p, "exitcode", None) not in (None, 0)})
        if codes or time.monotonic() > deadline:
            break
        time.sleep(0.02)
    if len(codes) > 1:  # the pool ends the other workers with SIGTERM once one has died
        codes = [c for c in codes if c != -signal.SIGTERM]
    how = [f"killed by {_signal_name(-c)}" for c in codes if c < 0] + [f"exit status {c}" for c in codes if c > 0]
    return ", ".join(how + ["by hand, or by the system when memory ran out"])


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def run_block_remote(indices, options: tuple, resolved=None) -> tuple:
    """``run_block`` in another process: the result as (pickle, journal frame or None), both made here. The
    pickle carries the result to the main process (memory to memory, never a file); the frame, plain data
    (e2esim.runner.journal), is what the main process appends to the journal as it is. The scenario comes with
    the call (dask) or was set once when the worker started (``_start_worker``). No frame when ``packages`` is
    None (no journal)."""
    engine, keep_products, packages, cache, kernel_memo = options
    if resolved is None:
        resolved = _WORKER["resolved"]
    if _WORKER.get("for") is not resolved:  # the first block of a run here: its memo serves the run's other blocks
        _WORKER.update({"for": resolved, "reads_sent": {}, "memo": _WORKER.pop("inherited", None) or StageMemo(),
                        "services": default_services(cache=cache, memo=kernel_memo)})
    result = run_block(resolved, indices, engine, keep_products, _WORKER["services"], _WORKER["memo"])
    frame = None if packages is None else encode_block(result, packages)
    return pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL), frame, _reads_grown(resolved, indices)


def _reads_grown(resolved, indices) -> dict:
    """{(slot, object): names} of the modules of the block ``indices`` whose record of the parameters they read
    (``Module.params_read``) grew in this process since the last block sent. The main process adds them to its own
    modules (``note_worker_reads``), so that the settings a run never read (``e2esim.runner.no_effect``) are found
    whichever processes ran its cases."""
    plan = resolved.plan
    sent, grown = _WORKER.setdefault("reads_sent", {}), {}
    codes = plan.object_codes(indices)
    for i, slot in enumerate(plan.module_slots):
        for j in np.unique(codes[:, i]).tolist():
            noted = getattr(slot.objects[j], "reads_noted", None)
            names = noted() if noted is not None else frozenset()
            if names and sent.get((i, j)) != names:
                grown[(i, j)] = sent[(i, j)] = names
    return grown


def note_worker_reads(resolved, grown: dict) -> None:
    """Add what a worker's modules read (``_reads_grown``) to this process's modules of ``resolved``."""
    slots = resolved.plan.module_slots
    for (i, j), names in grown.items():
        note = getattr(slots[i].objects[j], "note_reads", None)
        if note is not None:
            note(names)


def _start_worker(scenario, memo: StageMemo | None = None, parent: int | None = None) -> None:
    """Worker initializer: ``scenario`` is the resolved scenario (inherited by a forked worker) or its pickle;
    ``memo`` the main process's ``StageMemo`` (inherited by a forked worker) or None; ``parent`` the PID of the
    process that started the pool (None: a forkserver's worker)."""
    exit_with_parent(parent)
    worker_signals()
    _WORKER["resolved"] = pickle.loads(scenario) if isinstance(scenario, bytes) else scenario
    _WORKER["inherited"] = memo


def exit_with_parent(expected: int | None = None) -> None:
    """Worker initializer: end this worker when its parent dies, even by SIGKILL (which gives the main process
    no chance to stop its workers). The parent is the main process (fork, spawn) or the forkserver, which
    itself ends with the main process. Linux: the kernel sends SIGKILL on the parent's death
    (PR_SET_PDEATHSIG); everywhere: a daemon thread polls the parent's PID every half second. ``expected``: the
    PID the parent had when it started the pool. A parent killed between the fork and this call (a SIGKILL just
    as a pool starts) has left this worker to another process already, which the signal and the watch would
    take for the parent: such a worker ends here (it would otherwise wait for blocks for ever)."""
    parent = os.getppid() if expected is None else expected
    _set_parent_death_signal()
    if os.getppid() != parent:  # the parent died before the signal was armed
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent,), name="e2esim-parent-watch", daemon=True).start()


def _set_parent_death_signal() -> None:
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # pragma: no cover - no libc prctl: the watch thread does it
        pass


def _watch_parent(parent_pid: int) -> None:
    while True:
        time.sleep(_PARENT_POLL_S)
        if os.getppid() != parent_pid:
            os._exit(1)


_SCHEDULER_SCHEMES = ("tcp", "tls", "ucx", "ws", "wss", "inproc")
_ADDRESS = re.compile(r"^(?:(?P<scheme>[a-z][a-z0-9+.-]*)://)?(?P<rest>[^\s/]+)$")


def check_scheduler_address(address: str) -> None:
    """Refuse an address dask cannot mean, with a message, before trying to connect."""
    m = _ADDRESS.match(str(address))
    scheme = (m.group("scheme") or "tcp") if m else None
    if m is None or scheme not in _SCHEDULER_SCHEMES:
        shown = " ".join(str(address).split())[:80]
        raise UserError(f"--scheduler {shown!r}: not a dask scheduler address; expected SCHEME://HOST:PORT with "
                        f"SCHEME one of {', '.join(_SCHEDULER_SCHEMES)} (e.g. tcp://10.0.0.5:8786), or HOST:PORT")


CLUSTER_PURPOSE = "--scheduler (a dask.distributed cluster)"


class _DaskBlocks:
    """The blocks run on the dask.distributed cluster at ``address``; results as they finish."""

    def __init__(self, resolved, tasks: list, address: str, options: tuple):
        Client = optional_import("distributed", "cluster", CLUSTER_PURPOSE).Client
        self.resolved = resolved
        try:
            self.client = Client(address, timeout="20s")
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            reason = " ".join(str(exc).split())[:200]
            raise UserError(f"cannot connect to the dask scheduler at {address}: {reason}") from exc
        try:
            scenario = self.client.scatter(resolved, broadcast=True)  # once per worker, not per block
            futures = self.client.map(run_block_remote, tasks, options=options, resolved=scenario, pure=False)
        except BaseException:
            self.client.close()
            raise
        self.number = {future: k for k, future in enumerate(futures)}

    def __iter__(self):
        as_completed = optional_import("distributed", "cluster", CLUSTER_PURPOSE).as_completed

        for future in as_completed(list(self.number)):
            yield self._result(future)

    def _result(self, future) -> tuple:
        try:
            data, frame, reads = future.result()
        except Exception as exc:
            if type(exc).__name__ != "KilledWorker":
                raise
            raise WorkerLost("dask workers died while running a block (killed, or out of memory); the blocks they "
                             "were running are lost") from exc
        note_worker_reads(self.resolved, reads)
        return self.number[future], pickle.loads(data), frame

    def finished(self) -> list:
        done = [f for f in self.number if f.status == "finished"]
        return [self._result(f) for f in sorted(done, key=self.number.get)]

    def close(self) -> None:
        with contextlib.suppress(Exception):  # a cluster that went away: nothing left to cancel
            self.client.cancel(list(self.number))
        self.client.close()
