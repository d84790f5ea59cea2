"""Resolution, window broadening and number of looks, Ahmed et al. (2014), eqs. (22)-(25).

All functions are vectorised numpy kernels in SI units (m, Hz, rad).
"""

from __future__ import annotations

import numpy as np

from e2esim.ionosphere.constants import SPEED_OF_LIGHT  # m/s, exact (SI definition)

EARTH_RADIUS_M = 6_371_008.8  # m: mean Earth radius (IUGG), for the spherical-Earth slant range

_BROADENING_A = 1.6363  # eq. (25): kappa = A - B sqrt(eta)
_BROADENING_B = 0.6363


def range_resolution(bandwidth_hz, speed_of_light=SPEED_OF_LIGHT):
    """Slant-range resolution c / (2 B) (m), eq. (23). bandwidth_hz : B (Hz), any shape."""
    return speed_of_light / (2.0 * np.asarray(bandwidth_hz, dtype=float))


def azimuth_resolution(antenna_length_m):
    """Best azimuth resolution of a strip-map SAR, L_az / 2 (m), eq. (24)."""
    return np.asarray(antenna_length_m, dtype=float) / 2.0


def broadening_factor(eta):
    """Resolution broadening of a weighting window, kappa = 1.6363 - 0.6363 sqrt(eta), eq. (25).

    eta : pedestal of the window ``w(f) = eta + (1 - eta) cos^2(pi f / B)``; 1 uniform (kappa = 1),
    0.08 Hamming (kappa = 1.456), 0 Hann (kappa = 1.636). Eq. (25) is a fit: ``window_broadening`` in
    ``e2esim.budget.window`` computes the exact -3 dB width (eq. 25 is within 5.1 % of it for eta in [0, 1],
    largest near eta = 0.47).
    Table III of the paper prints kappa = 1.1909 for eta = 0.7, which is 1.6363 - 0.6363 eta (eta instead
    of sqrt(eta)); eq. (25) gives 1.1039 (docs/errata.md).
    """
    eta = np.asarray(eta, dtype=float)
    return _BROADENING_A - _BROADENING_B * np.sqrt(eta)


def number_of_looks(area_m2, incidence_rad, range_resolution_m, azimuth_resolution_m, range_broadening=1.0,
                    azimuth_broadening=1.0):
    """Independent looks in a ground area, eq. (22): ``N = A_g sin(theta_i) / (kappa_r dr kappa_s ds)``.

    area_m2 : A_g, ground area averaged (m^2). incidence_rad : local incidence angle theta_i (rad).
    range_resolution_m, azimuth_resolution_m : slant-range and azimuth resolution (m).
    range_broadening, azimuth_broadening : kappa_rho, kappa_s (eq. 25). Any broadcastable shapes;
    N is not rounded.
    """
    return (np.asarray(area_m2, dtype=float) * np.sin(incidence_rad)
            / (range_broadening * range_resolution_m * azimuth_broadening * azimuth_resolution_m))


def slant_range_spherical(altitude_m, incidence_rad, earth_radius_m=EARTH_RADIUS_M):
    """Slant range (m) from a platform at ``altitude_m`` to a point seen at incidence ``incidence_rad``
    on a spherical Earth (law of sines in the Earth-centre/platform/target triangle).

    For an airborne SAR (altitude << Earth radius) it tends to altitude / cos(incidence).
    """
    h = np.asarray(altitude_m, dtype=float)
    theta = np.asarray(incidence_rad, dtype=float)
    r = earth_radius_m
    look = np.arcsin(np.clip(r * np.sin(theta) / (r + h), -1.0, 1.0))  # off-nadir look angle
    central = theta - look  # Earth-central angle
    return np.sqrt(r**2 + (r + h) ** 2 - 2.0 * r * (r + h) * np.cos(central))
