"""The boundary of the region of two keys where every requirement holds in every case (issue 23, item 4).

For ``points`` values of the first key across its range, the value of the second key at which the smallest margin
over every requirement and case is zero: Brent's method (``e2esim.flowdown.brent``) over all points at once, each
step one run of the engine over the sweep times the points (``Evaluator.grid_margins``). The brackets come from
the scan of the second key's range (``e2esim.flowdown.scan``) by continuation along the first key: every
``COARSE``-th point (and the last) is scanned at all ``SCAN`` values; a point between two scanned points is
evaluated first at the low end and where its neighbours' brackets are (where both neighbours' first sign change
lies between the same two scan values, at those two; else at each met neighbour's two and the scan values next to
them), and keeps the bracket those values show when their first sign change is between two adjacent scan values
(the same bracket the full scan gives unless the margin changes sign twice between two of them below it); every
other point is scanned in full (at the scan values not yet evaluated; a point without a met neighbour at once).
As with the
trade-off curve of Men et al. (2021), Section V-B, which it reproduces for crosstalk and channel imbalance, a point
where the second key meets (or fails) the requirements over its whole range is reported as such.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import UserError
from e2esim.flowdown.brent import brent
from e2esim.flowdown.evaluate import Evaluator
from e2esim.flowdown.keys import bounds_of
from e2esim.flowdown.scan import SCAN, scan_brackets

COARSE = 8
"""Every COARSE-th point of the first key is scanned in full; those between by continuation (module docstring)."""


@dataclass
class BoundaryResult:
    """keys, bounds : the two keys and their search ranges. x : the first key's points; y : the second key's value on
    the boundary at each (NaN where ``state`` is not "met at"); state : per point ("met at", "every value meets it",
    "no value meets it"); side : which values of the second key meet ("at most" / "at least"); binding : per point,
    (requirement, case label) of the smallest margin there; case_margins : (cases, points) each case's smallest
    margin over the requirements there (the binding case's is zero on the boundary; the others' say how much room
    they keep)."""

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
    case_margins: np.ndarray = None


def _worst_of(m: np.ndarray) -> tuple:
    """(smallest margin per point, its flat (requirement, case) index) over (R, n, P) margins (NaN ignored)."""
    flat = np.where(np.isnan(m), np.inf, m).reshape(-1, m.shape[-1])
    where = np.argmin(flat, axis=0)
    return flat[where, np.arange(flat.shape[1])], where


def boundary(loaded, resolved, keys, bounds, points: int, workers: int = 1) -> BoundaryResult:
    if bounds is not None and len(bounds) != 2:
        raise UserError("--bounds: give one LO HI pair per --for key (two pairs for two keys)")
    ranges = [bounds_of(k, None if bounds is None else bounds[i]) for i, k in enumerate(keys)]
    if not 2 <= points <= 10_000:
        raise UserError(f"--points {points}: expected 2 to 10000 points along the boundary")
    engine = Evaluator(loaded, resolved, tuple(keys), workers)
    evaluator = _Recorded(engine)
    n = engine.n
    x = np.linspace(*ranges[0], points)
    (lo, hi) = ranges[1]
    ys = np.linspace(lo, hi, SCAN)
    state, a, b, f_a, f_b, side_lo, best = _brackets(evaluator, x, ys)
    if np.all(state == "no effect"):
        raise UserError(f"--for {keys[1].name}: no effect on any requirement in any case along {keys[0].name}")
    todo = np.flatnonzero(state == "met at")

    def f(active, y):
        m = evaluator.grid_margins(np.stack([x[todo[active]], y], 1))
        return _worst_of(m)[0]
    y = np.full(points, np.nan)
    if todo.size:
        y[todo], _ = brent(f, a[todo], b[todo], f_a[todo], f_b[todo], 1e-6 * (hi - lo))
    at = np.where(np.isnan(y), best, y)  # every one of them evaluated by the scan or the root search
    m_at = evaluator.found(np.stack([x, at], 1))
    _, where = _worst_of(m_at)
    case_margins = np.min(np.where(np.isnan(m_at), np.inf, m_at), axis=0)  # (n, P)
    case_margins[np.isinf(case_margins)] = np.nan
    binding = [(engine.names[w // n], engine.labels[w % n]) for w in where]
    side = [("at most" if g else "at least") if s == "met at" else "" for s, g in zip(state, side_lo)]
    return BoundaryResult(tuple(k.name for k in keys), tuple(ranges), engine.labels, engine.names, x, y,
                          list(state), side, binding, True, engine.calls, engine.rows, case_margins)


class _Recorded:
    """The ``Evaluator``'s margins, with those of every point evaluated kept (every requirement and case), so that
    the margins on the boundary are read from the evaluations that found it rather than evaluated again (a point
    evaluated in another run gives its margins to rounding: a row's residual draws follow its place in the run)."""

    def __init__(self, evaluator: Evaluator):
        self.evaluator = evaluator
        self.kept: dict = {}

    def grid_margins(self, values: np.ndarray) -> np.ndarray:
        values = np.asarray(values, dtype=float).reshape(-1, 2)
        m = self.evaluator.grid_margins(values)
        for p, point in enumerate(values):
            self.kept[tuple(point)] = m[:, :, p]
        return m

    def found(self, values: np.ndarray) -> np.ndarray:
        """(R, n, P) margins at the points ``values`` (P, 2): those kept, else (one not kept) a run at all of them."""
        kept = [self.kept.get(tuple(point)) for point in np.asarray(values, dtype=float)]
        if any(m is None for m in kept):
            return self.grid_margins(values)
        return np.stack(kept, -1)


def _scan(evaluator, x: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """(len(x), SCAN) smallest margins over every requirement and case at each point and scan value: one run."""
    if not len(x):
        return np.zeros((0, len(ys)))
    grid = np.stack([np.repeat(x, len(ys)), np.tile(ys, len(x))], 1)
    return _worst_of(evaluator.grid_margins(grid))[0].reshape(len(x), len(ys))


def _brackets(evaluator, x: np.ndarray, ys: np.ndarray) -> tuple:
    """Per point of ``x``: the state, bracket (a, b), margins there, "at most" side and the best scan value (where
    the smallest margin is largest; NaN for a point bracketed by continuation, which is "met at"), as
    ``scan_brackets`` gives them for the full scan of ``ys`` (module docstring)."""
    points = len(x)
    out = [np.empty(points, dtype=object)] + [np.full(points, np.nan) for _ in range(4)] + [
        np.zeros(points, dtype=bool), np.full(points, np.nan)]

    def put(where, worst):
        state, a, b, f_a, f_b, side_lo, _ = scan_brackets(ys, worst)
        for k, v in enumerate((state, a, b, f_a, f_b, side_lo, ys[np.argmax(worst, axis=1)])):
            out[k][where] = v
    coarse = np.unique(np.r_[np.arange(0, points, COARSE), points - 1])
    worst = _scan(evaluator, x[coarse], ys)
    put(coarse, worst)
    between = np.setdiff1d(np.arange(points), coarse)
    first = np.argmax((worst[:, 1:] >= 0) != (worst[:, :-1] >= 0), axis=1)  # per coarse point
    met = out[0][coarse] == "met at"
    right = np.searchsorted(coarse, between)  # the coarse points on either side: right - 1 and right
    guess = np.zeros((len(between), len(ys)), dtype=bool)  # the scan values evaluated first
    guess[:, 0] = True
    for i, r in enumerate(right):
        ks = {int(first[c]) for c in (r - 1, r) if met[c]}
        if met[r - 1] and met[r] and len(ks) == 1:  # both neighbours bracket alike: that bracket
            guess[i, ks.pop() + np.arange(2)] = True
        for k in ks:  # a neighbour's bracket and the scan values next to it
            guess[i, max(k - 1, 0):k + 3] = True
    guess[~np.any(guess[:, 1:], axis=1)] = True  # no met neighbour: the full scan at once
    values = np.full(guess.shape, np.nan)
    values[guess] = _evaluated(evaluator, x[between], ys, guess)
    done = np.array([_first_change_seen(v, g) for v, g in zip(values, guess)], dtype=bool) & ~guess.all(axis=1)
    rest = ~guess & ~done[:, None]
    values[rest] = _evaluated(evaluator, x[between], ys, rest)  # the rest of the scan where the first did not tell
    if np.any(~done):
        put(between[~done], values[~done])
    kept = between[done]
    if kept.size:
        v = values[done]
        k = np.array([_first_change(row, g) for row, g in zip(v, guess[done])])
        rows = np.arange(kept.size)
        out[0][kept] = "met at"
        out[1][kept], out[2][kept], out[3][kept], out[4][kept] = ys[k], ys[k + 1], v[rows, k], v[rows, k + 1]
        out[5][kept] = v[rows, k] >= 0
    return tuple(out)


def _evaluated(evaluator, x: np.ndarray, ys: np.ndarray, which: np.ndarray) -> np.ndarray:
    """The smallest margins at point ``x[i]`` and scan value ``ys[j]`` for every ``which[i, j]`` (row-major order):
    one run."""
    i, j = np.nonzero(which)
    if not i.size:
        return np.zeros(0)
    return _worst_of(evaluator.grid_margins(np.stack([x[i], ys[j]], 1)))[0]


def _first_change(values: np.ndarray, known: np.ndarray) -> int:
    """The scan index k where, among the known values, the sign first changes between k and the next known one."""
    idx = np.flatnonzero(known)
    good = values[idx] >= 0
    return int(idx[np.argmax(good[1:] != good[:-1])])


def _first_change_seen(values: np.ndarray, known: np.ndarray) -> bool:
    """Whether the known values show where the full scan's first sign change is: they change sign, the first time
    between two adjacent scan values (the full scan agrees unless the margin changes sign twice between known values
    below them), and at least one value is not NaN (a requirement that does not apply: the full scan decides)."""
    idx = np.flatnonzero(known)
    if np.any(np.isnan(values[idx])):
        return False
    good = values[idx] >= 0
    changes = np.flatnonzero(good[1:] != good[:-1])
    return bool(changes.size) and idx[changes[0] + 1] == idx[changes[0]] + 1
