"""Earth model and reference frames: a spherical Earth, Earth-fixed (ECEF) vectors and local ENU bases.

The imaging geometry uses a sphere of the IUGG mean Earth radius; geocentric latitude on that sphere is
what every ``lat`` means in e2esim's geometry (geodetic latitude differs by at most 0.19 deg, far below
what matters for ionospheric climatology and the dipole geometry of Quegan et al. 2018, Table 1). The
orbit dynamics (sun-synchronous inclination, period) use the WGS84 equatorial radius and J2.

All functions are vectorised; vectors have their 3 components on the last axis.
"""

from __future__ import annotations

import numpy as np

EARTH_MEAN_RADIUS = 6371.0088e3
"""IUGG mean radius R1 of the Earth (m), radius of the spherical Earth of the imaging geometry."""

EARTH_EQUATORIAL_RADIUS = 6378.137e3
"""WGS84 semi-major axis (m), used for the orbit radius a = R_eq + altitude."""

EARTH_GM = 3.986004418e14
"""WGS84 geocentric gravitational constant (m^3/s^2)."""

EARTH_J2 = 1.08262668e-3
"""Second zonal harmonic of the geopotential (EGM2008, unnormalised)."""

EARTH_ROTATION_RATE = 7.292115e-5
"""WGS84 angular velocity of the Earth (rad/s)."""

TROPICAL_YEAR_S = 365.2421897 * 86400.0
"""Tropical year (s): the nodal precession period of a sun-synchronous orbit."""


def to_ecef(lat, lon, radius):
    """Earth-fixed position (m) of geocentric latitude, longitude (rad) and radius (m). Shape (..., 3)."""
    lat, lon, radius = np.broadcast_arrays(np.asarray(lat, float), np.asarray(lon, float), np.asarray(radius, float))
    cl = np.cos(lat)
    return np.stack([radius * cl * np.cos(lon), radius * cl * np.sin(lon), radius * np.sin(lat)], -1)


def from_ecef(xyz):
    """(geocentric latitude, longitude in (-pi, pi], radius) of Earth-fixed positions (..., 3)."""
    xyz = np.asarray(xyz, float)
    x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
    rho = np.hypot(x, y)
    return np.arctan2(z, rho), np.arctan2(y, x), np.sqrt(rho**2 + z**2)


def enu_basis(lat, lon):
    """Unit vectors east, north, up (each shape (..., 3)) at geocentric latitude/longitude (rad)."""
    lat, lon = np.broadcast_arrays(np.asarray(lat, float), np.asarray(lon, float))
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    east = np.stack([-so, co, np.zeros_like(lat)], -1)
    north = np.stack([-sl * co, -sl * so, cl], -1)
    up = np.stack([cl * co, cl * so, sl], -1)
    return east, north, up


def ecef_to_enu(vec, lat, lon):
    """Components (east, north, up) of Earth-fixed vectors (..., 3) at latitude/longitude (rad)."""
    e, n, u = enu_basis(lat, lon)
    vec = np.asarray(vec, float)
    return np.stack([np.sum(vec * e, -1), np.sum(vec * n, -1), np.sum(vec * u, -1)], -1)


def enu_to_ecef(enu, lat, lon):
    """Earth-fixed vectors from (east, north, up) components (..., 3) at latitude/longitude (rad)."""
    e, n, u = enu_basis(lat, lon)
    enu = np.asarray(enu, float)
    return enu[..., 0:1] * e + enu[..., 1:2] * n + enu[..., 2:3] * u


def central_angle(lat1, lon1, lat2, lon2):
    """Great-circle angle (rad) between two points on the sphere (haversine form, stable for small angles)."""
    dlat = np.asarray(lat2) - np.asarray(lat1)
    dlon = np.asarray(lon2) - np.asarray(lon1)
    a = np.sin(dlat / 2) ** 2 + np.cos(lat1) * np.cos(lat2) * np.sin(dlon / 2) ** 2
    return 2 * np.arcsin(np.sqrt(np.clip(a, 0.0, 1.0)))


def wrap_angle(x):
    """Angle wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(x, float), 2 * np.pi)
