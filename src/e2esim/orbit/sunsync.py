"""A circular sun-synchronous orbit: inclination, state along the orbit, ground-track heading, local time.

Kernels on numpy arrays (radians, metres, seconds). The orbit plane keeps a fixed angle to the mean Sun
because J2 precesses the node by 360 deg per tropical year (Vallado 2013, eq. 11-14):

    cos i = -(2/3) (dOmega/dt) a^(7/2) / (J2 R_eq^2 sqrt(mu)),   dOmega/dt = 2 pi / (tropical year),

so the local mean solar time of the ascending node (LTAN) is the same every orbit. The sub-satellite
point at argument of latitude u (from the ascending node) has right ascension ``Omega + atan2(cos i sin u,
cos u)``, hence local mean solar time ``LTAN + atan2(cos i sin u, cos u) / 15 deg`` (h): for a dawn-dusk
orbit (LTAN 06:00) the local time at latitude 60 deg is about 05:04 on the ascending pass.

Earth-fixed state: the orbit is written in axes that coincide with the Earth-fixed axes at the instant
considered; ``node_lon`` is then the Earth-fixed longitude of the ascending node at that instant and the
Earth-relative velocity is ``v - omega_E z x r``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.orbit.frames import (
    EARTH_EQUATORIAL_RADIUS,
    EARTH_GM,
    EARTH_J2,
    EARTH_MEAN_RADIUS,
    EARTH_ROTATION_RATE,
    TROPICAL_YEAR_S,
    ecef_to_enu,
    from_ecef,
)

PASSES = ("ascending", "descending")
LOOK_SIDES = ("left", "right")


def sun_synchronous_inclination(altitude_m) -> np.ndarray:
    """Inclination (rad) of a circular sun-synchronous orbit at altitude (m) above the WGS84 equator."""
    a = EARTH_EQUATORIAL_RADIUS + np.asarray(altitude_m, float)
    rate = 2 * np.pi / TROPICAL_YEAR_S
    cos_i = -(2.0 / 3.0) * rate * a**3.5 / (EARTH_J2 * EARTH_EQUATORIAL_RADIUS**2 * np.sqrt(EARTH_GM))
    if np.any(np.abs(cos_i) > 1):
        raise PhysicsInputError(f"no sun-synchronous circular orbit at altitude {altitude_m} m")
    return np.arccos(cos_i)


def keplerian_period(altitude_m) -> np.ndarray:
    """Period (s) of a circular orbit at altitude (m) above the WGS84 equator: 2 pi sqrt(a^3 / mu)."""
    a = EARTH_EQUATORIAL_RADIUS + np.asarray(altitude_m, float)
    return 2 * np.pi * np.sqrt(a**3 / EARTH_GM)


@dataclass(frozen=True)
class SunSynchronousOrbit:
    """A circular sun-synchronous orbit and the side its radar looks to.

    altitude_m : height above the Earth (m): WGS84 equator for the dynamics, the spherical Earth of
        ``frames.EARTH_MEAN_RADIUS`` for the imaging geometry.
    ltan_h : local mean solar time of the ascending node (h), 6.0 for a dawn-dusk orbit.
    look_side : "left" or "right" of the Earth-relative velocity.
    earth_rotation : include the Earth's rotation in the ground velocity (heading, zero-Doppler plane).
    inclination_rad : None derives it from the sun-synchronous condition.
    """

    altitude_m: float
    ltan_h: float = 6.0
    look_side: str = "left"
    earth_rotation: bool = True
    inclination_rad: float | None = None

    def __post_init__(self):
        if not 150e3 <= self.altitude_m <= 6000e3:
            raise PhysicsInputError(f"orbit altitude {self.altitude_m / 1e3:g} km is outside 150-6000 km")
        if not 0 <= self.ltan_h < 24:
            raise PhysicsInputError(f"LTAN {self.ltan_h} h is outside [0, 24)")
        if self.look_side not in LOOK_SIDES:
            raise PhysicsInputError(f"look side {self.look_side!r} is not one of {LOOK_SIDES}")
        if self.inclination_rad is None:
            object.__setattr__(self, "inclination_rad", float(sun_synchronous_inclination(self.altitude_m)))

    @property
    def radius_m(self) -> float:
        """Orbit radius of the imaging geometry (m): spherical Earth radius + altitude."""
        return EARTH_MEAN_RADIUS + self.altitude_m

    @property
    def mean_motion(self) -> float:
        """Angular rate along the orbit (rad/s), from the WGS84 orbit radius."""
        return float(2 * np.pi / keplerian_period(self.altitude_m))

    @property
    def side_sign(self) -> float:
        return 1.0 if self.look_side == "left" else -1.0

    def pass_local_time(self, pass_name: str) -> float:
        """Local mean solar time (h) of the equator crossing of a pass."""
        return self.ltan_h if pass_name == "ascending" else (self.ltan_h + 12.0) % 24.0

    def pass_label(self, pass_name: str) -> str:
        """"dawn", "dusk", "day" or "night" from the local time of the pass at the equator."""
        t = self.pass_local_time(pass_name)
        if 4 <= t < 8:
            return "dawn"
        if 16 <= t < 20:
            return "dusk"
        return "day" if 8 <= t < 16 else "night"

    def pass_for_label(self, label: str) -> str:
        """Pass ("ascending"/"descending") whose equator crossing is at dawn, dusk, day or night."""
        for p in PASSES:
            if self.pass_label(p) == label:
                return p
        raise PhysicsInputError(f"this orbit (LTAN {self.ltan_h:g} h) has no {label} pass")


def orbit_state(orbit: SunSynchronousOrbit, u, node_lon):
    """Earth-fixed position (m) and Earth-relative velocity (m/s) at argument of latitude u and
    Earth-fixed node longitude ``node_lon`` (rad); shapes (..., 3)."""
    u, node_lon = np.broadcast_arrays(np.asarray(u, float), np.asarray(node_lon, float))
    ci, si = np.cos(orbit.inclination_rad), np.sin(orbit.inclination_rad)
    cn, sn, cu, su = np.cos(node_lon), np.sin(node_lon), np.cos(u), np.sin(u)
    node = np.stack([cn, sn, np.zeros_like(cn)], -1)
    quad = np.stack([-ci * sn, ci * cn, np.full_like(cn, si)], -1)
    r = orbit.radius_m * (cu[..., None] * node + su[..., None] * quad)
    v = orbit.radius_m * orbit.mean_motion * (-su[..., None] * node + cu[..., None] * quad)
    if orbit.earth_rotation:
        v = v - EARTH_ROTATION_RATE * np.stack([-r[..., 1], r[..., 0], np.zeros_like(r[..., 0])], -1)
    return r, v


def argument_of_latitude(orbit: SunSynchronousOrbit, lat, pass_name: str) -> np.ndarray:
    """u (rad) where the sub-satellite point is at geocentric latitude ``lat`` (rad) on a pass.

    NaN beyond the highest latitude the orbit reaches (180 deg - i).
    """
    s = np.sin(np.asarray(lat, float)) / np.sin(orbit.inclination_rad)
    with np.errstate(invalid="ignore"):
        u = np.arcsin(np.where(np.abs(s) <= 1, s, np.nan))
    return u if pass_name == "ascending" else np.pi - u


def ground_track_heading(orbit: SunSynchronousOrbit, lat, pass_name: str) -> np.ndarray:
    """Heading (rad, clockwise from north) of the ground track at sub-satellite latitude ``lat`` (rad),
    Earth rotation included when ``orbit.earth_rotation``."""
    u = argument_of_latitude(orbit, lat, pass_name)
    r, v = orbit_state(orbit, u, 0.0)
    plat, plon, _ = from_ecef(r)
    enu = ecef_to_enu(v, plat, plon)
    return np.arctan2(enu[..., 0], enu[..., 1])


def subsatellite_local_time(orbit: SunSynchronousOrbit, lat, pass_name: str) -> np.ndarray:
    """Local mean solar time (h, in [0, 24)) of the sub-satellite point at latitude ``lat`` (rad)."""
    u = argument_of_latitude(orbit, lat, pass_name)
    ci = np.cos(orbit.inclination_rad)
    offset = np.arctan2(ci * np.sin(u), np.cos(u))
    return np.mod(orbit.ltan_h + offset * 12 / np.pi, 24.0)
