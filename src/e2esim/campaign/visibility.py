"""When the mission sees a site: every pass of the propagated orbit that images it (issue 25, item 2).

The orbit is the circular sun-synchronous orbit of ``e2esim.orbit.sunsync`` propagated with the secular J2 rates
of a circular orbit (Vallado 2013, eqs. 9-41): the argument of latitude advances at

    du/dt = n [1 + (3/4) J2 (R_eq/a)^2 (3 cos^2 i - 1)] + (3/4) n J2 (R_eq/a)^2 (5 cos^2 i - 1),

(mean anomaly plus argument of perigee), and the node keeps its local mean solar time (LTAN): the Earth-fixed
longitude of the ascending node at UTC time t is lambda_N(t) = 2 pi (LTAN - UT(t)) / 24 h (the node precesses at the
mean Sun's rate, which is what makes the orbit sun-synchronous; ``sunsync`` module docstring). ``orbit_state`` then
gives the Earth-fixed position and Earth-relative velocity.

A pass images the site at zero Doppler in the Earth-fixed frame, (r_sat - r_T) . v_rel = 0, found by Newton's
method from the instant the sub-satellite point crosses the site's latitude; the site is acquired when its
incidence angle is inside the swath and it lies on the radar's look side. The phase of the orbit is set by
``first_node_utc``: the instant of an ascending-node crossing (the mission start by default).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.orbit.frames import EARTH_EQUATORIAL_RADIUS, EARTH_J2, EARTH_MEAN_RADIUS, to_ecef
from e2esim.orbit.sunsync import PASSES, SunSynchronousOrbit, argument_of_latitude, orbit_state

DAY_S = 86400.0


def argument_of_latitude_rate(orbit: SunSynchronousOrbit) -> float:
    """du/dt (rad/s) of a circular orbit with the secular J2 terms (Vallado 2013, eqs. 9-41, e = 0)."""
    a = EARTH_EQUATORIAL_RADIUS + orbit.altitude_m
    n = orbit.mean_motion
    k = 0.75 * EARTH_J2 * (EARTH_EQUATORIAL_RADIUS / a) ** 2
    c2 = np.cos(orbit.inclination_rad) ** 2
    return float(n * (1 + k * (3 * c2 - 1)) + n * k * (5 * c2 - 1))


def node_longitude(orbit: SunSynchronousOrbit, t_s) -> np.ndarray:
    """Earth-fixed longitude (rad) of the ascending node at ``t_s`` seconds after a UTC midnight."""
    ut_h = np.mod(np.asarray(t_s, float) / 3600.0, 24.0)
    return 2 * np.pi * (orbit.ltan_h - ut_h) / 24.0


def satellite_state(orbit: SunSynchronousOrbit, t_s, first_node_s: float = 0.0, track_offset=0.0):
    """Earth-fixed position (m) and Earth-relative velocity (m/s) at ``t_s`` (s after the mission's first
    UTC midnight), the satellite crossing the ascending node at ``first_node_s``, the ground track moved east by
    ``track_offset`` (rad; the drifting repeat track's stack, ``repeat_orbit``)."""
    t = np.asarray(t_s, float)
    u = argument_of_latitude_rate(orbit) * (t - first_node_s)
    return orbit_state(orbit, u, node_longitude(orbit, t) + track_offset)


@dataclass(frozen=True)
class SiteVisits:
    """Every acquisition of one site, in time order (arrays of shape (n,)).

    time_s : seconds after the first UTC midnight of the mission. day : time_s / 86400. incidence : rad.
    pass_name : "ascending"/"descending". local_time_h : local mean solar time at the site (h).
    track_offset : the ground track's eastward offset at each visit (rad; ``repeat_orbit``), 0 without a track.
    """

    site_name: str
    time_s: np.ndarray
    incidence: np.ndarray
    pass_name: np.ndarray
    local_time_h: np.ndarray
    track_offset: np.ndarray | float = 0.0

    @property
    def day(self) -> np.ndarray:
        return self.time_s / DAY_S

    @property
    def size(self) -> int:
        return int(self.time_s.size)


def site_visits(orbit: SunSynchronousOrbit, lat: float, lon: float, days: float, near: float, far: float,
                first_node_s: float = 0.0, name: str = "site", iterations: int = 6, track=None,
                point: bool = True) -> SiteVisits:
    """Every pass over (lat, lon) (rad) in ``days`` days that sees it at an incidence in [near, far] (rad) on the
    look side. ``track`` (a ``repeat_orbit.RepeatTrack`` of this orbit): the ground track moves with its stacks,
    a pass is kept only inside a stack (not in a manoeuvre) and where the mission's plan acquires it (``point``: a
    point calibrator, else an area; ``RepeatTrack.acquired``)."""
    if not 0 < near < far < np.pi / 2:
        raise PhysicsInputError(f"need 0 < near < far < 90 deg incidence, got {np.degrees(near):g}, "
                                f"{np.degrees(far):g}")
    target = to_ecef(np.array(lat), np.array(lon), EARTH_MEAN_RADIUS)
    up = target / np.linalg.norm(target)
    rate = argument_of_latitude_rate(orbit)
    period = 2 * np.pi / rate
    revs = np.arange(-1, int(np.ceil(days * DAY_S / period)) + 1)
    times = []
    for p in PASSES:
        # the latitude crossing of the sub-satellite point (beyond the orbit's reach: the nearest approach, u = pi/2)
        u0 = argument_of_latitude(orbit, np.clip(lat, -(np.pi - orbit.inclination_rad),
                                                 np.pi - orbit.inclination_rad), p)
        t = first_node_s + (revs + np.mod(u0, 2 * np.pi) / (2 * np.pi)) * period
        offset = 0.0 if track is None else track.stack_of(t / DAY_S)[3]  # the start's stack: held through Newton
        for _ in range(iterations):  # Newton on the zero-Doppler condition, derivative by a 1 s difference
            f0 = _doppler(orbit, t, first_node_s, target, offset)
            f1 = _doppler(orbit, t + 1.0, first_node_s, target, offset)
            step = f0 / (f1 - f0)
            t = t - step
        ok = np.abs(step) < 1e-3  # a start far from any closest approach has not converged: dropped
        if track is not None:  # a pass that left its start's stack lies in a manoeuvre: dropped
            ok &= (track.stack_of(t / DAY_S)[2] >= 0) & (track.stack_of(t / DAY_S)[3] == offset)
        times.append(t[ok])
    # near the orbit's highest latitude both starts can reach the same closest approach: keep it once, and name
    # its pass by the direction of the satellite's motion there
    t = np.unique(np.round(np.concatenate(times), 3))
    t = t[np.concatenate([[True], np.diff(t) > 60.0])]
    offset = 0.0 if track is None else track.stack_of(t / DAY_S)[3]
    r, v = satellite_state(orbit, t, first_node_s, offset)
    pass_name = np.where(v[:, 2] >= 0, "ascending", "descending")
    los = r - target
    cos_inc = los @ up / np.linalg.norm(los, axis=-1)
    incidence = np.arccos(np.clip(cos_inc, -1, 1))
    left = np.cross(r, v)  # r x v points to the left of the velocity
    side = np.sign(np.einsum("ij,ij->i", target - r, left)) * orbit.side_sign
    keep = (side > 0) & (incidence >= near) & (incidence <= far) & (t >= 0) & (t <= days * DAY_S)
    if track is not None:
        keep[keep] = track.acquired(t[keep] / DAY_S, pass_name[keep], incidence[keep], near, far, point)
    order = np.argsort(t[keep])
    t, incidence, pass_name = t[keep][order], incidence[keep][order], pass_name[keep][order]
    local = np.mod(t / 3600.0 + np.degrees(lon) / 15.0, 24.0)
    return SiteVisits(name, t, incidence, pass_name, local, 0.0 if track is None else track.stack_of(t / DAY_S)[3])


def _doppler(orbit, t, first_node_s, target, offset=0.0) -> np.ndarray:
    r, v = satellite_state(orbit, t, first_node_s, offset)
    return np.einsum("ij,ij->i", r - target, v)
