"""Where and when the ionosphere scintillates: a parameterised climatology of the screen strength C_kL.

The morphology follows the global picture of Aarons (1982), Proc. IEEE 70(4), "Global morphology of ionospheric
scintillations", and ITU-R Recommendation P.531-14 (2019), Section 4 (the same picture that WBMOD, Secan et al.
1995, Radio Science 30(3), parameterises): strong irregularities poleward of about 60 deg geomagnetic latitude
(auroral oval and polar cap), stronger at solar maximum and in the local winter; post-sunset equatorial bubbles at
the crests of the equatorial anomaly (about 15 deg geomagnetic), from about 19 h to 02 h local time, strongest at
the equinoxes and at solar maximum; a weak background elsewhere. The numbers below are ASSUMPTIONS, each with the
range the literature spans (docs/theory/scintillation.md, Section 3): the WBMOD values that Rogers et al. (2014)
used for BIOMASS are not published in a form this model could read. The strength is anchored to the phase
scintillation index sigma_phi of GPS L1 (scales below 1 km; ``screen.gps_phase_index``), which is what published
climatologies report (e.g. Spogli et al. 2009, Ann. Geophys. 27, high latitudes; Basu et al. 1988, equatorial):

    log10 C_kL = Q + A_hl(R, season) S((|lambda_m| - 62 deg) / 3 deg)
                   + A_eq(R) exp(-((|lambda_m| - 15 deg) / 8 deg)^2) E(LT) X(doy)  + z_q s_log      (eq. S16)

with S the logistic function, E(LT) = exp(-((LT - 22 h) / 2 h)^2) (LT taken in [12, 36) h), X = 0.6 + 0.4 cos(4 pi
(doy - 80) / 365.25) (equinox maxima), A_hl = 1.8 + 0.8 R / 150 + 0.2 w (w = +1 in the local winter solstice,
-1 in summer), A_eq = 4.0 (R / 150)^(1/2), R the 12-month sunspot number, and z_q the standard-normal quantile of
the percentile asked for (log-normal day-to-day spread, s_log = 0.5). Assumed values and ranges (C_kL in SI,
``screen``): Q = 22.8 (sigma_phi(L1) = 0.002 rad; range 22-23.5), the high-latitude median at solar maximum 25.4
(sigma_phi(L1) = 0.04 rad; range 24.5-26.5), at solar minimum 24.6 (0.017 rad), equatorial post-sunset maximum 26.8
(0.2 rad; range 26-27.5). Valid for 0 <= R <= 250; geomagnetic latitude from the IGRF-13 2020 dipole.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtri

from e2esim.errors import PhysicsInputError

# IGRF-13 dipole coefficients for 2020.0 (nT; mission facts): the geomagnetic north pole about 80.6 N, 72.7 W
_G10, _G11, _H11 = -29404.8, -1450.9, 4652.5
_B0 = math.sqrt(_G10 ** 2 + _G11 ** 2 + _H11 ** 2)
POLE_LAT = math.pi / 2.0 - math.acos(-_G10 / _B0)
POLE_LON = math.atan2(-_H11, -_G11)

QUIET_LOG10 = 22.8
SPREAD_LOG10 = 0.5
SOLAR_PRESETS = {"min": 10.0, "max": 150.0}  # 12-month sunspot number at solar minimum and maximum (cycles 23-25)


def geomagnetic_latitude(lat_rad, lon_rad):
    """Centred-dipole geomagnetic latitude (rad) of geocentric (lat, lon) (rad): spherical cosine rule to the pole."""
    s = (np.sin(lat_rad) * math.sin(POLE_LAT)
         + np.cos(lat_rad) * math.cos(POLE_LAT) * np.cos(np.asarray(lon_rad) - POLE_LON))
    return np.arcsin(np.clip(s, -1.0, 1.0))


def log10_ckl(mag_lat_rad, local_time_h, day_of_year, sunspot_number, percentile=50.0):
    """log10 C_kL (SI) of eq. S16; every argument broadcasts."""
    r = np.asarray(sunspot_number, dtype=float)
    if np.any((r < 0.0) | (r > 250.0)):
        raise PhysicsInputError(f"sunspot number {sunspot_number!r} is outside the climatology's range 0-250",
                                key="sunspot_number")
    pct = np.asarray(percentile, dtype=float)
    if np.any((pct <= 0.0) | (pct >= 100.0)):
        raise PhysicsInputError(f"percentile {percentile!r} must lie strictly between 0 and 100", key="percentile")
    mag = np.degrees(np.asarray(mag_lat_rad, dtype=float))
    doy = np.asarray(day_of_year, dtype=float)
    # local winter: December solstice (doy 355) in the north, June (doy 172) in the south
    winter = np.cos(2.0 * math.pi * (doy - 355.0) / 365.25) * np.sign(np.where(mag == 0.0, 1.0, mag))
    a_hl = 1.8 + 0.8 * r / 150.0 + 0.2 * winter
    high = a_hl / (1.0 + np.exp(-(np.abs(mag) - 62.0) / 3.0))
    lt = (np.asarray(local_time_h, dtype=float) - 12.0) % 24.0 + 12.0
    equinox = 0.6 + 0.4 * np.cos(4.0 * math.pi * (doy - 80.0) / 365.25)
    equatorial = (4.0 * np.sqrt(r / 150.0) * np.exp(-(((np.abs(mag) - 15.0) / 8.0) ** 2))
                  * np.exp(-(((lt - 22.0) / 2.0) ** 2)) * equinox)
    return QUIET_LOG10 + high + equatorial + ndtri(pct / 100.0) * SPREAD_LOG10


def ckl(lat_rad, lon_rad, local_time_h, day_of_year, sunspot_number, percentile=50.0):
    """C_kL (SI) at a site (geocentric lat, lon in rad) for a local time, day of year and sunspot number."""
    return 10.0 ** log10_ckl(geomagnetic_latitude(lat_rad, lon_rad), local_time_h, day_of_year, sunspot_number,
                             percentile)


__all__ = ["POLE_LAT", "POLE_LON", "QUIET_LOG10", "SOLAR_PRESETS", "SPREAD_LOG10", "ckl", "geomagnetic_latitude",
           "log10_ckl"]
