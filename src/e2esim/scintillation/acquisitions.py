"""The screen every acquisition of a site sees, and the azimuth-response statistics over them.

For each acquisition of the ``geometry`` product (``e2esim.orbit.acquisition.AcquisitionGeometry``) the climatology
gives C_kL at the ionospheric pierce point (its geomagnetic latitude), the acquisition's local time, day of year and
the solar activity (``climatology.log10_ckl``); the aperture follows from its incidence (``aperture.biomass_aperture``)
and the weak-scatter theory (``irf_analytic``) gives the statistics of its response, vectorised over the
acquisitions. A site's statistics are those of the mixture over its acquisitions with the geometry's probability
weights (a random acquisition): ``mixture_quantiles`` (docs/theory/scintillation.md, eq. S17).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import erf, gammainc

from e2esim.orbit.frames import EARTH_MEAN_RADIUS
from e2esim.scintillation.aperture import biomass_aperture, two_way_structure
from e2esim.scintillation.climatology import geomagnetic_latitude, log10_ckl
from e2esim.scintillation.defocus import broadening
from e2esim.scintillation.irf_analytic import ISLR_UNIFORM_DB, analytic_irf, gamma_parameters
from e2esim.scintillation.screen import check_screen, spectral_tail

_DB = 10.0 / math.log(10.0)


@dataclass(frozen=True)
class ScreenSettings:
    """The screen's parameters besides its strength (BIOMASS preset by default; docs/theory/scintillation.md,
    Section 3). sunspot_number : 12-month sunspot number R. percentile : of the day-to-day spread of C_kL.
    c_kl : a fixed strength (SI) instead of the climatology, or None. frequency_hz, azimuth_resolution_m : the SAR."""

    sunspot_number: float = 150.0
    percentile: float = 50.0
    spectral_index: float = 2.67
    c_kl: float | None = None
    outer_scale_m: float = 10e3
    height_m: float = 350e3
    drift_m_s: float = 0.0
    frequency_hz: float = 435e6
    azimuth_resolution_m: float = 8.3


@dataclass(frozen=True)
class AcquisitionScreens:
    """Per acquisition (arrays (n,)): weight, geomagnetic latitude (rad), log10 C_kL, zenith angle at the screen
    (rad), and the weak-scatter statistics: gamma law (k, theta) of the residual phase Y, SD of the shift and of
    the quadratic coefficient (``irf_analytic``), the mean-IRF peak loss (dB), ``weak``; with the aperture's
    scan length (m) and the pierce points' screen positions for the Faraday-rotation window (``faraday_window``)."""

    weight: np.ndarray
    magnetic_latitude: np.ndarray
    log10_ckl: np.ndarray
    zenith: np.ndarray
    shape: np.ndarray
    scale: np.ndarray
    shift_sd_cells: np.ndarray
    quadratic_sd_rad: np.ndarray
    mean_irf_peak_loss_db: np.ndarray
    weak: np.ndarray
    scan_length_m: np.ndarray
    spectral_index: float = 2.67
    outer_scale_m: float = 10e3

    def halo_share(self, cell_cells: float) -> np.ndarray:
        """q of eq. S19 per acquisition: the share of the halo energy that leaves a cell ``cell_cells`` resolution
        cells long, averaged over the target's position in the cell: E[min(|x| / X_0, 1)] with
        P(|x| > t) = T(2 pi t / L_scan) / T(2 pi 2 / L_scan) for t >= 2 (T the spectral tail, ``screen``; the
        residual after piston and tilt lives beyond 2 cycles per aperture), 1 below."""
        x0 = float(cell_cells)
        if x0 <= 2.0:
            return np.full(self.scan_length_m.shape, 1.0)
        nodes, weights = np.polynomial.legendre.leggauss(32)
        t = 2.0 + (x0 - 2.0) * 0.5 * (nodes + 1.0)
        scan = self.scan_length_m[..., None]
        base = spectral_tail(4.0 * math.pi / scan, self.spectral_index, self.outer_scale_m)
        survival = spectral_tail(2.0 * math.pi * t / scan, self.spectral_index, self.outer_scale_m) / base
        return (2.0 + (x0 - 2.0) * 0.5 * np.sum(weights * survival, axis=-1)) / x0


def day_of_year(time_utc) -> np.ndarray:
    """Day of the year (1 = 1 January) of datetime64 instants."""
    t = np.asarray(time_utc, dtype="datetime64[s]")
    return (t.astype("datetime64[D]") - t.astype("datetime64[Y]")).astype(int) + 1.0


def acquisition_screens(geometry, settings: ScreenSettings, site_lat=None, site_lon=None) -> AcquisitionScreens:
    """The screens of ``geometry``'s acquisitions (module docstring). ``site_lat``, ``site_lon`` (rad): put the
    irregularities over another site (a calibration site) seen with the same passes; default the pierce points."""
    orbit_height = geometry.orbit.radius_m - EARTH_MEAN_RADIUS
    check_screen(0.0 if settings.c_kl is None else settings.c_kl, settings.spectral_index, settings.outer_scale_m,
                 settings.height_m, orbit_height)
    if site_lat is None:
        mag = geomagnetic_latitude(np.asarray(geometry.pierce_lat), np.asarray(geometry.pierce_lon))
    else:
        mag = np.full(np.shape(geometry.incidence), float(geomagnetic_latitude(site_lat, site_lon)))
    logc = log10_ckl(mag, geometry.local_time_h, day_of_year(geometry.time_utc), settings.sunspot_number,
                     settings.percentile)
    if settings.c_kl is not None:
        logc = np.full_like(logc, math.log10(settings.c_kl) if settings.c_kl > 0 else -np.inf)
    aperture = biomass_aperture(np.asarray(geometry.incidence, dtype=float), orbit_height, settings.frequency_hz,
                                settings.azimuth_resolution_m, settings.height_m, settings.drift_m_s)
    stats = analytic_irf(lambda lag: two_way_structure(lag, aperture, 10.0 ** logc, settings.spectral_index,
                                                       settings.outer_scale_m), quantiles=False)
    k, theta = gamma_parameters(stats["residual_phase_mean"], stats["residual_phase_var"])
    weight = np.asarray(geometry.weight, dtype=float)  # (n,), or (sites, n) stacked (``stacked``)
    weight = weight / weight.sum(axis=-1, keepdims=True)
    return AcquisitionScreens(weight, mag, logc, np.asarray(aperture.zenith_rad), k, theta,
                              stats["shift_sd_cells"], stats["quadratic_sd_rad"], stats["mean_irf_peak_loss_db"],
                              stats["weak"], np.asarray(aperture.scan_length_m), settings.spectral_index,
                              settings.outer_scale_m)


def _bisect(cdf, prob, high, steps: int = 60) -> float:
    lo, hi = 0.0, high
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if cdf(mid) < prob else (lo, mid)
    return 0.5 * (lo + hi)


def mixture_quantiles(screens: AcquisitionScreens, prob: float) -> dict:
    """Quantiles over acquisitions and realisations (eq. S17): the mixture CDFs sum_i w_i F_i of the residual phase
    (gamma), |shift| and |quadratic coefficient| (half-normal) inverted by bisection; peak loss (dB), width ratio,
    |shift| (cells) and ISLR (dB) follow through their monotone maps (``irf_analytic``)."""
    w, k, theta = screens.weight, screens.shape, screens.scale

    def cdf_y(y):
        return float(np.sum(w * np.where(theta > 0.0, gammainc(k, y / np.where(theta > 0.0, theta, 1.0)), 1.0)))

    def half_normal(sd):
        return lambda x: float(np.sum(w * np.where(sd > 0.0, erf(x / (math.sqrt(2.0) * np.where(sd > 0, sd, 1))), 1)))

    y_high = float(np.max(k * theta + 12.0 * np.sqrt(k) * theta, initial=0.0)) + 1e-12
    y = _bisect(cdf_y, prob, y_high)
    shift = _bisect(half_normal(screens.shift_sd_cells), prob, 8.0 * float(np.max(screens.shift_sd_cells)) + 1e-12)
    quad_q = _bisect(half_normal(screens.quadratic_sd_rad), prob, 8.0 * float(np.max(screens.quadratic_sd_rad)) + 1e-12)
    return quantile_scalars(y, shift, quad_q)


def quantile_scalars(y: float, shift: float, quad_q: float) -> dict:
    """``mixture_quantiles``' output from the quantiles of Y, |shift| and |quadratic coefficient|."""
    e0 = 10.0 ** (ISLR_UNIFORM_DB / 10.0) / (1.0 + 10.0 ** (ISLR_UNIFORM_DB / 10.0))
    s = math.exp(-y)
    return {"peak_loss_db": _DB * y, "resolution_ratio": float(broadening(quad_q)), "shift_cells": shift,
            "islr_db": 10.0 * math.log10((e0 + (1.0 - e0) * (1.0 - s)) / ((1.0 - e0) * s))}


__all__ = ["AcquisitionScreens", "ScreenSettings", "acquisition_screens", "day_of_year", "mixture_quantiles",
           "quantile_scalars"]
