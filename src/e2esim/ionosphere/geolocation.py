"""Geolocation: the ionospheric range delay from measured Faraday rotation, its error, and the latitude
zone where a geolocation requirement cannot be met (Quegan et al. 2018, Section 6 and Table 1).

The slant range delay follows from the measured Omega by eq. (8), ``r_sd = Omega / ((e / m_e c) B.k)``,
so the Bickel-Bates estimator's error (eqs. 5-6) gives the delay error

    sigma_r = sigma_Omega / ((e / m_e c) |B.k|),

which blows up where B.k = 0, near the magnetic equator. The requirement ``z sigma_r <= R`` (R = 25 m for
BIOMASS, ESA 2016) fails in a latitude band around the zero line of B.k, Table 1.

The paper does not state the geometry, the confidence or the variance it used. ``TABLE1_ASSUMPTIONS`` is
the set found by searching incidence, pierce-point height, latitude convention, Earth rotation, dipole
strength, confidence factor, slant or ground range and variance form (docs/theory/ionosphere.md,
"Table 1"): with eq. (5) as printed it reproduces all eight printed latitudes to within 0.005 deg (their
rounding). e2esim computes with the corrected variance (gamma^2, e2esim.faraday.theory), which
moves the edges by at most 0.08 deg (SNR 10 dB, L = 100).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.faraday.theory import bickel_bates_variance
from e2esim.geomag.field import FieldModel
from e2esim.ionosphere.constants import CHARGE_TO_MASS_OVER_C
from e2esim.orbit.frames import from_ecef
from e2esim.orbit.geometry import ray_points, view_geometry
from e2esim.orbit.sunsync import SunSynchronousOrbit


def range_delay_error(sigma_omega, b_dot_k) -> np.ndarray:
    """Standard deviation (m) of the slant range delay estimated from Omega via eq. (8): sigma_Omega (rad)
    over (e / m_e c) |B.k| (B.k in T)."""
    return np.asarray(sigma_omega) / (CHARGE_TO_MASS_OVER_C * np.abs(np.asarray(b_dot_k)))


def delay_error_from_estimator(snr_db, looks, b_dot_k, form: str = "asymptotic") -> np.ndarray:
    """SD (m) of the slant range delay estimated from the Bickel-Bates Omega_hat (eqs. 5, 6, 8) for SNR
    (dB, eq. 6), L looks and B.k (T), any broadcastable shapes."""
    sigma = np.sqrt(bickel_bates_variance(10 ** (np.asarray(snr_db, float) / 10), looks, form))
    return range_delay_error(sigma, b_dot_k)


@dataclass(frozen=True)
class GeolocationAssumptions:
    """Everything behind a Table 1 zone.

    incidence_deg : incidence at the target. pierce_height_m : height where B.k is evaluated (0: at the
    target). latitude_at : "pierce" or "target", the latitude the zone is quoted in. earth_rotation :
    heading and zero Doppler with the Earth's rotation. pass_name : "ascending" or "descending" (the
    two give the same zone for a dipole). b0_tesla : equatorial surface field of the axis-aligned centred
    dipole. confidence_z : the requirement is ``confidence_z * sigma_r <= requirement_m``.
    ground_range : apply the requirement to the ground-range error sigma_r / sin(incidence).
    variance_form : "asymptotic" (eq. 5 corrected, gamma^2) or "printed" eq. (5).
    altitude_m, ltan_h, look_side : the orbit.
    """

    incidence_deg: float = 26.0
    pierce_height_m: float = 300e3
    latitude_at: str = "pierce"
    earth_rotation: bool = False
    pass_name: str = "ascending"
    b0_tesla: float = 3.12e-5
    confidence_z: float = 2.576
    requirement_m: float = 25.0
    ground_range: bool = False
    variance_form: str = "asymptotic"
    altitude_m: float = 666e3
    ltan_h: float = 6.0
    look_side: str = "left"

    def __post_init__(self):
        if self.latitude_at not in ("pierce", "target"):
            raise PhysicsInputError(f"latitude_at must be 'pierce' or 'target', got {self.latitude_at!r}")
        if self.pierce_height_m >= self.altitude_m:
            raise PhysicsInputError("the pierce point must be below the satellite")


TABLE1_ASSUMPTIONS = GeolocationAssumptions()
"""The geometry, field and confidence consistent with Quegan et al. (2018), Table 1: incidence 26 deg,
B.k at a 300 km pierce point and latitudes quoted there, no Earth rotation, axis-aligned centred dipole of
3.12e-5 T, 99 % two-sided confidence (z = 2.576) on the 25 m slant-range error."""


def b_dot_k_profile(assumptions: GeolocationAssumptions, target_lat_deg):
    """(quoted latitude (deg), B.k (T)) for targets at geocentric latitudes (deg), any shape."""
    a = assumptions
    orbit = SunSynchronousOrbit(a.altitude_m, a.ltan_h, a.look_side, a.earth_rotation)
    g = view_geometry(orbit, np.radians(np.asarray(target_lat_deg, float)), 0.0, np.radians(a.incidence_deg),
                      a.pass_name)
    if a.pierce_height_m > 0:
        pos = ray_points(g.target_ecef, g.satellite_ecef, np.array([a.pierce_height_m])).position[..., 0, :]
    else:
        pos = g.target_ecef
    lat = np.degrees(from_ecef(pos)[0]) if a.latitude_at == "pierce" else np.asarray(target_lat_deg, float)
    field = FieldModel("aligned_dipole", "2016-01-01", b0_tesla=a.b0_tesla)
    return lat, field.b_dot_k(pos, g.k_ecef)


def delay_error_threshold(snr_db: float, looks: float, assumptions: GeolocationAssumptions) -> float:
    """|B.k| (T) below which ``z sigma_r`` exceeds the requirement, for the Bickel-Bates estimator at
    SNR (dB, eq. 6) and L looks."""
    a = assumptions
    sigma = np.sqrt(bickel_bates_variance(10 ** (snr_db / 10), looks, a.variance_form))
    factor = 1 / np.sin(np.radians(a.incidence_deg)) if a.ground_range else 1.0
    return float(a.confidence_z * sigma * factor / (CHARGE_TO_MASS_OVER_C * a.requirement_m))


def excluded_zone(snr_db: float, looks: float, assumptions: GeolocationAssumptions = TABLE1_ASSUMPTIONS,
                  search_deg: tuple = (-20.0, 20.0)) -> tuple:
    """(south, north) latitude (deg) of the band where the requirement cannot be met (Table 1).

    The zero line of B.k is found by bracketing in target latitude within ``search_deg``; the edges where
    |B.k| equals the threshold on either side by Brent's method; latitudes are returned in the
    assumptions' convention (pierce point or target).
    """
    from scipy.optimize import brentq  # here: scipy.optimize costs every e2esim process a fifth of a second

    thr = delay_error_threshold(snr_db, looks, assumptions)

    def bk(lat):
        return float(b_dot_k_profile(assumptions, lat)[1])

    lo, hi = search_deg
    grid = np.linspace(lo, hi, 401)
    vals = b_dot_k_profile(assumptions, grid)[1]
    sign_change = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))
    if sign_change.size == 0:
        raise PhysicsInputError(f"B.k does not change sign between {lo} and {hi} deg")
    i = sign_change[0]
    zero = brentq(bk, grid[i], grid[i + 1], xtol=1e-10)
    slope_sign = np.sign(vals[i + 1] - vals[i])
    south = brentq(lambda x: bk(x) + slope_sign * thr, lo, zero, xtol=1e-10)
    north = brentq(lambda x: bk(x) - slope_sign * thr, zero, hi, xtol=1e-10)
    quoted = b_dot_k_profile(assumptions, np.array([south, north]))[0]
    return float(quoted[0]), float(quoted[1])


def zero_line_latitude(assumptions: GeolocationAssumptions = TABLE1_ASSUMPTIONS) -> float:
    """Latitude (deg, the assumptions' convention) where B.k = 0: the centre of the Table 1 zones."""
    from scipy.optimize import brentq

    grid = np.linspace(-20, 20, 401)
    vals = b_dot_k_profile(assumptions, grid)[1]
    i = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0]
    zero = brentq(lambda x: float(b_dot_k_profile(assumptions, x)[1]), grid[i], grid[i + 1], xtol=1e-10)
    return float(b_dot_k_profile(assumptions, np.array([zero]))[0][0])
