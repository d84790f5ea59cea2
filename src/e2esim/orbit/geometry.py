"""Side-looking SAR geometry on a spherical Earth: where the satellite is when it images a target.

For a target T, an incidence angle theta at T and a pass, ``view_geometry`` finds the orbit position S
(argument of latitude u and Earth-fixed node longitude) at which T is seen at zero Doppler (the line of
sight is perpendicular to the Earth-relative velocity, as for a zero-Doppler-steered SAR) and at incidence
theta on the radar's side. In the triangle Earth centre - target - satellite (radii R and R + H):

    sin(eta) = R sin(theta) / (R + H)   (look angle eta at the satellite),
    gamma = theta - eta                 (Earth-central angle between target and nadir),
    rho = (R + H) sin(gamma) / sin(theta)   (slant range).

Without Earth rotation the target lies at angular distance gamma from the orbit plane, which gives the
starting point; two Newton steps on (node longitude, u) then impose zero Doppler with rotation.

The look vector ``k = (T - S) / |T - S|`` is the propagation direction of the transmitted (down-going)
wave, the k of Quegan et al. (2018), eq. (3) (sign convention in e2esim.ionosphere.propagation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.orbit.frames import EARTH_MEAN_RADIUS, ecef_to_enu, from_ecef, to_ecef
from e2esim.orbit.sunsync import SunSynchronousOrbit, orbit_state


def side_looking_angles(incidence, orbit_radius, earth_radius=EARTH_MEAN_RADIUS):
    """(look angle eta, Earth-central angle gamma, slant range rho) for incidence theta (rad) at the
    target; radii in m. Spherical triangle of the module docstring."""
    incidence = np.asarray(incidence, float)
    eta = np.arcsin(earth_radius * np.sin(incidence) / orbit_radius)
    gamma = incidence - eta
    rho = orbit_radius * np.sin(gamma) / np.sin(incidence)
    return eta, gamma, rho


@dataclass(frozen=True)
class ViewGeometry:
    """Geometry of imaging targets, every array broadcast to one shape ``S`` (vectors ``S + (3,)``).

    target_ecef, satellite_ecef : Earth-fixed positions (m). velocity_ecef : Earth-relative satellite
    velocity (m/s). k_ecef : unit look vector satellite -> target. incidence : at the target (rad).
    u : argument of latitude (rad); node_lon : Earth-fixed node longitude at the instant (rad).
    local_time_h : local mean solar time at the target (h). heading : ground-track heading at the nadir
    point (rad, clockwise from north). look_azimuth : azimuth of the horizontal look direction at the
    target, from the target's point of view towards where the wave goes (rad, clockwise from north).
    k_enu : look vector in the target's (east, north, up) axes. valid : solution found (target reachable
    on this pass at this incidence).
    """

    target_ecef: np.ndarray
    satellite_ecef: np.ndarray
    velocity_ecef: np.ndarray
    k_ecef: np.ndarray
    incidence: np.ndarray
    u: np.ndarray
    node_lon: np.ndarray
    local_time_h: np.ndarray
    heading: np.ndarray
    look_azimuth: np.ndarray
    k_enu: np.ndarray
    valid: np.ndarray


def _residuals(orbit, target_unit, cos_gamma, node_lon, u):
    s, v = orbit_state(orbit, u, node_lon)
    t = target_unit * EARTH_MEAN_RADIUS
    d = t - s
    f1 = np.sum(target_unit * s, -1) / orbit.radius_m - cos_gamma
    f2 = np.sum(d * v, -1) / (np.linalg.norm(d, axis=-1) * np.linalg.norm(v, axis=-1))
    return f1, f2


def view_geometry(orbit: SunSynchronousOrbit, target_lat, target_lon, incidence, pass_name: str,
                  iterations: int = 6) -> ViewGeometry:
    """Solve the imaging geometry of targets (geocentric lat/lon, rad) at incidence (rad) on a pass.

    All inputs broadcast together. Targets the pass cannot see at that incidence are flagged
    ``valid = False`` (their numbers are NaN).
    """
    lat, lon, inc = np.broadcast_arrays(np.asarray(target_lat, float), np.asarray(target_lon, float),
                                        np.asarray(incidence, float))
    _, gamma, _ = side_looking_angles(inc, orbit.radius_m)
    tu = to_ecef(lat, np.zeros_like(lat), 1.0)  # target at longitude 0; rotated back at the end
    ci, si = np.cos(orbit.inclination_rad), np.sin(orbit.inclination_rad)
    side = orbit.side_sign
    # Start: no Earth rotation, T = cos(gamma) F + side sin(gamma) n with F on the orbit circle.
    x = (side * np.sin(gamma) - np.sin(lat) * ci) / (np.cos(lat) * si)
    with np.errstate(invalid="ignore"):
        base = np.arcsin(np.where(np.abs(x) <= 1, x, np.nan))
    candidates = []
    for node in (base, np.pi - base):
        n_hat = np.stack([si * np.sin(node), -si * np.cos(node), np.full_like(node, ci)], -1)
        foot = (tu - side * np.sin(gamma)[..., None] * n_hat) / np.cos(gamma)[..., None]
        node_vec = np.stack([np.cos(node), np.sin(node), np.zeros_like(node)], -1)
        quad = np.cross(n_hat, node_vec)
        u = np.arctan2(np.sum(foot * quad, -1), np.sum(foot * node_vec, -1))
        candidates.append((node, u))
    (n1, u1), (n2, u2) = candidates
    first_is_asc = np.cos(u1) >= np.cos(u2)
    want_asc = pass_name == "ascending"
    pick_first = first_is_asc if want_asc else ~first_is_asc
    node = np.where(pick_first, n1, n2)
    u = np.where(pick_first, u1, u2)
    cos_gamma = np.cos(gamma)
    h = 1e-7
    for _ in range(iterations):  # Newton on (node, u) with a finite-difference Jacobian
        f1, f2 = _residuals(orbit, tu, cos_gamma, node, u)
        a1, a2 = _residuals(orbit, tu, cos_gamma, node + h, u)
        b1, b2 = _residuals(orbit, tu, cos_gamma, node, u + h)
        j11, j21, j12, j22 = (a1 - f1) / h, (a2 - f2) / h, (b1 - f1) / h, (b2 - f2) / h
        det = j11 * j22 - j12 * j21
        with np.errstate(invalid="ignore", divide="ignore"):
            node = node - (j22 * f1 - j12 * f2) / det
            u = u - (-j21 * f1 + j11 * f2) / det
    s, v = orbit_state(orbit, u, node)
    t = tu * EARTH_MEAN_RADIUS
    f1, f2 = _residuals(orbit, tu, cos_gamma, node, u)
    d = t - s
    k = d / np.linalg.norm(d, axis=-1, keepdims=True)
    left = np.sum(np.cross(s, v) * (t - s), -1)  # > 0: target on the left of the velocity
    ok = np.isfinite(f1) & (np.abs(f1) < 1e-9) & (np.abs(f2) < 1e-9) & (side * left > 0)
    ok &= (np.cos(u) >= 0) == want_asc
    # rotate everything from "target at longitude 0" to the target's longitude
    rot = rotation_z(lon)
    s, v, t, k = (np.einsum("...ij,...j->...i", rot, a) for a in (s, v, t, k))
    node_lon = node + lon
    nadir_lat, nadir_lon, _ = from_ecef(s)
    v_enu = ecef_to_enu(v, nadir_lat, nadir_lon)
    k_enu = ecef_to_enu(k, lat, lon)
    local_time = np.mod(orbit.ltan_h + (lon - node_lon) * 12 / np.pi, 24.0)
    nan = np.where(ok, 1.0, np.nan)
    return ViewGeometry(
        target_ecef=t, satellite_ecef=s * nan[..., None], velocity_ecef=v * nan[..., None],
        k_ecef=k * nan[..., None], incidence=inc * nan, u=u * nan, node_lon=np.mod(node_lon + np.pi, 2 * np.pi) - np.pi,
        local_time_h=local_time * nan, heading=np.arctan2(v_enu[..., 0], v_enu[..., 1]) * nan,
        look_azimuth=np.arctan2(k_enu[..., 0], k_enu[..., 1]) * nan, k_enu=k_enu * nan[..., None], valid=ok,
    )


def rotation_z(angle):
    """Rotation matrices about the z axis by ``angle`` (rad), shape ``angle.shape + (3, 3)``."""
    c, s = np.cos(angle), np.sin(angle)
    z, o = np.zeros_like(c), np.ones_like(c)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


@dataclass(frozen=True)
class RayPoints:
    """Points where the line of sight target -> satellite crosses spherical shells.

    heights_m : shell heights (H,). position : Earth-fixed points (..., H, 3). lat, lon : geocentric
    (rad, (..., H)). zenith : angle between the local vertical and the ray there (rad). path_per_height :
    ds/dh = 1 / cos(zenith), the slant path length per unit height. k_enu : down-going look vector in
    the local (east, north, up) axes at each point (..., H, 3).
    """

    heights_m: np.ndarray
    position: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    zenith: np.ndarray
    path_per_height: np.ndarray
    k_enu: np.ndarray


def ray_points(target_ecef, satellite_ecef, heights_m, earth_radius=EARTH_MEAN_RADIUS) -> RayPoints:
    """Crossings of the ray from targets to satellites with shells at ``heights_m`` (m, 1-D).

    Solves ``|T + s e| = R + h`` for s > 0, ``e`` the unit vector from target to satellite; the ionospheric
    pierce point of a thin-shell model is the crossing at the shell height.
    """
    t = np.asarray(target_ecef, float)[..., None, :]
    s = np.asarray(satellite_ecef, float)[..., None, :]
    h = np.asarray(heights_m, float)
    e = (s - t) / np.linalg.norm(s - t, axis=-1, keepdims=True)
    te = np.sum(t * e, -1)
    tt = np.sum(t * t, -1)
    dist = -te + np.sqrt(te**2 - tt + (earth_radius + h) ** 2)
    p = t + dist[..., None] * e
    lat, lon, r = from_ecef(p)
    cos_z = np.sum(p * e, -1) / r
    k_enu = ecef_to_enu(np.broadcast_to(-e, p.shape), lat, lon)
    return RayPoints(h, p, lat, lon, np.arccos(np.clip(cos_z, -1, 1)), 1.0 / cos_z, k_enu)
