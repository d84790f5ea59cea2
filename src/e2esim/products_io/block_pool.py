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

import dataclasses
from collections import deque
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from e2esim.blas_threads import blas_threads, one_blas_thread
from e2esim.case import KernelMemo
from e2esim.products_io.assumptions import load_assumptions
from e2esim.products_io.pixel_model import pixel_moments

_WORKER: dict = {}


def block_layers(open_product, product, scenario, pixels, assumptions, bands, block_rows: int, workers: int = 1,
                 encode=None):
    """Yield (rows, layers) for each band of ``bands`` in order; with ``encode`` (a picklable function of the
    layers, e.g. their compressed NetCDF chunks) and workers, (rows, layers, encode(layers)), encoded in the
    worker."""
    if workers <= 1:
        memo = KernelMemo()  # this product's pixel models (each worker makes its own: ``_start``)
        for rows in bands:
            with one_blas_thread():
                layers = band_layers(pixels, assumptions, rows, block_rows, memo)
            yield rows, layers
        return
    with ProcessPoolExecutor(max_workers=workers, initializer=_start, initargs=(open_product, product, scenario,
                                                                                  pixels.mission)) as pool:
        pending: deque = deque()
        for rows in bands:
            pending.append((rows, pool.submit(_layers, rows, block_rows, encode)))
            if len(pending) >= 2 * workers:
                done_rows, future = pending.popleft()
                yield done_rows, *future.result()
        while pending:
            done_rows, future = pending.popleft()
            yield done_rows, *future.result()


def band_layers(pixels, assumptions, rows: slice, block_rows: int, memo) -> dict:
    """The layers of the band ``rows``: read once, evaluated in blocks of ``block_rows`` rows from its start, with
    the evaluating process's ``KernelMemo`` ``memo``."""
    band = pixels.read(rows)
    n = rows.stop - rows.start
    out: dict = {}
    for start in range(0, n, block_rows):
        part = slice(start, min(start + block_rows, n))
        layers = pixel_moments(_part(band, part), pixels, assumptions, memo)
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


def _start(open_product, product, scenario, mission) -> None:
    pixels = open_product(product)
    _WORKER.update(pixels=pixels, assumptions=load_assumptions(scenario, mission), memo=KernelMemo())
    for set_threads, _ in blas_threads():  # for the worker's life
        set_threads(1)


def _layers(rows: slice, block_rows: int, encode=None) -> tuple:
    layers = band_layers(_WORKER["pixels"], _WORKER["assumptions"], rows, block_rows, _WORKER["memo"])
    # float32 as written (the verdict stays uint8): half the bytes back to the writer
    layers = {k: v if v.dtype == np.uint8 else v.astype(np.float32) for k, v in layers.items()}
    return (layers,) if encode is None else (layers, encode(layers))
