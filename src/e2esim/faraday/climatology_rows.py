"""The statistics of the Faraday-rotation climatologies of a block of cases, each case a row.

``FaradayClimatology`` with a case axis (the ``global_climatology`` ionosphere's product for a block of a map sweep)
holds, per case, Omega at each swath position (NaN where the pass cannot see the cell); a one-case climatology (a
site's) is a block of one, its acquisitions one row. The statistics every case needs (the output scalars, the
circular moments of the error model) are computed here for the whole block with the one-case formulas of
``EmpiricalFaraday`` and a leading case axis, cases grouped by how many acquisitions they have (their sample count)
and by their acquisition weights (equal in a map; a case with other weights is a group alone), bit for bit what each
case gets alone: samples Omega_i X_j with the log-normal nodes X_j of the day-to-day TEC variability (Rishbeth &
Mendillo 2001; ``e2esim.ionosphere.variability``), the weighted mean, SD and percentiles and the circular moments
phi_k = E[exp(i k Omega)] (Men et al. 2021, eqs. 9-10).
"""

from __future__ import annotations

import numpy as np

from e2esim.faraday.distribution import PERCENTILES, weighted_percentiles

EVEN_HARMONICS = np.array([2.0, 4.0, 6.0, 8.0])  # the phi_k behind FaradayDistribution.even_quadrature


def row_statistics(omega: np.ndarray, per_acquisition: dict, x: np.ndarray, weight: np.ndarray) -> dict:
    """Per case (row of ``omega``, (B, positions), rad, NaN where not seen): mean, SD and mean |Omega| (rad), the
    acquisition means of ``per_acquisition`` ({name: (B, positions)}: vertical and slant TEC, range delay, B.k), the
    ``PERCENTILES`` of Omega (rad), Re phi_k for k = 2, 4, 6, 8 evaluated together (``even_quadrature``) and phi_2,
    phi_4 each alone (``trig_moments``), with the operations of ``climatology_from_integrals`` and
    ``EmpiricalFaraday``; ``x`` the log-normal nodes, ``weight`` the acquisitions' weights (B, positions)."""
    n_cases = len(omega)
    out = {name: np.full(n_cases, np.nan) for name in ("mean", "sd", "mean_abs", *per_acquisition)}
    out["percentiles"] = np.full((n_cases, len(PERCENTILES)), np.nan)
    out["phi"] = np.full((n_cases, EVEN_HARMONICS.size), np.nan)
    out["phi2"], out["phi4"] = np.full(n_cases, np.nan, complex), np.full(n_cases, np.nan, complex)
    seen = np.isfinite(omega)
    count = seen.sum(-1)
    for n in np.unique(count[count > 0]):
        rows = np.flatnonzero(count == n)
        w_rows = weight[rows][seen[rows]].reshape(rows.size, n)
        shared = bool(np.all(w_rows == w_rows[0]))  # the map's cases: equal weights; else each case alone
        for k, group in enumerate([rows] if shared else [rows[[k]] for k in range(rows.size)]):
            _group(out, group, seen[group], omega, per_acquisition, x, w_rows[k])
    return out


def _group(out: dict, rows, mask, omega, per_acquisition: dict, x: np.ndarray, w_acq: np.ndarray) -> None:
    """``row_statistics`` of the cases ``rows``, which see the same number of acquisitions (``mask``) with the same
    weights ``w_acq``."""
    n = w_acq.size
    weights = np.repeat(w_acq / w_acq.sum(), x.size) / x.size
    w = weights / weights.sum()  # EmpiricalFaraday's normalised weights, the same for every case of the group
    samples = (omega[rows][mask].reshape(rows.size, n)[:, :, None] * x[None, None, :]).reshape(rows.size, -1)
    mean = _row_dot(samples, w)
    out["mean"][rows] = mean
    out["sd"][rows] = np.sqrt(_row_dot((samples - mean[:, None]) ** 2, w))
    out["mean_abs"][rows] = _row_dot(np.abs(samples), w)
    acq = w_acq / w_acq.sum()
    for name, values in per_acquisition.items():
        out[name][rows] = _row_dot(values[rows][mask].reshape(rows.size, n), acq)
    if np.all(w == w[0]):
        out["percentiles"][rows] = _percentiles(np.sort(samples, axis=-1), w)
    else:  # unequal weights sort with their samples: one case
        out["percentiles"][rows] = weighted_percentiles(samples[0], w, PERCENTILES)
    # circular moments as EmpiricalFaraday.circular_moment: k = 2, 4, 6, 8 together; k = 2 and 4 alone
    wc = w.astype(complex)
    out["phi"][rows] = (np.exp(1j * EVEN_HARMONICS[:, None] * samples[:, None, :]) @ wc).real
    for k in (2, 4):
        out[f"phi{k}"][rows] = _row_dot(np.exp(1j * np.asarray(float(k))[..., None] * samples), wc)


def _row_dot(a: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``np.dot(w, row)`` of every row of ``a`` (G, m), bit for bit: a stack of (1, m) x (m, 1) products is
    reduced as the one-case dot is, where ``a @ w`` need not be."""
    return np.matmul(a[:, None, :], w[None, :, None])[:, 0, 0]


def _percentiles(sorted_samples: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``weighted_percentiles`` of every row of ``sorted_samples`` (G, m) with the same weights ``w`` (m,) for
    every row: the inverse of the weighted empirical CDF, linear between the mid-points of the probability
    masses, with ``numpy.interp``'s arithmetic (its ends, its exact nodes, its slope)."""
    w = w / w.sum()
    cdf = np.cumsum(w) - w / 2
    out = np.empty((len(sorted_samples), len(PERCENTILES)))
    for k, p in enumerate(PERCENTILES):
        q = p / 100.0
        j = int(np.searchsorted(cdf, q, side="right")) - 1
        if j < 0:
            out[:, k] = sorted_samples[:, 0]
        elif j >= cdf.size - 1:
            out[:, k] = sorted_samples[:, -1]
        elif cdf[j] == q:
            out[:, k] = sorted_samples[:, j]
        else:
            slope = (sorted_samples[:, j + 1] - sorted_samples[:, j]) / (cdf[j + 1] - cdf[j])
            out[:, k] = slope * (q - cdf[j]) + sorted_samples[:, j]
    return out


__all__ = ["EVEN_HARMONICS", "row_statistics"]
