"""Budget presets: UAVSAR as in Ahmed et al. (2014), Tables III-IV, and ESA BIOMASS at its AGB product
resolution (published mission facts, each value with its source; docs/theory/retrieval.md lists them).

Values are in SI units and radians; each carries its source. "Assumed" marks a value no source in the
project's reference list gives: change it for your study.
"""

from __future__ import annotations

import numpy as np

from e2esim.budget.calibration import BEAM_SHAPING_UNIFORM
from e2esim.budget.geometry import slant_range_spherical
from e2esim.budget.result import BudgetInputs

_MRAD = 1e-3
_DEG = np.pi / 180.0

UAVSAR_AHMED2014 = dict(
    bandwidth_hz=80e6,  # Table III, B = 80 MHz
    antenna_length_m=1.5,  # Table III, L_az
    eta_range=0.7,  # Table III, eta_rho
    eta_azimuth=0.7,  # Table III, eta_s
    nesz=10 ** (-40 / 10),  # Table III, -40 dB
    quantisation_bits=8,  # Table III, b
    ambiguity_ratio_db=20.0,  # Table III, AMB_t (from [21])
    random_calibration_db=0.05,  # Table III, Delta sigma_dB (from [21])
    pointing_error_rad=0.8 * _MRAD,  # Table III prints "0.8 [dB]": read as 0.8 mrad (docs/errata.md)
    elevation_beamwidth_rad=39.0 * _DEG,  # Table III, theta_1/2,e
    azimuth_beamwidth_rad=8.0 * _DEG,  # Table III, theta_1/2,s
    beam_shaping=BEAM_SHAPING_UNIFORM,  # Table III, k = 1/0.88
    dem_height_error_m=3.0,  # Table III, Delta h_dem (SRTM, [34])
    dem_posting_m=30.0,  # Table III, L_dem (SRTM)
    area_m2=10_000.0,  # Table IV, A_g (hectares)
    incidence_rad=40.0 * _DEG,  # Table IV, theta_i
    slope_range_rad=3.0 * _DEG,  # Table IV, tau_rho
    slope_azimuth_rad=3.0 * _DEG,  # Table IV, tau_s
    slant_range_m=16_322.0,  # Table IV, rho
    observations=10,  # Section III-A: "N_ot = N_oi = 10" (ten speckle-identical scenes; docs/errata.md)
    diverse_observations=1,  # Table IV, N_os
    temporal_sd_m2m2=0.002,  # eq. (44), HV, August 2009 over the Harvard Forest
)
"""UAVSAR over the Harvard and Howland forests, Ahmed et al. (2014), Tables III-IV and eq. (44)."""

_BIOMASS_ALTITUDE_M = 666e3  # CEOS EO Handbook, BIOMASS mission summary: 666 km
_BIOMASS_INCIDENCE = 0.5 * (23.0 + 33.75) * _DEG  # Quegan et al. (2018), Section 4.2: 23 deg near to 33.75 deg far

BIOMASS_200M = dict(
    bandwidth_hz=6e6,  # WMO OSCAR, instrument "SAR-P": 6 MHz; c/2B = 24.98 m = the quoted 25 m slant range
    azimuth_resolution_m=8.3,  # Quegan et al. (2018), Section 6: single look 25 m slant range x 8.3 m azimuth
    eta_range=1.0,  # assumed: the quoted resolutions are c/2B, i.e. unweighted (kappa = 1, eq. 25)
    eta_azimuth=1.0,  # assumed, as in range
    nesz=10 ** (-27 / 10),  # Men et al. (2021), Section V-A: -27 dB threshold
    quantisation_bits=8,  # assumed (UAVSAR value of Table III)
    ambiguity_ratio_db=20.0,  # assumed (the value of Hensley et al. [21] used by Ahmed et al. 2014)
    random_calibration_db=0.1,  # CEOS EO Handbook: radiometric stability 0.3 dB (3 sigma) -> 0.1 dB (1 sigma)
    pointing_error_rad=0.0,  # assumed: antenna pointing is inside the radiometric stability specification
    elevation_beamwidth_rad=9.5 * _DEG,  # assumed: look-angle span of the 23-33.75 deg incidence swath
    azimuth_beamwidth_rad=3.0 * _DEG,  # assumed; only used with a non-zero pointing error
    beam_shaping=BEAM_SHAPING_UNIFORM,  # uniformly weighted aperture (Table III of Ahmed et al. 2014)
    dem_height_error_m=3.0,  # assumed: SRTM-class DEM as in Ahmed et al. (2014), Table III
    dem_posting_m=30.0,  # assumed: 30 m posting (SRTM / Copernicus GLO-30)
    area_m2=200.0 * 200.0,  # Quegan et al. (2019), abstract: AGB product at 200 m (4 ha)
    incidence_rad=_BIOMASS_INCIDENCE,  # Quegan et al. (2018), Section 4.2: mid-swath
    slope_range_rad=3.0 * _DEG,  # assumed: the mean slopes of Ahmed et al. (2014), Table IV
    slope_azimuth_rad=3.0 * _DEG,  # assumed, as above
    slant_range_m=float(slant_range_spherical(_BIOMASS_ALTITUDE_M, _BIOMASS_INCIDENCE)),  # 666 km orbit
    observations=3,  # Quegan et al. (2018), Section 2: interferometric-phase cycle of 3 passes
    diverse_observations=1,  # assumed: repeat passes with small baselines are speckle identical
    temporal_relative_sd=0.0,  # no published value in the reference list: set it in the scenario
)
"""ESA BIOMASS P-band at the 200 m AGB product resolution (published values with their sources; assumptions
marked)."""

PRESETS = {"uavsar_ahmed2014": UAVSAR_AHMED2014, "biomass_200m": BIOMASS_200M}


def preset(name: str, **overrides) -> BudgetInputs:
    """``BudgetInputs`` of a preset with some fields replaced (SI units)."""
    if name not in PRESETS:
        raise KeyError(f"unknown budget preset {name!r}; presets: {', '.join(PRESETS)}")
    return BudgetInputs(**{**PRESETS[name], **overrides})
