"""The zero-Doppler acquisitions of a site on a real orbit, on the radar's side and inside the swath.

A zero-Doppler-steered SAR images a target T when the line of sight is perpendicular to the Earth-relative
velocity V of the satellite S (the convention of e2esim.orbit.geometry). The Doppler function

    f(t) = (T - S(t)) . V(t) / |T - S(t)|      (the rate at which the range shrinks, m/s)

goes from positive (approaching) to negative (receding) at the closest approach of each pass; the other zero, a
range maximum, is on the far side of the Earth. Crossings are bracketed on a grid of ``SEARCH_STEP_S`` and refined
by bisection to ``TIME_TOLERANCE_S``. An acquisition is kept when the target is on the ``look_side`` of the
velocity (``(S x V) . (T - S) > 0`` for left) and its incidence lies in [near, far] of the swath.

The incidence at T is the angle between the surface normal there and the direction to the satellite. The site is
placed on the ``surface``: "sphere" (the IUGG mean sphere of e2esim's circular-orbit geometry: the site's geocentric
latitude and the radial normal) or "wgs84" (the point of the WGS84 ellipsoid at that geocentric latitude and the
ellipsoid normal, where real orbits place the ground): at latitude 60 deg the ellipsoid lies 9.0 km inside the
mean sphere, which lowers BIOMASS's incidence there by 0.4 deg (28.0 -> 27.6 deg).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.orbit.frames import EARTH_EQUATORIAL_RADIUS, EARTH_MEAN_RADIUS, to_ecef
from e2esim.orbit.real.trajectory import Trajectory

SEARCH_STEP_S = 20.0
"""Grid of the Doppler zero search (s): a pass's closest approach is a single sign change at this step (the
Doppler function of a low orbit changes sign once in about 45 minutes)."""

TIME_TOLERANCE_S = 1e-6
"""Bisection stops at this bracket width (s): 7 mm along track."""

MAX_SEARCH_SAMPLES = 2_000_000
"""Samples of the Doppler function in one search (a window of 460 days at 20 s)."""

WGS84_FLATTENING = 1 / 298.257223563
SURFACES = ("wgs84", "sphere")


def site_on_surface(lat, lon, surface: str):
    """Earth-fixed position (m) and unit surface normal of the site at geocentric ``lat``, ``lon`` (rad)."""
    if surface == "sphere":
        p = to_ecef(lat, lon, EARTH_MEAN_RADIUS)
        return p, p / EARTH_MEAN_RADIUS
    a = EARTH_EQUATORIAL_RADIUS
    b = a * (1 - WGS84_FLATTENING)
    r = a * b / np.hypot(b * np.cos(lat), a * np.sin(lat))
    geodetic = np.arctan(np.tan(lat) * (a / b) ** 2)
    return to_ecef(lat, lon, r), to_ecef(geodetic, lon, 1.0)


@dataclass(frozen=True)
class SitePasses:
    """The acquisitions found: UTC seconds ``t_s`` (since the trajectory's epoch), satellite position and
    Earth-relative velocity (n, 3), incidence (rad), ascending (bool), and what was rejected and why."""

    t_s: np.ndarray
    satellite: np.ndarray
    velocity: np.ndarray
    incidence: np.ndarray
    ascending: np.ndarray
    rejected: str


def doppler(trajectory: Trajectory, target, t_s):
    s, v = trajectory.state(t_s)
    d = target - s
    return np.sum(d * v, -1) / np.linalg.norm(d, axis=-1)


def site_passes(trajectory: Trajectory, target, normal, start_s: float, end_s: float, look_side: str,
                incidence_range: tuple, passes: tuple) -> SitePasses:
    """Zero-Doppler acquisitions of ``target`` (Earth-fixed, m; ``normal`` its unit surface normal) between
    ``start_s`` and ``end_s`` (module docstring)."""
    count = int(np.ceil((end_s - start_s) / SEARCH_STEP_S)) + 1
    if count > MAX_SEARCH_SAMPLES:
        days = MAX_SEARCH_SAMPLES * SEARCH_STEP_S / 86400
        raise PhysicsInputError(f"an acquisition window of {(end_s - start_s) / 86400:.1f} days needs {count:,} orbit "
                                f"samples; at most {MAX_SEARCH_SAMPLES:,} ({days:.0f} days)")
    grid = np.linspace(start_s, end_s, max(count, 2))
    f = doppler(trajectory, target, grid)
    k = np.nonzero((f[:-1] > 0) & (f[1:] <= 0))[0]
    lo, hi = grid[k], grid[k + 1]
    while lo.size and np.max(hi - lo) > TIME_TOLERANCE_S:
        mid = 0.5 * (lo + hi)
        positive = doppler(trajectory, target, mid) > 0
        lo, hi = np.where(positive, mid, lo), np.where(positive, hi, mid)
    t = 0.5 * (lo + hi)
    s, v = trajectory.state(t)
    d = s - target
    incidence = np.arccos(np.clip(np.sum(d * normal, -1) / np.linalg.norm(d, axis=-1), -1, 1))
    side = 1.0 if look_side == "left" else -1.0
    on_side = side * np.sum(np.cross(s, v) * (target - s), -1) > 0
    in_swath = (incidence >= incidence_range[0] - 1e-12) & (incidence <= incidence_range[1] + 1e-12)
    ascending = v[:, 2] > 0
    wanted = np.isin(np.where(ascending, "ascending", "descending"), passes)
    keep = on_side & in_swath & wanted
    rejected = (f"{t.size} zero-Doppler crossings: {int(np.sum(~on_side))} on the other side, "
                f"{int(np.sum(on_side & ~in_swath))} outside the swath's incidence, "
                f"{int(np.sum(on_side & in_swath & ~wanted))} on a pass not asked for")
    return SitePasses(t[keep], s[keep], v[keep], incidence[keep], ascending[keep], rejected)
