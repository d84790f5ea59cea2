"""Calibration tables on a coarse grid of their own (NISAR ``nes0``) onto a product's grid, a block of rows at a
time."""

from __future__ import annotations

import numpy as np


def bilinear_rows(gx, gy, values, x):
    """Rows of ``values`` (on gy x gx) at the product's x, for given y: separable linear interpolation, held
    constant beyond the grid's edges (np.interp)."""
    ox, oy = np.argsort(gx), np.argsort(gy)
    gx, gy, values = gx[ox], gy[oy], values[np.ix_(oy, ox)]
    along_x = np.array([np.interp(x, gx, row) for row in values])  # (len(gy), len(x))

    def at(y):
        if gy.size == 1:
            return np.broadcast_to(along_x[0], (np.size(y), x.size)).copy()
        pos = np.interp(y, gy, np.arange(gy.size, dtype=np.float64))
        i0 = np.clip(np.floor(pos).astype(int), 0, gy.size - 2)
        w = (pos - i0)[:, None]
        return (1 - w) * along_x[i0] + w * along_x[i0 + 1]

    return at
