"""Published values of Ahmed, Siqueira & Hensley (2014), recomputed by ``e2esim.verification.ahmed2014``.

Tolerances are half a unit of the last printed digit (the printed values are rounded), unless the
record says otherwise. Each value is computed from the paper's equations and the inputs of Tables III-IV
or Section III-A, never copied from the table it is compared with.
"""

from __future__ import annotations

from e2esim.verification.records import Published

_AHMED = "e2esim.verification.ahmed2014"
_T3 = "Ahmed, Siqueira & Hensley (2014), Table III"
_T4 = "Ahmed, Siqueira & Hensley (2014), Table IV"
_S3A = "Ahmed, Siqueira & Hensley (2014), Section III-A and eq. (22)"
_C_ROUNDED = (
    "The printed value is what eq. (23) gives with the speed of light rounded to 3.0e8 m/s (0.07 % high); "
    "e2esim uses the exact c = 299792458 m/s. See docs/errata.md (seed 004, A1)."
)

PUBLISHED: list = [
    Published(
        "ahmed2014.table3.range_resolution_m", "slant-range resolution c/(2B) for B = 80 MHz (m)", 1.875, 0.0005,
        f"{_T3}, eq. (23)", f"{_AHMED}:range_resolution", known_discrepancy=_C_ROUNDED,
        expected_computed=1.8737028625, computed_tolerance=1.87e-06,
    ),
    Published(
        "ahmed2014.table3.azimuth_resolution_m", "azimuth resolution L_az/2 for L_az = 1.5 m (m)", 0.75, 0.005,
        f"{_T3}, eq. (24)", f"{_AHMED}:azimuth_resolution",
    ),
    Published(
        "ahmed2014.table3.broadening_factor", "window broadening factor kappa for eta = 0.7", 1.1909, 0.00005,
        f"{_T3}, eq. (25)", f"{_AHMED}:broadening",
        expected_computed=1.1039332251163678, computed_tolerance=1.1e-06,
        known_discrepancy=(
            "Eq. (25), kappa = 1.6363 - 0.6363 sqrt(eta), gives 1.1039 for eta = 0.7; the printed 1.1909 is "
            "1.6363 - 0.6363 eta (eta instead of sqrt(eta)). The exact -3 dB width of the eta = 0.7 window is "
            "1.063 times the uniform one, so eq. (25) is the better approximation and Table III is in error "
            "(its Hamming value 1.456 also matches the 1.45 of Section III-A only with sqrt(eta)). See "
            "docs/errata.md (seed 004, A2)."
        ),
    ),
    Published(
        "ahmed2014.table3.slc_pixel_area_m2", "SLC pixel area (range x azimuth resolution) (m^2)", 1.4062, 0.00005,
        f"{_T3}", f"{_AHMED}:pixel_area",
        expected_computed=1.405277146875, computed_tolerance=1.41e-06,
        known_discrepancy=(
            "1.875 m x 0.75 m = 1.40625 m^2 with c rounded to 3.0e8 m/s; with the exact c the range resolution is "
            "1.87370 m and the area 1.40528 m^2. See docs/errata.md (seed 004, A1)."
        ),
    ),
    Published(
        "ahmed2014.table4.looks", "number of looks in a hectare, eq. (22), UAVSAR Tables III-IV", 3223, 0.5,
        f"{_T4}, eq. (22)", f"{_AHMED}:looks_table4",
        expected_computed=3753.3572577465216, computed_tolerance=0.00375,
        known_discrepancy=(
            "Eq. (22) with the Table III/IV inputs and kappa from eq. (25) (1.1039) gives 3753 looks. The printed "
            "3223 follows from the erroneous kappa = 1.1909 of Table III (and c = 3.0e8 m/s): 10000 sin(40 deg) / "
            "(1.1909^2 x 1.40625) = 3223.0. See docs/errata.md (seed 004, A2)."
        ),
    ),
    Published(
        "ahmed2014.table4.dem_pointing_error", "pointing error from the DEM, dh/rho (mrad; printed '[mm]')", 0.183,
        0.0005, f"{_T4}, eq. (35)", f"{_AHMED}:dem_pointing",
        expected_computed=0.18380100477882613, computed_tolerance=1.84e-07,
        known_discrepancy=(
            "3 m / 16322 m = 0.18380 mrad, which rounds to 0.184; the printed 0.183 is the value truncated, not "
            "rounded, to three decimals (the unit '[mm]' is mrad). See docs/errata.md (seed 004, A3)."
        ),
    ),
    Published(
        "ahmed2014.table4.slope_error", "slope error dh/(L_dem (1 + tan^2 tau)) (rad; printed '[m]')", 0.0997,
        0.00005, f"{_T4}, eq. (38)", f"{_AHMED}:slope_error",
    ),
    Published(
        "ahmed2014.sec3a.looks_subplot", "looks in a 25 m x 25 m subplot (1.6 m x 0.66 m, kappa 1.45, 40 deg)", 187,
        0.5, _S3A, f"{_AHMED}:looks_sec3a",
        expected_computed=180.94541853767475, computed_tolerance=0.000181,
        known_discrepancy=(
            "Eq. (22) with A_g = 625 m^2, theta = 40 deg, 1.6 m x 0.66 m and kappa = 1.45 in both directions gives "
            "180.9. The two printed values (187 and 2790) are also inconsistent with each other: eq. (22) makes N "
            "proportional to A_g, so hectare/subplot = 10000/625 = 16, while 2790/187 = 14.9. No single incidence "
            "angle or broadening reproduces both. See docs/errata.md (seed 004, A4)."
        ),
    ),
    Published(
        "ahmed2014.sec3a.looks_hectare", "looks in a hectare (1.6 m x 0.66 m, kappa 1.45, 40 deg)", 2790, 0.5,
        _S3A, f"{_AHMED}:looks_sec3a",
        expected_computed=2895.126696602796, computed_tolerance=0.0029,
        known_discrepancy=(
            "Eq. (22) with A_g = 10000 m^2 and the Section III-A inputs gives 2895.1, 16 times the subplot value; "
            "the printed 2790 is 14.9 times the printed subplot value 187. See docs/errata.md (seed 004, A4)."
        ),
    ),
]
