"""Batched least-squares engines for the retrieval models: Levenberg-Marquardt for non-linear fits, ordinary
least squares for log-linear ones, and a vectorised bisection for monotone inversions.

Thousands of small data sets (SIMEX and bootstrap replicates) are fitted in one set of numpy operations;
each data set gets a status, so that non-converging fits are counted, never dropped silently.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CONVERGED = 0
"""Fit status: converged (relative reduction of the residuals, relative step or scaled gradient below tolerance)."""
MAX_ITERATIONS = 1
"""Fit status: the iteration limit was reached before convergence."""
NON_FINITE = 2
"""Fit status: the model, its Jacobian or the residuals became non-finite."""
STALLED = 3
"""Fit status: no step reduced the residuals any more (damping exhausted) away from a stationary point."""
BAD_DATA = 4
"""Fit status: the data set cannot be fitted (non-finite values, sigma <= 0 or AGB <= 0 for a log fit,
fewer points than parameters)."""
OUT_OF_DOMAIN = 5
"""Fit status: the least-squares coefficients lie outside the model's domain (e.g. a power-law exponent <= 0), or
the fit stopped on the domain's boundary (``levenberg_marquardt``)."""
FIT_STATUS_NAMES = {CONVERGED: "converged", MAX_ITERATIONS: "max_iterations", NON_FINITE: "non_finite",
                    STALLED: "stalled", BAD_DATA: "bad_data", OUT_OF_DOMAIN: "out_of_domain"}

_STALL_GTOL = 1e-6  # scaled gradient below which a fit whose damping is exhausted counts as converged


@dataclass(frozen=True)
class BatchFit:
    """Fits of many data sets at once.

    params : (B, p) fitted coefficients (the starting values where a fit failed).
    status : (B,) fit status codes (``CONVERGED``, ``MAX_ITERATIONS``, ...).
    ssr : (B,) residual sum of squares in the fit space. iterations : (B,) iterations used.
    """

    params: np.ndarray
    status: np.ndarray
    ssr: np.ndarray
    iterations: np.ndarray

    @property
    def converged(self) -> np.ndarray:
        return self.status == CONVERGED

    @property
    def n_failed(self) -> int:
        return int(np.count_nonzero(self.status != CONVERGED))

    def failure_counts(self) -> dict:
        return {name: int(np.count_nonzero(self.status == code)) for code, name in FIT_STATUS_NAMES.items()
                if code != CONVERGED}


def levenberg_marquardt(fun, jac, y, p0, valid=None, weights=None, bad=None, max_iter: int = 200,
                        ftol: float = 1e-12, xtol: float = 1e-10, gtol: float = 1e-10) -> BatchFit:
    """Levenberg-Marquardt least squares for B independent data sets at once.

    fun(p, idx) -> (b, n) model values and jac(p, idx) -> (b, n, p) Jacobian for the data sets ``idx``
    (an index array into the batch) with coefficients p (b, p). y : (B, n) data. p0 : (B, p) start.
    valid(p) -> (b,) bool: a step leaving the domain is rejected like one that increases the residuals.
    weights : optional (B, n) weights. bad : optional (B,) data sets not to fit (status ``BAD_DATA``).

    Marquardt's scaled damping ``(J^T J + lambda diag(J^T J)) step = J^T r``; lambda shrinks by 10 after
    an accepted step and grows by 10 after a rejected one. Converged (MINPACK-like tests): the relative
    reduction of the residual sum of squares below ``ftol``, the relative step below ``xtol``, or the
    scaled gradient below ``gtol``. Failure modes are reported per data set, never dropped.
    Only the data sets still iterating are evaluated in each pass.
    """
    y = np.asarray(y, dtype=float)
    nb = y.shape[0]
    y2 = y.reshape(nb, -1)
    w = np.ones_like(y2) if weights is None else np.broadcast_to(np.asarray(weights, float).reshape(nb, -1),
                                                                  y2.shape)
    p = np.array(p0, dtype=float, copy=True)
    npar = p.shape[1]
    status = np.full(nb, MAX_ITERATIONS, dtype=np.int8)
    iterations = np.zeros(nb, dtype=np.int32)
    ssr = np.full(nb, np.inf)
    bad = np.zeros(nb, bool) if bad is None else np.asarray(bad, bool).copy()
    bad |= y2.shape[1] <= npar
    status[bad] = BAD_DATA
    all_idx = np.arange(nb)
    start = all_idx[~bad]
    if start.size:
        ok_start = np.ones(start.size, bool) if valid is None else np.asarray(valid(p[start]), bool)
        f0 = fun(p[start], start).reshape(start.size, -1)
        r0 = y2[start] - f0
        s0 = np.sum(w[start] * r0**2, axis=1)
        fine = ok_start & np.isfinite(s0)
        status[start[~fine]] = NON_FINITE
        ssr[start] = s0
        active = start[fine]
    else:
        active = start
    lam = np.full(nb, 1e-3)
    eye = np.eye(npar)
    resid = np.zeros_like(y2)
    if start.size:
        resid[start] = r0
    for it in range(1, max_iter + 1):
        if active.size == 0:
            break
        iterations[active] = it
        pa = p[active]
        ja = jac(pa, active).reshape(active.size, -1, npar)
        ra = resid[active]  # residuals at the current coefficients, kept from the last accepted step
        wa = w[active]
        jtw = np.swapaxes(ja, 1, 2) * wa[:, None, :]
        a = jtw @ ja  # (b, p, p)
        g = np.einsum("bpn,bn->bp", jtw, ra)
        finite = np.all(np.isfinite(a), axis=(1, 2)) & np.all(np.isfinite(g), axis=1)
        diag = np.einsum("bii->bi", a)
        scale = np.where(diag > 0, diag, 1.0)
        gnorm = np.max(np.abs(g) / np.sqrt(scale), axis=1) / np.sqrt(np.maximum(ssr[active], np.finfo(float).tiny))
        at_stationary = finite & (gnorm <= gtol)
        damped = a + lam[active, None, None] * scale[:, :, None] * eye
        try:
            step = np.linalg.solve(damped[finite], g[finite][..., None])[..., 0]
        except np.linalg.LinAlgError:
            step = np.stack([_solve_or_nan(m, v) for m, v in zip(damped[finite], g[finite])])
        full_step = np.full((active.size, npar), np.nan)
        full_step[finite] = step
        pn = pa + full_step
        ok = np.all(np.isfinite(pn), axis=1)
        if valid is not None:
            ok &= np.asarray(valid(np.where(ok[:, None], pn, pa)), bool)
        sn = np.full(active.size, np.inf)
        rn = np.zeros((active.size, y2.shape[1]))
        if np.any(ok):
            idx_ok = active[ok]
            rn[ok] = y2[idx_ok] - fun(pn[ok], idx_ok).reshape(idx_ok.size, -1)
            sn[ok] = np.sum(w[idx_ok] * rn[ok] ** 2, axis=1)
        accept = ok & np.isfinite(sn) & (sn <= ssr[active])
        old = ssr[active]
        rel_red = np.where(accept, (old - sn) / np.maximum(old, np.finfo(float).tiny), np.inf)
        rel_step = np.where(accept, np.linalg.norm(np.nan_to_num(full_step), axis=1)
                            / (np.linalg.norm(pa, axis=1) + xtol), np.inf)
        acc_idx = active[accept]
        p[acc_idx] = pn[accept]
        ssr[acc_idx] = sn[accept]
        resid[acc_idx] = rn[accept]
        lam[acc_idx] = np.maximum(lam[acc_idx] / 10.0, 1e-12)
        lam[active[~accept]] *= 10.0
        done = at_stationary | (accept & ((rel_red <= ftol) | (rel_step <= xtol)))
        status[active[done]] = CONVERGED
        nonfinite = ~finite & ~done
        status[active[nonfinite]] = NON_FINITE
        stalled = ~done & ~nonfinite & (lam[active] > 1e16)
        # Damping exhausted: converged if the point is stationary to working precision, else stalled.
        status[active[stalled]] = np.where(gnorm[stalled] <= _STALL_GTOL, CONVERGED, STALLED)
        active = active[~(done | nonfinite | stalled)]
    if valid is not None:
        converged = np.flatnonzero(status == CONVERGED)
        status[converged[_on_domain_edge(p[converged], valid)]] = OUT_OF_DOMAIN
    return BatchFit(p, status, ssr, iterations)


_EDGE_STEP = 1e-3
"""Relative change of one coefficient that a converged fit must survive inside the domain (``_on_domain_edge``)."""


def _on_domain_edge(p: np.ndarray, valid) -> np.ndarray:
    """(b,) True where a relative change of ``_EDGE_STEP`` in one coefficient leaves the domain: the fit stopped
    against the domain's boundary, where the steps that would lower the residuals further are rejected, so it is
    no least-squares solution (the solution lies outside the domain, e.g. a saturating model's saturation level
    running to its cap on data that show no saturation) and counts as ``OUT_OF_DOMAIN``."""
    edge = np.zeros(p.shape[0], dtype=bool)
    for k in range(p.shape[1]):
        for factor in (1.0 + _EDGE_STEP, 1.0 - _EDGE_STEP):
            moved = p.copy()
            moved[:, k] *= factor
            edge |= ~np.asarray(valid(moved), bool)
    return edge


def _solve_or_nan(matrix, vector):
    try:
        return np.linalg.solve(matrix, vector)
    except np.linalg.LinAlgError:
        return np.full(vector.shape, np.nan)


def ols_batch(design: np.ndarray, y: np.ndarray):
    """Ordinary least squares for B data sets: design (B, n, k), y (B, n[, c]).

    Returns ``(coef (B, k[, c]), ssr (B[, c]), ok (B,))``; ok is False where the design is rank-deficient
    or the data are not finite (those coefficients are NaN, to be counted by the caller).
    """
    design = np.asarray(design, dtype=float)
    y = np.asarray(y, dtype=float)
    squeeze = y.ndim == 2
    y3 = y[..., None] if squeeze else y
    xtx = np.swapaxes(design, 1, 2) @ design
    xty = np.swapaxes(design, 1, 2) @ y3
    finite = np.all(np.isfinite(xtx), axis=(1, 2)) & np.all(np.isfinite(xty), axis=(1, 2))
    cond = np.full(design.shape[0], np.inf)
    if np.any(finite):
        cond[finite] = np.linalg.cond(xtx[finite])
    ok = finite & (cond < 1e12)
    coef = np.full((design.shape[0], design.shape[2], y3.shape[2]), np.nan)
    if np.any(ok):
        coef[ok] = np.linalg.solve(xtx[ok], xty[ok])
    resid = y3 - design @ np.nan_to_num(coef)
    ssr = np.sum(resid**2, axis=1)
    if squeeze:
        return coef[..., 0], ssr[..., 0], ok
    return coef, ssr, ok


def bisect_increasing(func, target, lo, hi, iterations: int = 80, rtol: float = 1e-13):
    """Solve ``func(x) = target`` elementwise for an increasing ``func`` on [lo, hi] (bracketed).

    Vectorised bisection followed by safeguarded secant polishing; lo, hi, target broadcast together.
    """
    target, lo, hi = np.broadcast_arrays(np.asarray(target, float), np.asarray(lo, float), np.asarray(hi, float))
    if target.shape == (1,):
        lo, hi = _bisected_one(func, float(target[0]), float(lo[0]), float(hi[0]), iterations, rtol)
    else:
        lo, hi = lo.copy(), hi.copy()
        for _ in range(iterations):
            mid = 0.5 * (lo + hi)
            above = func(mid) >= target
            hi = np.where(above, mid, hi)
            lo = np.where(above, lo, mid)
            if np.all(hi - lo <= rtol * np.maximum(np.abs(hi), 1.0)):
                break
    flo, fhi = func(lo), func(hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(fhi > flo, lo + (target - flo) * (hi - lo) / (fhi - flo), 0.5 * (lo + hi))
    return np.clip(x, lo, hi)


def _bisected_one(func, target: float, lo: float, hi: float, iterations: int, rtol: float) -> tuple:
    """The bracket (lo, hi) of one element's bisection in ``bisect_increasing``, as arrays of shape (1,): its steps
    on Python floats, which add, halve and compare as numpy's float64 do (IEEE 754), so the same bracket bit for bit
    without a dozen array operations per step (a retrieval map's threshold inverts one value a few hundred times:
    ``e2esim.retrieval.relative_error_map``). ``func`` is still asked with an array of one element, as the arrays'
    loop asks it (numpy's power and exp may round otherwise on a scalar)."""
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if func(np.array([mid]))[0] >= target:
            hi = mid
        else:
            lo = mid
        if hi - lo <= rtol * max(abs(hi), 1.0):
            break
    return np.array([lo]), np.array([hi])
