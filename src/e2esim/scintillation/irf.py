"""Monte Carlo of the azimuth impulse response through a phase screen: 1-D azimuth compression of a point target.

After range compression and range-cell-migration correction, the azimuth compression of a point target is the
matched filter's output, which for a two-way phase error psi(u) along the normalised aperture u in [-1/2, 1/2] is

    h(x) = sum_n w_n exp(i psi(u_n)) exp(2 pi i u_n x)                    (docs/theory/scintillation.md, eq. S8)

(Belcher & Rogers 2009, eq. 12, discretised; x in units of the Rayleigh resolution rho_a; w the azimuth weighting,
uniform here). It is evaluated for all x by a zero-padded FFT. Realisations of psi are drawn exactly from the
screen's structure function: psi(u) - psi(0) is Gaussian with covariance (D_2(u_i) + D_2(u_j) - D_2(u_i - u_j)) / 2
(eq. S9; the piston does not change |h|). Metrics of each realisation (``irf_metrics``): peak loss (peak intensity over
the undistorted peak), 3-dB width over the undistorted one, azimuth shift of the peak (resolution cells), PSLR (the
largest intensity more than one cell from the peak, over the peak) and ISLR (energy more than one cell from the peak
over the energy within it; the null-to-null main lobe of the uniform aperture).
"""

from __future__ import annotations

import numpy as np

from e2esim.scintillation.aperture import aperture_grid

METRICS = ("peak_loss_db", "resolution_ratio", "shift_cells", "pslr_db", "islr_db")
"""Per-realisation metrics of ``irf_metrics``: -10 log10 of the peak ratio (dB, >= 0 is a loss), 3-dB width
ratio, |shift| (resolution cells), PSLR and ISLR (dB)."""


def phase_draws(rng, structure, n: int, realisations: int) -> np.ndarray:
    """(realisations, n) two-way phase errors on ``aperture_grid(n)`` with structure function ``structure(lag_u)``
    (eq. S9): exact Gaussian draws through the eigen-decomposition of their covariance relative to the centre."""
    u = aperture_grid(n)
    d_abs = structure(np.abs(u))
    # the n^2 lags of a regular grid take few distinct values: the structure function (a Bessel function per
    # value) is evaluated once for each, which gives the same matrix bit for bit
    lags, where = np.unique(np.abs(u[:, None] - u[None, :]), return_inverse=True)
    d_lag = structure(lags)[where.reshape(n, n)]
    cov = 0.5 * (d_abs[:, None] + d_abs[None, :] - d_lag)
    return rng.standard_normal((realisations, n)) @ _square_root(cov).T


def _square_root(cov) -> np.ndarray:
    """A factor F with F F^T = cov: Cholesky with a jitter of 1e-12 of the mean variance (ten times faster than an
    eigen-decomposition at this size), the eigen-decomposition where the matrix is singular (a flat screen)."""
    jitter = 1e-12 * max(float(np.trace(cov)) / cov.shape[0], np.finfo(float).tiny)
    try:
        return np.linalg.cholesky(cov + jitter * np.eye(cov.shape[0]))
    except np.linalg.LinAlgError:
        vals, vecs = np.linalg.eigh(cov)
        return vecs * np.sqrt(np.clip(vals, 0.0, None))


def compress(phases, weights=None, oversample: int = 16) -> np.ndarray:
    """|h(x)|^2 of eq. S8 for phase errors (..., n): intensities (..., n * oversample), x = 0 at index
    n * oversample // 2, sample spacing 1 / oversample resolution cells."""
    phases = np.asarray(phases, dtype=float)
    n = phases.shape[-1]
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
    m = n * oversample
    # exp(2 pi i u_n x) = exp(2 pi i n x / n) times a phase of x alone: |h| is the padded inverse DFT
    signal = w * np.exp(1j * phases)
    spectrum = np.fft.ifft(signal, m, axis=-1) * m
    return np.fft.fftshift(np.abs(spectrum) ** 2, axes=-1)


def _crossing(intensity, peak_index, level, step):
    """Fractional index where ``intensity`` first falls below ``level`` walking from ``peak_index`` by ``step``."""
    i = peak_index
    last = intensity.shape[-1] - 1
    while 0 < i < last and intensity[i + step] >= level:
        i += step
    if not 0 < i < last:
        return float(i)
    a, b = intensity[i], intensity[i + step]
    return i + step * (a - level) / (a - b)


def irf_metrics(intensity, oversample: int, ideal_peak: float, ideal_width: float) -> dict:
    """The metrics of ``METRICS`` for each row of ``intensity`` (R, M) from ``compress`` (module docstring)."""
    intensity = np.atleast_2d(intensity)
    rows, m = intensity.shape
    peak_index = np.argmax(intensity, axis=-1)
    peak = intensity[np.arange(rows), peak_index]
    offset = np.arange(m)[None, :] - peak_index[:, None]
    main = np.abs(offset) < oversample  # within one resolution cell of the peak: the null-to-null main lobe
    side_peak = np.where(main, 0.0, intensity).max(axis=-1)
    main_energy = np.where(main, intensity, 0.0).sum(axis=-1)
    side_energy = intensity.sum(axis=-1) - main_energy
    width = np.empty(rows)
    for r in range(rows):
        row, k, half = intensity[r], int(peak_index[r]), 0.5 * peak[r]
        width[r] = (_crossing(row, k, half, 1) - _crossing(row, k, half, -1)) / oversample
    centre = m // 2
    # parabolic interpolation of the peak (the grid is 1 / oversample cells apart)
    left = intensity[np.arange(rows), np.clip(peak_index - 1, 0, m - 1)]
    right = intensity[np.arange(rows), np.clip(peak_index + 1, 0, m - 1)]
    curvature = left - 2.0 * peak + right
    delta = np.where(curvature < 0.0, 0.5 * (left - right) / np.where(curvature < 0.0, curvature, -1.0), 0.0)
    return {
        "peak_loss_db": -10.0 * np.log10(peak / ideal_peak),
        "resolution_ratio": width / ideal_width,
        "shift_cells": np.abs(peak_index + delta - centre) / oversample,
        "pslr_db": 10.0 * np.log10(side_peak / peak),
        "islr_db": 10.0 * np.log10(side_energy / main_energy),
    }


def ideal_response(n: int, oversample: int, weights=None) -> tuple:
    """(peak intensity, 3-dB width in cells) of the undistorted compression."""
    ideal = compress(np.zeros((1, n)), weights, oversample)
    metrics = irf_metrics(ideal, oversample, 1.0, 1.0)
    return float(ideal.max()), float(metrics["resolution_ratio"][0])


def summarise(metrics: dict) -> dict:
    """Median and 90th percentile of every metric over the realisations (``<metric>_median``, ``<metric>_p90``),
    with the sample mean's standard error of the peak loss (``peak_loss_db_mean``, ``peak_loss_db_mean_se``)."""
    out = {}
    for name, values in metrics.items():
        out[f"{name}_median"] = float(np.median(values))
        out[f"{name}_p90"] = float(np.quantile(values, 0.9))
    loss = metrics["peak_loss_db"]
    out["peak_loss_db_mean"] = float(np.mean(loss))
    out["peak_loss_db_mean_se"] = float(np.std(loss, ddof=1) / np.sqrt(loss.size)) if loss.size > 1 else np.nan
    return out


def monte_carlo_irf(rng, structure, realisations: int = 200, n: int = 128, oversample: int = 16) -> dict:
    """IRF statistics over ``realisations`` screen realisations (module docstring): ``summarise`` of the metrics
    and the raw per-realisation arrays under ``"samples"``."""
    phases = phase_draws(rng, structure, n, realisations)
    ideal_peak, ideal_width = ideal_response(n, oversample)
    metrics = irf_metrics(compress(phases, None, oversample), oversample, ideal_peak, ideal_width)
    return {**summarise(metrics), "samples": metrics}


__all__ = ["METRICS", "compress", "ideal_response", "irf_metrics", "monte_carlo_irf", "phase_draws", "summarise"]
