"""The layers of a product's bands of rows, in order, computed in this process or in ``workers`` processes (each
opens the product and runs the scenario once, then evaluates the bands it is handed); at most two bands per
worker are in flight, so that memory does not grow with the grid when the writer is slower than the workers. A
band is read at once and evaluated block by block (``e2esim.products_io.uncertainty.block_rows``).

This process (while it evaluates a band) and each worker use one BLAS thread: the processes already share the
cores, and OpenBLAS threads waiting on each other for the small matrix products of the model cost more CPU time
than they save (a (65,536 x 5) by (5 x 5) product: 10 ms of CPU with its threads, 0.7 ms with one). The numbers are
the same bit for bit: each row of a product is computed by the same kernel however the rows are split among
threads (checked on the products of the tests and the benchmark's)."""

from __future__ import annotations

import ctypes
import dataclasses
from collections import deque
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager

import numpy as np

from e2esim.products_io.assumptions import load_assumptions
from e2esim.products_io.pixel_model import pixel_moments

_WORKER: dict = {}


def block_layers(open_product, product, scenario, pixels, assumptions, bands, block_rows: int, workers: int = 1):
    """Yield (rows, layers) for each band of ``bands`` in order."""
    if workers <= 1:
        for rows in bands:
            with one_blas_thread():
                layers = band_layers(pixels, assumptions, rows, block_rows)
            yield rows, layers
        return
    with ProcessPoolExecutor(max_workers=workers, initializer=_start, initargs=(open_product, product, scenario,
                                                                                  pixels.mission)) as pool:
        pending: deque = deque()
        for rows in bands:
            pending.append((rows, pool.submit(_layers, rows, block_rows)))
            if len(pending) >= 2 * workers:
                done_rows, future = pending.popleft()
                yield done_rows, future.result()
        while pending:
            done_rows, future = pending.popleft()
            yield done_rows, future.result()


def band_layers(pixels, assumptions, rows: slice, block_rows: int) -> dict:
    """The layers of the band ``rows``: read once, evaluated in blocks of ``block_rows`` rows from its start."""
    band = pixels.read(rows)
    n = rows.stop - rows.start
    out: dict = {}
    for start in range(0, n, block_rows):
        part = slice(start, min(start + block_rows, n))
        layers = pixel_moments(_part(band, part), pixels, assumptions)
        for name, values in layers.items():
            if name not in out:
                out[name] = np.empty((n, *values.shape[1:]), dtype=values.dtype)
            out[name][part] = values
    return out


def _part(band, part: slice):
    """Rows ``part`` (relative) of a ``PixelBlock``: views of its arrays."""
    def cut(x):
        return None if x is None else x[part]

    return dataclasses.replace(
        band, rows=slice(band.rows.start + part.start, band.rows.start + part.stop), valid=band.valid[part],
        noise_power=band.noise_power[part], sigma=None if band.sigma is None else tuple(cut(s) for s in band.sigma),
        hhvv=cut(band.hhvv), looks=cut(band.looks), faraday_mean=cut(band.faraday_mean),
        faraday_sd=cut(band.faraday_sd), crosstalk_corrected=cut(band.crosstalk_corrected))


SETTERS = (("scipy_openblas_set_num_threads64_", "scipy_openblas_get_num_threads64_"),
           ("scipy_openblas_set_num_threads", "scipy_openblas_get_num_threads"),
           ("openblas_set_num_threads64_", "openblas_get_num_threads64_"),
           ("openblas_set_num_threads", "openblas_get_num_threads"))


def _blas_threads() -> list:
    """(set, get) of the thread count of every OpenBLAS this process has loaded (numpy's and scipy's wheels bundle
    one each), found through /proc/self/maps (Linux; elsewhere none: nothing is changed)."""
    try:
        with open("/proc/self/maps") as maps:
            paths = sorted({line.split()[-1] for line in maps if "openblas" in line.split()[-1]})
    except OSError:
        return []
    found = []
    for path in paths:
        library = ctypes.CDLL(path)
        for set_name, get_name in SETTERS:
            if hasattr(library, set_name) and hasattr(library, get_name):
                found.append((getattr(library, set_name), getattr(library, get_name)))
                break
    return found


@contextmanager
def one_blas_thread():
    """One BLAS thread while the pixels are evaluated, the count restored afterwards (module docstring)."""
    threads = _blas_threads()
    saved = [get() for _, get in threads]
    for set_threads, _ in threads:
        set_threads(1)
    try:
        yield
    finally:
        for (set_threads, _), count in zip(threads, saved):
            set_threads(count)


def _start(open_product, product, scenario, mission) -> None:
    pixels = open_product(product)
    _WORKER.update(pixels=pixels, assumptions=load_assumptions(scenario, mission))
    for set_threads, _ in _blas_threads():  # for the worker's life
        set_threads(1)


def _layers(rows: slice, block_rows: int) -> dict:
    layers = band_layers(_WORKER["pixels"], _WORKER["assumptions"], rows, block_rows)
    # float32 as written (the verdict stays uint8): half the bytes back to the writer
    return {k: v if v.dtype == np.uint8 else v.astype(np.float32) for k, v in layers.items()}
