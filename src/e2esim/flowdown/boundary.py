"""The boundary of the region of two keys where every requirement holds in every case (issue 23, item 4).

For ``points`` values of the first key across its range, the value of the second key at which the smallest margin
over every requirement and case is zero: Brent's method (``e2esim.flowdown.brent``) over all points at once, each
step one run of the engine over the sweep times the points (``Evaluator.grid_margins``). As with the trade-off curve
of Men et al. (2021), Section V-B, which it reproduces for crosstalk and channel imbalance, a point where the second
key meets (or fails) the requirements over its whole range is reported as such.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import UserError
from e2esim.flowdown.brent import brent
from e2esim.flowdown.evaluate import Evaluator
from e2esim.flowdown.keys import bounds_of
from e2esim.flowdown.scan import SCAN, scan_brackets


@dataclass
class BoundaryResult:
    """keys, bounds : the two keys and their search ranges. x : the first key's points; y : the second key's value on
    the boundary at each (NaN where ``state`` is not "met at"); state : per point ("met at", "every value meets it",
    "no value meets it"); side : which values of the second key meet ("at most" / "at least"); binding : per point,
    (requirement, case label) of the smallest margin there."""

    keys: tuple
    bounds: tuple
    labels: list
    requirements: list
    x: np.ndarray
    y: np.ndarray
    state: list
    side: list
    binding: list
    worst_case: bool = True
    calls: int = 0
    rows: int = 0


def _worst_of(m: np.ndarray) -> tuple:
    """(smallest margin per point, its flat (requirement, case) index) over (R, n, P) margins (NaN ignored)."""
    flat = np.where(np.isnan(m), np.inf, m).reshape(-1, m.shape[-1])
    where = np.argmin(flat, axis=0)
    return flat[where, np.arange(flat.shape[1])], where


def boundary(loaded, resolved, keys, bounds, points: int) -> BoundaryResult:
    if bounds is not None and len(bounds) != 2:
        raise UserError("--bounds: give one LO HI pair per --for key (two pairs for two keys)")
    ranges = [bounds_of(k, None if bounds is None else bounds[i]) for i, k in enumerate(keys)]
    if not 2 <= points <= 10_000:
        raise UserError(f"--points {points}: expected 2 to 10000 points along the boundary")
    evaluator = Evaluator(loaded, resolved, tuple(keys))
    n = evaluator.n
    x = np.linspace(*ranges[0], points)
    (lo, hi) = ranges[1]
    ys = np.linspace(lo, hi, SCAN)
    grid = np.stack([np.repeat(x, SCAN), np.tile(ys, points)], 1)
    scan = evaluator.grid_margins(grid)  # (R, n, points * SCAN)
    worst, _ = _worst_of(scan)
    state, a, b, f_a, f_b, side_lo, _ = scan_brackets(ys, worst.reshape(points, SCAN))
    if np.all(state == "no effect"):
        raise UserError(f"--for {keys[1].name}: no effect on any requirement in any case along {keys[0].name}")
    todo = np.flatnonzero(state == "met at")

    def f(active, y):
        m = evaluator.grid_margins(np.stack([x[todo[active]], y], 1))
        return _worst_of(m)[0]
    y = np.full(points, np.nan)
    if todo.size:
        y[todo], _ = brent(f, a[todo], b[todo], f_a[todo], f_b[todo], 1e-6 * (hi - lo))
    best = np.argmax(worst.reshape(points, SCAN), axis=1)
    at = np.where(np.isnan(y), ys[best], y)
    _, where = _worst_of(evaluator.grid_margins(np.stack([x, at], 1)))
    binding = [(evaluator.names[w // n], evaluator.labels[w % n]) for w in where]
    side = [("at most" if g else "at least") if s == "met at" else "" for s, g in zip(state, side_lo)]
    return BoundaryResult(tuple(k.name for k in keys), tuple(ranges), evaluator.labels, evaluator.names, x, y,
                          list(state), side, binding, True, evaluator.calls, evaluator.rows)
