"""The weak-scatter statistics of the azimuth response through a phase screen, vectorised over cases.

For a Gaussian two-way phase error psi along the normalised aperture with structure function D_2 (``aperture``),
on n aperture samples u_i:

* the **mean IRF** at the undistorted peak (Belcher & Rogers 2009, eq. 17, discretised; exact for any strength):
  E|h(0)|^2 / |h_0(0)|^2 = (1/n^2) sum_ij exp(-D_2(u_i - u_j) / 2)                        (eq. S11)
* the **azimuth shift**: the least-squares tilt b = c^T psi, c = u / sum(u^2), moves the peak by x = -b / (2 pi)
  resolution cells (shift theorem); b is Gaussian with Var[b] = -c^T D_2 c / 2 (c sums to 0)           (eq. S12)
* the **peak loss**: after tilt and piston, the residual phase variance Y = psi^T P psi / n (P the projector off
  span(1, u)) gives the peak ratio exp(-Y) (the Strehl-Marechal law of the weak-scatter regime; Born & Wolf,
  Principles of Optics, Section 9.1); Y is a Gaussian quadratic form with E[Y] = -tr(P D_2) / (2 n) and
  Var[Y] = tr((P D_2)^2) / (2 n^2) (Mathai & Provost 1992, Thm 3.2b.2), taken as gamma distributed with
  these moments (Satterthwaite)                                                                     (eq. S13)
* the **broadening**: the quadratic coefficient a = q^T psi / q^T q, q = u^2 - mean(u^2), Gaussian with
  Var[a] = -q^T D_2 q / (2 (q^T q)^2), through the defocus width of ``defocus``                      (eq. S14)
* the **ISLR**: a fraction 1 - exp(-Y) of the energy leaves the coherent response as a halo outside the main lobe,
  so ISLR = (e_0 + (1 - e_0)(1 - s)) / ((1 - e_0) s), s = exp(-Y), e_0 the undistorted sidelobe fraction  (eq. S15)

Quantiles are exact maps of those of Y, |b| and |a| (monotone functions). The weak-scatter forms hold while the
residual phase is small (E[Y] < 0.3 rad^2, ``WEAK_LIMIT``); ``weak`` says where. PSLR has no weak-scatter form here
(Monte Carlo only).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from scipy.special import gammaincinv

from e2esim.scintillation.aperture import aperture_grid
from e2esim.scintillation.defocus import broadening

WEAK_LIMIT = 0.3  # rad^2 of residual two-way phase: the Marechal law is within about 5 % of the peak below it
ISLR_UNIFORM_DB = -9.68  # undistorted ISLR of the uniform aperture (main lobe: one cell either side of the peak)
_DB = 10.0 / math.log(10.0)
_HALF_NORMAL = {0.5: 0.6744897501960817, 0.9: 1.6448536269514722}  # quantiles of |N(0, 1)|


def _matrices(n: int):
    u = aperture_grid(n)
    basis = np.stack([np.ones(n), u])
    projector = np.eye(n) - basis.T @ np.linalg.solve(basis @ basis.T, basis)
    tilt = u / np.sum(u * u)
    q = u * u - np.mean(u * u)
    return u, projector, tilt, q


CHUNK_CASES = 32
"""Cases whose (n, n) matrices are built and multiplied together: 32 x 64 x 64 doubles (1 MiB per array) stay in a
core's L2 cache, where chunks of 256 (8 MiB per array) went through the L3 cache or memory several times (about
1.9 times slower, measured). Each case's numbers are the same, bit for bit, for any chunk (the matrix products and
reductions run case by case)."""


def analytic_irf(structure, n: int = 64, quantiles: bool = True) -> dict:
    """Weak-scatter IRF statistics (module docstring) for the structure function ``structure(lag_u)`` (its case
    axes lead, ``two_way_structure``): arrays over the cases. Keys: ``mean_irf_peak_loss_db``, ``residual_phase_
    mean``, ``residual_phase_var`` (Y), ``shift_sd_cells``, ``quadratic_sd_rad``, and, with ``quantiles``, the
    median and 90th percentile (``_median``, ``_p90``) of ``peak_loss_db``, ``resolution_ratio``, ``shift_cells``
    and ``islr_db``, with ``weak`` (bool). The matrices are built ``CHUNK_CASES`` cases at a time."""
    _, projector, tilt, q = _matrices(n)
    lags = np.abs(np.arange(n)[:, None] - np.arange(n)[None, :])
    on_lags = np.asarray(structure(np.arange(n) / n), dtype=float)
    case_shape = on_lags.shape[:-1]
    rows = on_lags.reshape(-1, n)
    moments = np.empty((5, rows.shape[0]))
    work = _Work(n)
    for start, stop in _chunks(rows.shape[0]):
        moments[:, start:stop] = _toeplitz_moments(rows[start:stop], lags, projector, tilt, q, work)
    mean_y, var_y, var_b, var_a, mean_irf = (m.reshape(case_shape) for m in moments)
    shift_sd = np.sqrt(np.clip(var_b, 0.0, None)) / (2.0 * math.pi)
    quad_sd = np.sqrt(np.clip(var_a, 0.0, None))
    out = {
        "mean_irf_peak_loss_db": -_DB * np.log(mean_irf),
        "residual_phase_mean": mean_y,
        "residual_phase_var": var_y,
        "shift_sd_cells": shift_sd,
        "quadratic_sd_rad": quad_sd,
        "weak": mean_y < WEAK_LIMIT,
    }
    e0 = 10.0 ** (ISLR_UNIFORM_DB / 10.0) / (1.0 + 10.0 ** (ISLR_UNIFORM_DB / 10.0))
    for tag, prob in (("median", 0.5), ("p90", 0.9)) if quantiles else ():
        y = residual_quantile(mean_y, var_y, prob)
        s = np.exp(-y)
        out[f"peak_loss_db_{tag}"] = _DB * y
        out[f"resolution_ratio_{tag}"] = broadening(_HALF_NORMAL[prob] * quad_sd)
        out[f"shift_cells_{tag}"] = _HALF_NORMAL[prob] * shift_sd
        out[f"islr_db_{tag}"] = 10.0 * np.log10((e0 + (1.0 - e0) * (1.0 - s)) / ((1.0 - e0) * s))
    return out


def _chunks(total: int) -> list:
    """(start, stop) of ``CHUNK_CASES`` cases, never a chunk of one case among several: numpy reduces the mean IRF
    of a single (1, n, n) matrix in another order than that of a stack (the last bits differ)."""
    stops = list(range(CHUNK_CASES, total, CHUNK_CASES))
    if stops and total - stops[-1] == 1:
        stops.pop()
    bounds = [0, *stops, total]
    return list(itertools.pairwise(bounds))


class _Work:
    """The (n, n) matrices of a chunk of cases, allocated once for the chunks of one size (a block's chunks are all
    ``CHUNK_CASES`` but the last): fresh arrays each chunk cost page faults, about as much as the arithmetic."""

    def __init__(self, n: int):
        self.n, self.cases, self.arrays = n, None, None

    def of(self, cases: int) -> tuple:
        """(d, pd, exp_d) for ``cases`` cases: d and pd (cases, n, n) C-contiguous; exp_d (n, n, cases), the layout
        of the fancy index ``x[..., lags]`` of an (cases, n) array (its case axis innermost)."""
        if self.cases != cases:
            n = self.n
            self.cases, self.arrays = cases, (np.empty((cases, n, n)), np.empty((cases, n, n)),
                                              np.empty((n, n, cases)))
        return self.arrays


def _toeplitz_moments(on_lags, lags, projector, tilt, q, work: _Work | None = None) -> np.ndarray:
    """(E[Y], Var[Y], Var[b], Var[a], mean IRF at the peak) of eqs. S11-S14 for cases (rows of ``on_lags``: D_2 on
    the n distinct lags); ``work``: the arrays to build the matrices in."""
    n = lags.shape[0]
    d, pd, exp_d = (work or _Work(n)).of(on_lags.shape[0])
    np.take(on_lags, lags, axis=-1, out=d, mode="clip")  # Toeplitz: D_2 on the n distinct lags
    np.matmul(projector, d, out=pd)
    mean_y = -np.trace(pd, axis1=-2, axis2=-1) / (2.0 * n)
    var_y = np.einsum("...ij,...ji->...", pd, pd) / (2.0 * n * n)
    var_b = -np.einsum("i,...ij,j->...", tilt, d, tilt) / 2.0
    var_a = -np.einsum("i,...ij,j->...", q, d, q) / (2.0 * np.dot(q, q) ** 2)
    # exp on the n distinct lags, then the matrix (the same elements in the same layout as exp of d: the same
    # mean, bit for bit; tests/test_error_terms_stacked.py). The mean's order of summation follows the layout: the
    # case axis innermost, as the fancy index exp(-D_2 / 2)[..., lags] lays it out
    np.take(np.exp(-0.5 * on_lags).T, lags, axis=0, out=exp_d, mode="clip")
    mean_irf = np.mean(exp_d.transpose(2, 0, 1), axis=(-2, -1))
    return np.stack([mean_y, var_y, var_b, var_a, mean_irf])


def residual_quantile(mean_y, var_y, prob):
    """Quantile of Y, gamma with mean ``mean_y`` and variance ``var_y`` (eq. S13); 0 where Y is 0."""
    mean_y = np.asarray(mean_y, dtype=float)
    safe_var = np.where(var_y > 0.0, var_y, 1.0)
    shape = np.where(var_y > 0.0, mean_y * mean_y / safe_var, 1.0)
    scale = np.where(mean_y > 0.0, safe_var / np.where(mean_y > 0.0, mean_y, 1.0), 0.0)
    return scale * gammaincinv(shape, prob)


def gamma_parameters(mean_y, var_y) -> tuple:
    """(shape k, scale theta) of the gamma law of Y (eq. S13); (1, 0) where Y is 0."""
    mean_y = np.asarray(mean_y, dtype=float)
    var_y = np.asarray(var_y, dtype=float)
    ok = (mean_y > 0.0) & (var_y > 0.0)
    k = np.where(ok, mean_y * mean_y / np.where(ok, var_y, 1.0), 1.0)
    theta = np.where(ok, var_y / np.where(ok, mean_y, 1.0), 0.0)
    return k, theta


__all__ = ["ISLR_UNIFORM_DB", "WEAK_LIMIT", "analytic_irf", "gamma_parameters", "residual_quantile"]
