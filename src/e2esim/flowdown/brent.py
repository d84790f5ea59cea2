"""Brent's root finding, vectorised: many independent brackets advanced together, one evaluation per step.

The algorithm is Brent's (1973, "Algorithms for Minimization without Derivatives", ch. 4), in the form of
SciPy's ``brentq`` (inverse quadratic interpolation, secant, bisection when neither makes progress); each bracket
is its own element of arrays, and ``f`` is asked once per iteration for every element not yet converged, so that
one call of the engine serves them all.
"""

from __future__ import annotations

import numpy as np


def brent(f, a: np.ndarray, b: np.ndarray, fa: np.ndarray, fb: np.ndarray, xtol: np.ndarray,
          max_iter: int = 100) -> tuple:
    """Roots of ``f`` in the brackets [a, b] (fa, fb of opposite signs, or one of them 0), element by element.

    f : called as ``f(indices, x)`` with the indices of the elements still running and their new abscissae;
    returns their values. xtol : absolute tolerance per element. Returns (root, iterations of f).
    """
    a, b = np.asarray(a, float).copy(), np.asarray(b, float).copy()
    fa, fb = np.asarray(fa, float).copy(), np.asarray(fb, float).copy()
    xtol = np.broadcast_to(np.asarray(xtol, float), a.shape)
    xpre, xcur, fpre, fcur = a, b, fa, fb
    xblk, fblk = np.zeros_like(a), np.zeros_like(a)
    spre, scur = np.zeros_like(a), np.zeros_like(a)
    root = np.full(a.shape, np.nan)
    running = np.ones(a.shape, dtype=bool)
    calls = 0
    for _ in range(max_iter):
        flip = (fpre != 0) & (fcur != 0) & (np.signbit(fpre) != np.signbit(fcur))
        xblk = np.where(flip, xpre, xblk)
        fblk = np.where(flip, fpre, fblk)
        spre = np.where(flip, xcur - xpre, spre)
        scur = np.where(flip, xcur - xpre, scur)
        swap = np.abs(fblk) < np.abs(fcur)
        xpre, xcur, xblk = np.where(swap, xcur, xpre), np.where(swap, xblk, xcur), np.where(swap, xcur, xblk)
        fpre, fcur, fblk = np.where(swap, fcur, fpre), np.where(swap, fblk, fcur), np.where(swap, fcur, fblk)
        delta = xtol / 2
        sbis = (xblk - xcur) / 2
        done = running & ((fcur == 0) | (np.abs(sbis) < delta))
        root = np.where(done, xcur, root)
        running &= ~done
        if not running.any():
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            interpolate = xpre == xblk
            secant = -fcur * (xcur - xpre) / (fcur - fpre)
            dpre = (fpre - fcur) / (xpre - xcur)
            dblk = (fblk - fcur) / (xblk - xcur)
            quadratic = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            stry = np.where(interpolate, secant, quadratic)
        try_step = (np.abs(spre) > delta) & (np.abs(fcur) < np.abs(fpre))
        good = try_step & np.isfinite(stry) & (2 * np.abs(stry) < np.minimum(np.abs(spre), 3 * np.abs(sbis) - delta))
        spre, scur = np.where(good, scur, sbis), np.where(good, stry, sbis)
        xpre, fpre = xcur, fcur
        step = np.where(np.abs(scur) > delta, scur, np.where(sbis > 0, delta, -delta))
        xcur = xcur + step
        active = np.flatnonzero(running)
        values = np.asarray(f(active, xcur[active]), dtype=float)
        calls += 1
        fcur = fcur.copy()
        fcur[active] = values
    root = np.where(running, xcur, root)  # not converged in max_iter: the last estimate
    return root, calls
