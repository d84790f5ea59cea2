"""Where sweep cases run: in this process, on local worker processes, or on a dask.distributed cluster.

Every case carries its own seed (``run.case_generator``), so the numbers are the same whichever executor
runs it and in whatever order. The unit of work is a block of cases (``e2esim.runner.run.block_tasks``); the
resolved scenario goes to each worker once, and results come back as each block finishes. Local worker
processes end with the main process, however it ends (``exit_with_parent``).
"""

from __future__ import annotations

import os
import pickle
import re
import signal
import sys
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

from e2esim.errors import UserError

_PR_SET_PDEATHSIG = 1  # linux/prctl.h
_PARENT_POLL_S = 0.5

_WORKER: dict = {}  # in a worker process: the scenario it runs blocks of, and its stage memo


def iter_blocks(resolved, tasks: list, workers: int = 1, scheduler: str | None = None, engine: str = "batched",
                keep_products: bool = False, packages: frozenset | None = None, frames: bool = True):
    """Yield ``(BlockResult, journal frame or None)`` as blocks finish (not necessarily in case order); frames
    come from other processes, made with ``packages`` (e2esim.runner.plaindata.allowed_packages), and only
    when ``frames`` (a run with a journal)."""
    from e2esim.runner.blocks import StageMemo
    from e2esim.runner.run import default_services, run_block

    if not tasks:
        return
    if scheduler:
        check_scheduler_address(scheduler)
    if not scheduler and workers <= 1:
        services, memo = default_services(), StageMemo()
        for indices in tasks:
            yield run_block(resolved, indices, engine, keep_products, services, memo), None
        return
    if packages is None and frames:
        from e2esim.runner.plaindata import allowed_packages

        packages = allowed_packages()
    options = (engine, keep_products, packages)
    remote = _dask(resolved, tasks, scheduler, options) if scheduler else _processes(resolved, tasks, workers,
                                                                                        options)
    for data, frame in remote:
        yield pickle.loads(data), frame


def run_block_remote(indices, options: tuple, resolved=None) -> tuple:
    """``run_block`` in another process: the result as (pickle, journal frame or None), both made here. The
    pickle carries the result to the main process (memory to memory, never a file); the frame, plain data
    (e2esim.runner.journal), is what the main process appends to the journal as it is. The scenario comes with
    the call (dask) or was set once when the worker started (``_start_worker``). No frame when ``packages`` is
    None (no journal)."""
    from e2esim.runner.blocks import StageMemo
    from e2esim.runner.journal import encode_block
    from e2esim.runner.run import default_services, run_block

    engine, keep_products, packages = options
    if resolved is None:
        resolved = _WORKER["resolved"]
    if _WORKER.get("for") is not resolved:
        _WORKER.update({"for": resolved, "memo": StageMemo(), "services": default_services()})
    result = run_block(resolved, indices, engine, keep_products, _WORKER["services"], _WORKER["memo"])
    frame = None if packages is None else encode_block(result, packages)
    return pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL), frame


def _start_worker(scenario: bytes) -> None:
    exit_with_parent()
    _WORKER["resolved"] = pickle.loads(scenario)


def _processes(resolved, tasks: list, workers: int, options: tuple):
    scenario = pickle.dumps(resolved, protocol=pickle.HIGHEST_PROTOCOL)  # sent once to each worker, not per block
    with ProcessPoolExecutor(max_workers=workers, initializer=_start_worker, initargs=(scenario,)) as pool:
        pending = {pool.submit(run_block_remote, indices, options) for indices in tasks}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    yield future.result()
        except BaseException:
            for future in pending:
                future.cancel()
            raise


def exit_with_parent() -> None:
    """Worker initializer: end this worker when its parent dies, even by SIGKILL (which gives the main process
    no chance to stop its workers). The parent is the main process (fork, spawn) or the forkserver, which
    itself ends with the main process. Linux: the kernel sends SIGKILL on the parent's death
    (PR_SET_PDEATHSIG); everywhere: a daemon thread polls the parent's PID every half second."""
    parent = os.getppid()
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


def _dask(resolved, tasks: list, address: str, options: tuple):
    try:
        from distributed import Client, as_completed
    except ImportError as exc:  # pragma: no cover - dask.distributed is a dependency
        raise UserError("--scheduler needs dask.distributed (pip install distributed)") from exc
    try:
        client = Client(address, timeout="20s")
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        reason = " ".join(str(exc).split())[:200]
        raise UserError(f"cannot connect to the dask scheduler at {address}: {reason}") from exc
    try:
        scenario = client.scatter(resolved, broadcast=True)  # once per worker, not per block
        futures = client.map(run_block_remote, tasks, options=options, resolved=scenario, pure=False)
        try:
            for future in as_completed(futures):
                yield future.result()
        except BaseException:
            client.cancel(futures)
            raise
    finally:
        client.close()
