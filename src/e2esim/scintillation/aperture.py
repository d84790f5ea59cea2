"""The synthetic aperture seen through a phase screen: where the rays of one azimuth compression cross the screen.

A stripmap SAR of wavelength lambda at slant range R with azimuth (Rayleigh) resolution rho_a integrates over the
synthetic aperture L_sa = lambda R / (2 rho_a) (Cumming & Wong 2005, Digital Processing of SAR Data, eq. 4.36 with
uniform weighting). The rays from every aperture position to one target cross a screen at height h_s at the fraction
h_s / H of the way from the target to the platform (flat-layer geometry, Rogers et al. 2014, Section III; Belcher &
Rogers 2009, Section 2), so the pierce point moves at V h_s / H while the irregularities drift at v_d: over the
aperture time L_sa / V the ray scans the screen over

    L_scan = L_sa |h_s / H - v_d / V|                                       (docs/theory/scintillation.md, eq. S6)

Both the transmitted and the received wave cross the screen at the same point (the platform moves 15 m per pulse),
so the two-way phase error is twice the one-way phase (Belcher & Rogers 2009, eq. 9) and its structure function
along the normalised aperture coordinate u in [-1/2, 1/2] is D_2(Delta u) = 4 D(Delta u L_scan) (eq. S7).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.orbit.frames import EARTH_MEAN_RADIUS
from e2esim.orbit.geometry import side_looking_angles
from e2esim.scintillation.screen import check_screen, matern_decorrelation, phase_variance, structure_function

GM_EARTH = 3.986004418e14  # m^3 s^-2 (IERS 2010)
SPEED_OF_LIGHT = 299792458.0


@dataclass(frozen=True)
class ApertureGeometry:
    """One azimuth compression (module docstring); every field broadcasts (arrays over cases).

    wavelength_m, slant_range_m, azimuth_resolution_m (rho_a, the Rayleigh resolution lambda R / (2 L_sa)),
    orbit_height_m (H), velocity_m_s (V), screen_height_m (h_s), drift_m_s (v_d), zenith_rad (zenith angle of the
    ray at the screen)."""

    wavelength_m: object
    slant_range_m: object
    azimuth_resolution_m: object
    orbit_height_m: object
    velocity_m_s: object
    screen_height_m: object
    drift_m_s: object = 0.0
    zenith_rad: object = 0.0

    @property
    def aperture_length_m(self):
        """L_sa = lambda R / (2 rho_a)."""
        return np.asarray(self.wavelength_m) * self.slant_range_m / (2.0 * np.asarray(self.azimuth_resolution_m))

    @property
    def scan_length_m(self):
        """L_scan of eq. S6: the length of screen one compression sees (m)."""
        ratio = np.asarray(self.screen_height_m, float) / self.orbit_height_m
        return self.aperture_length_m * np.abs(ratio - np.asarray(self.drift_m_s, float) / self.velocity_m_s)


def biomass_aperture(incidence_rad, orbit_height_m=666e3, frequency_hz=435e6, azimuth_resolution_m=8.3,
                     screen_height_m=350e3, drift_m_s=0.0) -> ApertureGeometry:
    """The aperture of BIOMASS (666 km, 435 MHz, 8.3 m single-look azimuth resolution: mission facts, seed 003
    Section 6) at an incidence angle: slant range from the spherical triangle (``side_looking_angles``), circular
    orbital speed sqrt(GM / r), zenith angle at the screen from sin(z) = R_E sin(theta) / (R_E + h_s)."""
    check_screen(0.0, 2.67, 1.0, screen_height_m, orbit_height_m)
    radius = EARTH_MEAN_RADIUS + np.asarray(orbit_height_m, float)
    _, _, rho = side_looking_angles(incidence_rad, radius)
    zenith = np.arcsin(EARTH_MEAN_RADIUS * np.sin(incidence_rad) / (EARTH_MEAN_RADIUS + np.asarray(screen_height_m)))
    return ApertureGeometry(SPEED_OF_LIGHT / frequency_hz, rho, azimuth_resolution_m, orbit_height_m,
                            np.sqrt(GM_EARTH / radius), screen_height_m, drift_m_s, zenith)


def two_way_structure(lag_u, aperture: ApertureGeometry, c_kl, spectral_index, outer_scale_m):
    """D_2(Delta u) = 4 D(Delta u L_scan): two-way phase structure function along the normalised aperture
    (eq. S7, rad^2), shape (cases..., lags...): the screen and aperture arguments give the case axes (scalars: none),
    ``lag_u`` the trailing ones."""
    lag = np.asarray(lag_u, dtype=float)

    def lead(value):
        value = np.asarray(value, dtype=float)
        return value.reshape(value.shape + (1,) * lag.ndim)

    lag_m = lag * lead(aperture.scan_length_m)
    args = lead(c_kl), lead(spectral_index), lead(outer_scale_m), lead(aperture.wavelength_m), lead(aperture.zenith_rad)
    rows = lag_m.reshape(-1, lag.size) if lag.ndim and lag_m.ndim > lag.ndim else None
    if rows is not None and np.ndim(spectral_index) == 0 and np.ndim(outer_scale_m) == 0:
        # the Matern factor (a Bessel function per element) depends on the scan length alone: computed once per
        # distinct length (a map's cases share their few incidences), then structure_function's expression. A row is
        # lag * L_scan: the distinct lengths are found among the numbers, not the rows (sorting the rows cost more
        # than the Bessel function)
        lengths, where = np.unique(np.asarray(aperture.scan_length_m, dtype=float).reshape(-1), return_inverse=True)
        scans = lag.reshape(-1) * lengths[:, None]
        decorrelation = matern_decorrelation(scans, args[1], args[2])[where.reshape(-1)].reshape(lag_m.shape)
        return 4.0 * (2.0 * phase_variance(*args) * decorrelation)
    return 4.0 * structure_function(lag_m, *args)


def aperture_grid(n: int) -> np.ndarray:
    """n sample positions of the normalised aperture, cell centres in [-1/2, 1/2]."""
    return (np.arange(n) + 0.5) / n - 0.5



__all__ = ["ApertureGeometry", "aperture_grid", "biomass_aperture", "two_way_structure"]
