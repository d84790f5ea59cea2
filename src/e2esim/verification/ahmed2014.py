"""Recompute the published numbers of Ahmed, Siqueira & Hensley (2014) from its equations and inputs.

Each function takes the ``Published`` record and returns ``(computed, tolerance or None, note)``.
Inputs: Table III (B = 80 MHz, L_az = 1.5 m, eta = 0.7, Delta h_dem = 3 m, L_dem = 30 m), Table IV
(A_g = 1 ha, theta_i = 40 deg, tau = 3 deg, rho = 16322 m) and Section III-A (25 m subplots and hectares,
native resolution 1.6 m x 0.66 m, broadening 1.45, 40 deg).
"""

from __future__ import annotations

import numpy as np

from e2esim.budget.area import slope_error as _slope_error
from e2esim.budget.calibration import dem_pointing_error
from e2esim.budget.geometry import azimuth_resolution as _azimuth_resolution
from e2esim.budget.geometry import broadening_factor, number_of_looks
from e2esim.budget.geometry import range_resolution as _range_resolution
from e2esim.budget.presets import UAVSAR_AHMED2014 as _U

_C_PAPER = 3.0e8  # m/s: the rounded speed of light the printed Table III values imply (docs/errata.md)


def _table3_looks(kappa: float, c: float | None = None) -> float:
    dr = float(_range_resolution(_U["bandwidth_hz"])) if c is None else float(_range_resolution(_U["bandwidth_hz"], c))
    ds = float(_azimuth_resolution(_U["antenna_length_m"]))
    return float(number_of_looks(_U["area_m2"], _U["incidence_rad"], dr, ds, kappa, kappa))


def range_resolution(record):
    value = float(_range_resolution(_U["bandwidth_hz"]))
    paper = float(_range_resolution(_U["bandwidth_hz"], _C_PAPER))
    return value, None, f"eq. (23), B = 80 MHz, exact c; with c = 3.0e8 m/s: {paper:.4f} m"


def azimuth_resolution(record):
    return float(_azimuth_resolution(_U["antenna_length_m"])), None, "eq. (24), L_az = 1.5 m"


def broadening(record):
    value = float(broadening_factor(_U["eta_range"]))
    linear = 1.6363 - 0.6363 * _U["eta_range"]
    return value, None, f"eq. (25), eta = 0.7; 1.6363 - 0.6363 eta would give {linear:.4f}"


def pixel_area(record):
    dr = float(_range_resolution(_U["bandwidth_hz"]))
    ds = float(_azimuth_resolution(_U["antenna_length_m"]))
    return dr * ds, None, f"eqs. (23)-(24): {dr:.5f} m x {ds:.2f} m"


def looks_table4(record):
    kappa = float(broadening_factor(_U["eta_range"]))
    value = _table3_looks(kappa)
    printed_kappa = _table3_looks(1.1909, _C_PAPER)
    return value, None, (f"eq. (22), A_g = 1 ha, theta = 40 deg, kappa = {kappa:.4f} (eq. 25), exact c; with "
                         f"Table III's kappa = 1.1909 and c = 3.0e8 m/s: {printed_kappa:.1f}")


def dem_pointing(record):
    value = float(dem_pointing_error(_U["dem_height_error_m"], _U["slant_range_m"])) * 1e3
    return value, None, "eq. (35), 3 m / 16322 m, in mrad"


def slope_error(record):
    value = float(_slope_error(_U["dem_height_error_m"], _U["dem_posting_m"], _U["slope_range_rad"]))
    return value, None, "eq. (38), 3 m / (30 m (1 + tan^2 3 deg)), in rad"


def looks_sec3a(record):
    area = 625.0 if record.id.endswith("subplot") else 10_000.0
    value = float(number_of_looks(area, np.radians(40.0), 1.6, 0.66, 1.45, 1.45))
    return value, None, f"eq. (22), A_g = {area:g} m^2, theta = 40 deg, 1.6 m x 0.66 m, kappa = 1.45"
