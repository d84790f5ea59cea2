"""Where sweep cases run: in this process, on local worker processes, or on a dask.distributed cluster.

Every case carries its own seed (``run.case_generator``), so the numbers are the same whichever executor
runs it and in whatever order. Cases are sent in batches to keep the per-task overhead small; results
come back as each batch finishes. Local worker processes end with the main process, however it ends
(``exit_with_parent``).
"""

from __future__ import annotations

import math
import os
import pickle
import re
import signal
import sys
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

from e2esim.errors import UserError

_BATCHES_PER_WORKER = 8  # enough batches for load balancing and frequent journal writes
_PR_SET_PDEATHSIG = 1  # linux/prctl.h
_PARENT_POLL_S = 0.5


def run_batch(specs: list) -> list:
    from e2esim.runner.run import run_case

    return [run_case(spec) for spec in specs]


def run_batch_remote(specs: list, packages: frozenset) -> list:
    """``run_batch`` for another process: each result as (pickle, journal frame or None), both made here.
    The pickle carries the result to the main process (memory to memory, never a file); the frame, plain
    data (e2esim.runner.journal), is what the main process appends to the journal as it is."""
    from e2esim.runner.journal import encode_case

    return [(pickle.dumps(r, protocol=pickle.HIGHEST_PROTOCOL), encode_case(r, packages)) for r in run_batch(specs)]


def _batches(specs: list, workers: int) -> list:
    size = max(1, math.ceil(len(specs) / (workers * _BATCHES_PER_WORKER)))
    return [specs[i:i + size] for i in range(0, len(specs), size)]


def iter_results(specs: list, workers: int = 1, scheduler: str | None = None, packages: frozenset | None = None):
    """Yield ``(CaseResult, journal frame or None)`` as cases finish (not necessarily in case order); frames
    come from other processes, made with ``packages`` (e2esim.runner.plaindata.allowed_packages)."""
    if not specs:
        return
    if scheduler:
        check_scheduler_address(scheduler)
    if packages is None:
        from e2esim.runner.plaindata import allowed_packages

        packages = allowed_packages()
    if scheduler:
        remote = _dask(specs, scheduler, packages)
    elif workers > 1:
        remote = _processes(specs, workers, packages)
    else:
        for spec in specs:
            yield run_batch([spec])[0], None
        return
    for data, frame in remote:
        yield pickle.loads(data), frame


def _processes(specs: list, workers: int, packages: frozenset):
    with ProcessPoolExecutor(max_workers=workers, initializer=exit_with_parent) as pool:
        pending = {pool.submit(run_batch_remote, batch, packages) for batch in _batches(specs, workers)}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    yield from future.result()
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


def _dask(specs: list, address: str, packages: frozenset):
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
        workers = max(1, len(client.scheduler_info().get("workers", {})))
        futures = client.map(run_batch_remote, _batches(specs, workers), packages=packages, pure=False)
        try:
            for future in as_completed(futures):
                yield from future.result()
        except BaseException:
            client.cancel(futures)
            raise
    finally:
        client.close()
