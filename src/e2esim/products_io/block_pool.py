"""The layers of a product's blocks of rows, in order, computed in this process or in ``workers`` processes (each
opens the product and runs the scenario once, then evaluates the blocks it is handed); at most two blocks per
worker are in flight, so that memory does not grow with the grid when the writer is slower than the workers."""

from __future__ import annotations

from collections import deque
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from e2esim.products_io.assumptions import load_assumptions
from e2esim.products_io.pixel_model import pixel_moments

_WORKER: dict = {}


def block_layers(open_product, product, scenario, pixels, assumptions, blocks, workers: int = 1):
    """Yield (rows, layers) for each block of ``blocks`` in order."""
    if workers <= 1:
        for rows in blocks:
            yield rows, pixel_moments(pixels.read(rows), pixels, assumptions)
        return
    with ProcessPoolExecutor(max_workers=workers, initializer=_start, initargs=(open_product, product, scenario,
                                                                                  pixels.mission)) as pool:
        pending: deque = deque()
        for rows in blocks:
            pending.append((rows, pool.submit(_layers, rows)))
            if len(pending) >= 2 * workers:
                done_rows, future = pending.popleft()
                yield done_rows, future.result()
        while pending:
            done_rows, future = pending.popleft()
            yield done_rows, future.result()


def _start(open_product, product, scenario, mission) -> None:
    pixels = open_product(product)
    _WORKER.update(pixels=pixels, assumptions=load_assumptions(scenario, mission))


def _layers(rows: slice) -> dict:
    pixels = _WORKER["pixels"]
    layers = pixel_moments(pixels.read(rows), pixels, _WORKER["assumptions"])
    # float32 as written (the verdict stays uint8): half the bytes back to the writer
    return {k: v if v.dtype == np.uint8 else v.astype(np.float32) for k, v in layers.items()}
