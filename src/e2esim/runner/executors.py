"""Where sweep cases run: in this process, on local worker processes, or on a dask.distributed cluster.

Every case carries its own seed (``run.case_generator``), so the numbers are the same whichever executor
runs it and in whatever order. Cases are sent in batches to keep the per-task overhead small; results
come back as each batch finishes.
"""

from __future__ import annotations

import math
import pickle
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

from e2esim.errors import UserError

_BATCHES_PER_WORKER = 8  # enough batches for load balancing and frequent journal writes


def run_batch(specs: list) -> list:
    from e2esim.runner.run import run_case

    return [run_case(spec) for spec in specs]


def run_batch_pickled(specs: list) -> list:
    """``run_batch`` for another process: each result pickled once, here, so that the main process can
    journal the bytes as they are and unpickle them once."""
    return [pickle.dumps(r, protocol=pickle.HIGHEST_PROTOCOL) for r in run_batch(specs)]


def _batches(specs: list, workers: int) -> list:
    size = max(1, math.ceil(len(specs) / (workers * _BATCHES_PER_WORKER)))
    return [specs[i:i + size] for i in range(0, len(specs), size)]


def iter_results(specs: list, workers: int = 1, scheduler: str | None = None):
    """Yield ``(CaseResult, pickled bytes or None)`` as cases finish (not necessarily in case order); the
    bytes come from other processes and can be journaled as they are."""
    if not specs:
        return
    if scheduler:
        remote = _dask(specs, scheduler)
    elif workers > 1:
        remote = _processes(specs, workers)
    else:
        for spec in specs:
            yield run_batch([spec])[0], None
        return
    for data in remote:
        yield pickle.loads(data), data


def _processes(specs: list, workers: int):
    with ProcessPoolExecutor(max_workers=workers) as pool:
        pending = {pool.submit(run_batch_pickled, batch) for batch in _batches(specs, workers)}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    yield from future.result()
        except BaseException:
            for future in pending:
                future.cancel()
            raise


def _dask(specs: list, address: str):
    try:
        from distributed import Client, as_completed
    except ImportError as exc:  # pragma: no cover - dask.distributed is a dependency
        raise UserError("--scheduler needs dask.distributed (pip install distributed)") from exc
    try:
        client = Client(address, timeout="20s")
    except (OSError, TimeoutError) as exc:
        raise UserError(f"cannot connect to the dask scheduler at {address}: {exc}") from exc
    try:
        workers = max(1, len(client.scheduler_info().get("workers", {})))
        futures = client.map(run_batch_pickled, _batches(specs, workers), pure=False)
        try:
            for future in as_completed(futures):
                yield from future.result()
        except BaseException:
            client.cancel(futures)
            raise
    finally:
        client.close()
