"""The Monte Carlo of the azimuth response over a site's acquisitions: the reference beside the weak-scatter theory.

Each of R realisations picks an acquisition by its probability weight and draws a screen for it (``irf.phase_draws``
with that acquisition's two-way structure function), then compresses (``irf.compress``) and measures
(``irf.irf_metrics``): the statistics are those of the same mixture as ``acquisitions.mixture_quantiles``.
"""

from __future__ import annotations

import numpy as np

from e2esim.orbit.frames import EARTH_MEAN_RADIUS
from e2esim.scintillation.aperture import biomass_aperture, two_way_structure
from e2esim.scintillation.irf import compress, ideal_response, irf_metrics, phase_draws

REALISATIONS = 200  # screen realisations per case (issue 24, Speed: 200 realisations <= 0.5 s)
SAMPLES = 64  # aperture samples: the response is alias-free over +-32 resolution cells
OVERSAMPLE = 16


def mixture_monte_carlo(rng, geometry, settings, screens, realisations: int = REALISATIONS) -> dict:
    """Median and 90th percentile of every metric (``irf.METRICS``; the shift in metres), with the mean peak loss
    and its standard error, over ``realisations`` realisations of the acquisitions' mixture (module docstring)."""
    pick = rng.choice(screens.weight.size, size=realisations, p=screens.weight)
    orbit_height = geometry.orbit.radius_m - EARTH_MEAN_RADIUS
    incidence = np.asarray(geometry.incidence, dtype=float)
    phases = np.zeros((realisations, SAMPLES))
    for index in np.unique(pick):
        rows = np.flatnonzero(pick == index)
        aperture = biomass_aperture(incidence[index], orbit_height, settings.frequency_hz,
                                    settings.azimuth_resolution_m, settings.height_m, settings.drift_m_s)
        c_kl = 10.0 ** screens.log10_ckl[index]

        def structure(lag, aperture=aperture, c_kl=c_kl):
            return two_way_structure(lag, aperture, c_kl, settings.spectral_index, settings.outer_scale_m)

        phases[rows] = phase_draws(rng, structure, SAMPLES, rows.size)
    peak, width = ideal_response(SAMPLES, OVERSAMPLE)
    metrics = irf_metrics(compress(phases, None, OVERSAMPLE), OVERSAMPLE, peak, width)
    metrics["shift_cells"] = metrics["shift_cells"] * settings.azimuth_resolution_m
    names = {"peak_loss_db": "peak_loss_{}_db", "resolution_ratio": "resolution_ratio_{}",
             "shift_cells": "shift_{}_m", "pslr_db": "pslr_{}_db", "islr_db": "islr_{}_db"}
    out = {}
    for key, pattern in names.items():
        out[pattern.format("median")] = float(np.median(metrics[key]))
        out[pattern.format("p90")] = float(np.quantile(metrics[key], 0.9))
    loss = metrics["peak_loss_db"]
    out["peak_loss_mean_db"] = float(np.mean(loss))
    out["peak_loss_mean_se_db"] = float(np.std(loss, ddof=1) / np.sqrt(loss.size))
    return out


def peak_log_loss(rng, geometry, settings, screens, realisations: int = REALISATIONS) -> tuple:
    """Per acquisition, (E[Z], E[Z^2]) of Z = -ln(peak ratio) of a point target: the residual phase Y of the
    weak-scatter theory (gamma: k theta and k theta^2 + (k theta)^2) where the acquisition is weak, else the sample
    moments of ``realisations`` Monte Carlo compressions (the Marechal law fails in strong scatter, where the peak
    keeps the incoherent part of the energy)."""
    k, theta = screens.shape, screens.scale
    mean, second = k * theta, k * theta * theta + (k * theta) ** 2
    strong = np.flatnonzero(~np.asarray(screens.weak, dtype=bool))
    if strong.size == 0:
        return mean, second
    orbit_height = geometry.orbit.radius_m - EARTH_MEAN_RADIUS
    peak, _ = ideal_response(SAMPLES, OVERSAMPLE)
    mean, second = mean.copy(), second.copy()
    for index in strong:
        aperture = biomass_aperture(float(np.asarray(geometry.incidence)[index]), orbit_height, settings.frequency_hz,
                                    settings.azimuth_resolution_m, settings.height_m, settings.drift_m_s)
        c_kl = 10.0 ** screens.log10_ckl[index]

        def structure(lag, aperture=aperture, c_kl=c_kl):
            return two_way_structure(lag, aperture, c_kl, settings.spectral_index, settings.outer_scale_m)

        intensity = compress(phase_draws(rng, structure, SAMPLES, realisations), None, OVERSAMPLE)
        z = -np.log(intensity.max(axis=-1) / peak)
        mean[index], second[index] = np.mean(z), np.mean(z * z)
    return mean, second


__all__ = ["OVERSAMPLE", "REALISATIONS", "SAMPLES", "mixture_monte_carlo", "peak_log_loss"]
