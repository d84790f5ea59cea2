"""Where a requirement starts to fail as one error level grows: the root finding behind the level margins, the
trade-off curves and their axis crossings (``e2esim.requirements.tradeoff``, ``e2esim.requirements.margins``).

``first_failing_level`` brackets the first sign change of a violation function on a log-spaced scan and refines it
by the Illinois variant of regula falsi, element-wise; ``first_failing_levels`` does it for the sides of a bound at
once, the scan's moments evaluated once for all of them (each side's limit bit for bit its own search's).
"""

from __future__ import annotations

import math

import numpy as np

LEVEL_SEARCH_RANGE = (1e-12, 1.0)  # variances searched for a limit (-120 dB to 0 dB)
_SCAN_POINTS = 25  # log-spaced bracketing grid over LEVEL_SEARCH_RANGE (2 per decade)
_MAX_ITERATIONS = 100  # Illinois steps; typically 8-15 reach the tolerance
_LOG_TOLERANCE = 4e-10  # bracket width in log10(V): relative precision ~1e-9 in V


def scan_levels(shape=(), search_range=LEVEL_SEARCH_RANGE) -> np.ndarray:
    """The levels of ``first_failing_level``'s scan: shape ``shape + (25,)``, log-spaced over ``search_range``."""
    lo, hi = search_range
    grid = np.linspace(np.log10(lo), np.log10(hi), _SCAN_POINTS)
    return np.broadcast_to(10.0**grid, tuple(shape) + grid.shape)


def first_failing_levels(bounds, levels_of, shape=(), bisect: bool = False) -> list:
    """``first_failing_level`` of each bound's violation at the levels ``levels_of(v)`` (a dict of the error model's
    levels for an array v of shape ``shape + (k,)``), one per bound, each the limit its own search finds, bit for bit.

    Bounds that ask the same moments (the sides of a requirement: ``moments_source``) share the scan's evaluation,
    the largest of the search. Where each search asks more than one level at a time (``shape`` not a single element:
    a curve's points, a block's cases) their refinements are one search over ``shape + (bounds,)``, every step's
    levels of all bounds asked in one evaluation: the moments are element-wise, the same numbers whatever else is
    asked with them (a lone element is left alone: its numbers may come from another order of summation)."""
    def violation(bound):
        return lambda v: bound.violation_at(**levels_of(v))

    shape = tuple(shape)
    if bisect or len(bounds) < 2 or any(b.moments_source is not bounds[0].moments_source for b in bounds):
        return [first_failing_level(violation(b), shape, bisect=bisect) for b in bounds]
    moments = bounds[0].moments_at(**levels_of(scan_levels(shape)))
    scans = [b.violation_of(moments) for b in bounds]
    if math.prod(shape) < 2:
        return [first_failing_level(violation(b), shape, scan_values=scan) for b, scan in zip(bounds, scans)]

    def together(v):  # v: shape + (bounds, k) -> every bound's violation at its own levels, one evaluation
        flat = bounds[0].moments_at(**levels_of(v.reshape(shape + (-1,))))
        return np.stack([b.violation_of(flat).reshape(v.shape)[..., i, :] for i, b in enumerate(bounds)], axis=-2)

    limits = first_failing_level(together, shape + (len(bounds),), scan_values=np.stack(scans, axis=-2))
    return [limits[..., i] for i in range(len(bounds))]


def first_failing_level(violation, shape=(), search_range=LEVEL_SEARCH_RANGE, bisect: bool = False,
                        scan_values=None) -> np.ndarray:
    """Smallest level V in ``search_range`` at which ``violation(V) > 0``, element-wise.

    violation : vectorised function of an array of levels of shape ``shape + (k,)`` returning the
        same shape. Returns shape ``shape``: NaN where the requirement already fails at the lowest level,
        +inf where it still holds at the highest.
    scan_values : the violation at ``scan_levels(shape, search_range)`` where the caller has it (shared by the sides
        of a bound: ``first_failing_levels``), else None.
    bisect : find the scan's bracket by bisecting the grid (``_bisected_scan``: some five evaluations of one
        level each instead of one of all 25), for a level whose every value costs a computation of its own
        (``ErrorModel.costly_levels``); the same bracket, and so the same limit, where the violation changes
        sign once.

    A log-spaced scan brackets the first sign change (two points per decade), then the Illinois variant of
    regula falsi, on log10 V and vectorised over all elements, refines it to a relative precision of about
    1e-9 in V in some ten evaluations. A second pass/fail change inside one bracket (half a decade) would
    be missed; the violation functions here change sign once.
    """
    lo, hi = search_range
    grid = np.linspace(np.log10(lo), np.log10(hi), _SCAN_POINTS)
    if bisect:
        first, fa, fb, fails_first, fails_any = _bisected_scan(violation, tuple(shape), grid)
    else:
        values = violation(scan_levels(shape, search_range)) if scan_values is None else scan_values
        fails = values > 0
        first = np.argmax(fails, axis=-1)
        below = np.maximum(first - 1, 0)
        fa = np.take_along_axis(values, below[..., None], -1)[..., 0]
        fb = np.take_along_axis(values, first[..., None], -1)[..., 0]
        fails_first, fails_any = fails[..., 0], fails.any(axis=-1)
    result = np.full(shape, np.inf)
    result[fails_first] = np.nan
    todo = fails_any & ~fails_first
    if not np.any(todo):
        return result
    below = np.maximum(first - 1, 0)
    a, b = grid[below], grid[first]
    fa, fb = np.where(todo, fa, -1.0), np.where(todo, fb, 1.0)  # harmless brackets where nothing to do
    b = np.where(fa == 0, a, b)  # the lower end is the root itself
    last = np.zeros(shape, dtype=int)  # +1: b moved last step, -1: a moved last step
    active = todo.copy()
    for _ in range(_MAX_ITERATIONS):
        with np.errstate(invalid="ignore", divide="ignore"):
            c = np.where(b > a, (a * fb - b * fa) / (fb - fa), a)
        fc = violation((10.0**c)[..., None])[..., 0]
        fail = fc > 0
        # an element that has converged keeps its bracket: each element gets the same iterations whether it
        # is solved alone or with others (a case in a block of sweep cases, a point of a curve)
        fa = np.where(active & fail & (last == 1), 0.5 * fa, fa)  # Illinois: halve the stale end's value
        fb = np.where(active & ~fail & (last == -1), 0.5 * fb, fb)
        a, fa = np.where(active & ~fail, c, a), np.where(active & ~fail, fc, fa)
        b, fb = np.where(active & fail, c, b), np.where(active & fail, fc, fb)
        b = np.where(active & (fc == 0), c, b)  # landed on the root
        last = np.where(active, np.where(fail, 1, -1), last)
        active &= ~(b - a < _LOG_TOLERANCE)
        if not np.any(active):
            break
    result[todo] = (10.0 ** (0.5 * (a + b)))[todo]
    return result


def _bisected_scan(violation, shape: tuple, grid: np.ndarray) -> tuple:
    """The scan of ``first_failing_level`` by bisection of its grid: (index of the first failing grid point (0
    where none is, or the first is), the violation at the point below it and at it, whether the first point fails,
    whether any does), element-wise. The ends first: NaN's and +inf's cases as the full scan finds them where the
    violation changes sign once; between a passing and a failing point, the midpoint's sign halves the bracket
    until its ends are neighbours. Each evaluation is at one level per element, at the grid's own values."""
    def at(index):
        return violation((10.0 ** grid[index])[..., None])[..., 0]

    low, high = np.zeros(shape, dtype=int), np.full(shape, grid.size - 1)
    f_low, f_high = at(low), at(high)
    fails_first, fails_any = f_low > 0, (f_low > 0) | (f_high > 0)
    open_ = ~fails_first & fails_any
    while np.any(open_ & (high - low > 1)):
        mid = np.where(open_ & (high - low > 1), (low + high) // 2, high)
        f_mid = at(mid)
        fail = f_mid > 0
        moved = open_ & (mid != high)
        high, f_high = np.where(moved & fail, mid, high), np.where(moved & fail, f_mid, f_high)
        low, f_low = np.where(moved & ~fail, mid, low), np.where(moved & ~fail, f_mid, f_low)
    first = np.where(open_, high, 0)
    return first, f_low, f_high, fails_first, fails_any
