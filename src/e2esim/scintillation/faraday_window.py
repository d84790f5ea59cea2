"""The spread of the Faraday rotation inside its estimation window from the TEC irregularities of the screen.

The screen's one-way phase is phi = r_e lambda dTEC (Rino 1979, eq. 8), and the one-way Faraday rotation is
Omega = K B_par TEC / f^2 (Quegan et al. 2018, eq. 3; K = e^3 / (8 pi^2 eps_0 m_e^2 c)), so the irregularities
rotate by dOmega = K B_par phi / (r_e c f) and the structure function of Omega is D_Omega = (K B_par / (r_e c f))^2 D
(docs/theory/scintillation.md, eq. S22). An estimator that averages over a window of side W on the ground (Bickel &
Bates over 2 km x 2 km) sees pierce points W (1 - h_s / H) apart on the screen (similar triangles), and a pixel's
rotation differs from the window's estimate by a residual of variance (averaged over the pixels of the window)

    s^2 = (1/2) E[D_Omega(|r - r'|)],   r, r' uniform in the square of side W' = W (1 - h_s / H)       (eq. S23)

(the mean squared deviation from the window mean of a stationary field), evaluated with Gauss-Legendre quadrature
over the triangular densities of the coordinate differences. Isotropic irregularities, no averaging over the
synthetic aperture: an upper bound (the aperture's own average can only smooth the residual).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import constants

from e2esim.geomag.dipole import dipole_field_ecef, dipole_moment_vector
from e2esim.orbit.frames import EARTH_MEAN_RADIUS
from e2esim.scintillation.screen import ELECTRON_RADIUS_M, structure_function

FARADAY_K = constants.e ** 3 / (8.0 * math.pi ** 2 * constants.epsilon_0 * constants.m_e ** 2 * constants.c)
DIPOLE_2020_T = (-29404.8e-9, -1450.9e-9, 4652.5e-9)  # IGRF-13 g10, g11, h11 for 2020.0 (mission facts)


@functools.lru_cache(maxsize=4)
def _nodes(order: int = 24) -> tuple:
    x, w = np.polynomial.legendre.leggauss(order)
    return 0.5 * (x + 1.0), 0.5 * w  # on [0, 1]


def parallel_field(geometry, screen_height_m) -> np.ndarray:
    """|B . k| (T) at each acquisition's pierce point (the geometry's pierce latitude and longitude at the screen
    height), from the IGRF-13 2020 centred dipole."""
    lat, lon = np.asarray(geometry.pierce_lat), np.asarray(geometry.pierce_lon)
    r = EARTH_MEAN_RADIUS + screen_height_m
    position = r * np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], axis=-1)
    field = dipole_field_ecef(position, dipole_moment_vector(*DIPOLE_2020_T))
    k = np.asarray(geometry.target_ecef, float) - np.asarray(geometry.satellite_ecef, float)
    k /= np.linalg.norm(k, axis=-1, keepdims=True)
    return np.abs(np.sum(field * k, axis=-1))


def window_variance(window_m, b_parallel, frequency_hz, c_kl, spectral_index, outer_scale_m, height_m,
                    orbit_height_m, zenith_rad):
    """s^2 of eq. S23 (rad^2) per acquisition; arrays broadcast."""
    side = window_m * (1.0 - np.asarray(height_m, float) / orbit_height_m)
    t, wt = _nodes()
    t1, t2 = np.meshgrid(t, t, indexing="ij")
    density = 4.0 * (1.0 - t1) * (1.0 - t2) * wt[:, None] * wt[None, :]  # triangular densities on [0, 1]^2
    lag = np.sqrt(t1 * t1 + t2 * t2)
    side = np.asarray(side, float)[..., None, None]

    def lead(value):
        return np.asarray(value, float)[..., None, None]

    d_phi = structure_function(lag * side, lead(c_kl), lead(spectral_index), lead(outer_scale_m),
                               constants.c / frequency_hz, lead(zenith_rad))
    ratio = FARADAY_K * np.asarray(b_parallel, float) / (ELECTRON_RADIUS_M * constants.c * frequency_hz)
    return 0.5 * ratio ** 2 * np.sum(density * d_phi, axis=(-2, -1))


__all__ = ["DIPOLE_2020_T", "FARADAY_K", "parallel_field", "window_variance"]
