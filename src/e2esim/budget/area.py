"""Area-projection (topographic normalisation) error, Ahmed et al. (2014), eqs. (36)-(38)."""

from __future__ import annotations

import numpy as np


def slope_error(dem_height_error_m, dem_posting_m, slope_rad):
    """Error of a terrain slope from the DEM, ``dtau = dh / (L_dem (1 + tan^2 tau))`` (rad), eq. (38).

    (The derivative of tau = arctan(dh / L) with respect to the height difference, times dh.)
    """
    return (np.asarray(dem_height_error_m, dtype=float)
            / (np.asarray(dem_posting_m, dtype=float) * (1.0 + np.tan(slope_rad) ** 2)))


def area_projection_error(incidence_rad, slope_range_rad, slope_azimuth_rad, slope_error_rad):
    """Relative error of the projected scattering area ``Delta A_c / A_c``, eq. (37):

    ``[sin(2 t_r) sin^2(t_s) + sin(2 t_s) sin^2(t_r)] / (2 - 2 sin^2(t_r) sin^2(t_s)) dtau
    + cos(theta - t_r - t_s) / (sin(theta - t_r) cos(t_s)) dtau``.

    On flat ground it reduces to ``cot(theta) dtau``, the derivative of ln(1/sin(theta - t_r)).
    """
    tr = np.asarray(slope_range_rad, dtype=float)
    ts = np.asarray(slope_azimuth_rad, dtype=float)
    theta = np.asarray(incidence_rad, dtype=float)
    dtau = np.asarray(slope_error_rad, dtype=float)
    s2r, s2s = np.sin(tr) ** 2, np.sin(ts) ** 2
    first = (np.sin(2 * tr) * s2s + np.sin(2 * ts) * s2r) / (2.0 - 2.0 * s2r * s2s)
    second = np.cos(theta - tr - ts) / (np.sin(theta - tr) * np.cos(ts))
    return (first + second) * dtau


def dem_averaging_factor(dem_pixel_area_m2, pixel_area_m2, looks, cap: bool = False):
    """``sqrt(A_dem / A_pix) / sqrt(N)`` of eqs. (30) and (36): how much of a DEM error survives averaging
    N looks. It exceeds 1 when the averaged area is smaller than a DEM cell (the paper's subplots); with
    ``cap`` it is limited to 1 (one DEM cell's error cannot grow by averaging inside it)."""
    f = np.sqrt(np.asarray(dem_pixel_area_m2, float) / (np.asarray(pixel_area_m2, float) * np.asarray(looks, float)))
    return np.minimum(f, 1.0) if cap else f
