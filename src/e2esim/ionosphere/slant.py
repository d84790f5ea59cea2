"""Slant TEC and the Faraday path integral along a radar line of sight, three ways.

For a ray from target T to satellite S (heights 0 to H_sat; the ionosphere above the satellite does not
count), with N_e the electron density and k the down-going unit vector:

    STEC = int N_e ds,        F = int N_e (B.k) ds,        Omega = A F / f^2   (Quegan et al. 2018, eq. 3).

Methods (``METHODS``), all integrating from ``bottom_height_m`` to the satellite:

* ``thin_shell``: all electrons on a shell at ``shell_height_m``. VTEC is the vertical integral of the
  profile at the pierce point P; ``STEC = VTEC / cos(chi_P)`` (chi the zenith angle of the ray at P,
  the single-layer mapping function) and ``F = (B.k)(P) STEC``.
* ``pierce_profile``: the vertical profile at the pierce point, but B.k and the path length ds = dh/cos(chi)
  taken at each height along the ray (the ray's horizontal drift through the layer is ignored only for
  N_e).
* ``multilayer``: N_e evaluated at the ray's own position at every height (IRI at each crossing point, same
  UT): the reference; its cost is one IRI evaluation per layer.

B.k varies slowly along the ray; it is evaluated at nodes every ``field_step_m`` and interpolated linearly
in height (error below 1e-4 relative). Integrals are trapezoidal in height on a ``layer_step_m`` grid.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.geomag.field import FieldModel
from e2esim.ionosphere import iri
from e2esim.orbit.frames import EARTH_MEAN_RADIUS
from e2esim.orbit.geometry import ray_points

METHODS = ("thin_shell", "pierce_profile", "multilayer")


@dataclass(frozen=True)
class SlantSettings:
    """How the path integrals are computed.

    method : one of ``METHODS``. shell_height_m : thin-shell / pierce-point height (m).
    bottom_height_m : lowest height integrated (m; the IRI profile below 60 km holds under 1e-6 of the TEC).
        layer_step_m : height step of the integration (m). field_step_m : height step of
        the B.k nodes (m). field : geomagnetic field model. fof2_model : "ursi" or "ccir" foF2 maps.
    monthly_medians : use each date's monthly median IRI (a climatology) instead of PyIRI's interpolation
        between the monthly medians around the day.
    """

    method: str = "thin_shell"
    shell_height_m: float = 350e3
    bottom_height_m: float = 60e3
    layer_step_m: float = 10e3
    field_step_m: float = 50e3
    field: FieldModel = field(default_factory=FieldModel)
    fof2_model: str = "ursi"
    monthly_medians: bool = True

    def __post_init__(self):
        if self.method not in METHODS:
            raise PhysicsInputError(f"method {self.method!r} is not one of {', '.join(METHODS)}")
        if self.fof2_model not in iri.FOF2_MODELS:
            raise PhysicsInputError(f"foF2 model {self.fof2_model!r} is not one of {iri.FOF2_MODELS}")
        if not 0 < self.layer_step_m <= 100e3 or not 0 < self.field_step_m <= 200e3:
            raise PhysicsInputError("layer_step_m must be in (0, 100 km] and field_step_m in (0, 200 km]")


@dataclass(frozen=True)
class PathIntegrals:
    """Path integrals of N rays for each solar level, arrays of shape (n_solar, N).

    vtec : vertical TEC of the profile at the pierce point, bottom to satellite height (electrons/m^2).
    stec : slant TEC along the ray (electrons/m^2). faraday : F = int N_e B.k ds (T electrons/m^2).
    b_dot_k_pierce : B.k at the pierce point (T), shape (N,). pierce_zenith : (rad), shape (N,).
    f107 : F10.7 of each solar level (sfu). method : the method used.
    """

    vtec: np.ndarray
    stec: np.ndarray
    faraday: np.ndarray
    b_dot_k_pierce: np.ndarray
    pierce_zenith: np.ndarray
    f107: tuple
    method: str

    @property
    def effective_b_dot_k(self) -> np.ndarray:
        """F / STEC (T): the path-averaged B.k weighted by electron density."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.faraday / self.stec


def _heights(bottom: float, top: float, step: float) -> np.ndarray:
    n = max(int(np.ceil((top - bottom) / step)), 1)
    return np.linspace(bottom, top, n + 1)


def _trapezoid_weights(h: np.ndarray) -> np.ndarray:
    w = np.zeros_like(h)
    d = np.diff(h)
    w[:-1] += d / 2
    w[1:] += d / 2
    return w


def _b_dot_k_along(settings: SlantSettings, target, satellite, heights):
    """B.k (T) at every height of ``heights`` along each ray, (N, H), from nodes every field_step_m."""
    nodes = _heights(heights[0], heights[-1], settings.field_step_m)
    ray = ray_points(target, satellite, nodes)
    k = -(satellite - target) / np.linalg.norm(satellite - target, axis=-1, keepdims=True)
    bk = settings.field.b_dot_k(ray.position, k[:, None, :])
    j = np.clip(np.searchsorted(nodes, heights, side="right") - 1, 0, nodes.size - 2)
    frac = (heights - nodes[j]) / (nodes[j + 1] - nodes[j])
    return bk[:, j] * (1 - frac) + bk[:, j + 1] * frac


def path_integrals(target_ecef, satellite_ecef, dates, ut_h, f107_levels, settings: SlantSettings) -> PathIntegrals:
    """STEC, VTEC and Faraday path integrals of N rays (Earth-fixed target/satellite positions (N, 3), m)
    at one date (``datetime.date``) and UT (h) each, for every F10.7 in ``f107_levels`` (sfu)."""
    t = np.asarray(target_ecef, float).reshape(-1, 3)
    s = np.asarray(satellite_ecef, float).reshape(-1, 3)
    ut = np.asarray(ut_h, float).ravel()
    f107_levels = tuple(float(f) for f in f107_levels)
    top = float(np.min(np.linalg.norm(s, axis=-1))) - EARTH_MEAN_RADIUS
    if settings.shell_height_m >= top or settings.bottom_height_m >= settings.shell_height_m:
        raise PhysicsInputError(f"need bottom height < shell height {settings.shell_height_m / 1e3:g} km < satellite "
                                f"height {top / 1e3:.0f} km")
    heights = _heights(settings.bottom_height_m, top, settings.layer_step_m)
    w = _trapezoid_weights(heights)
    pierce = ray_points(t, s, np.array([settings.shell_height_m]))
    plat, plon = np.degrees(pierce.lat[:, 0]), np.degrees(pierce.lon[:, 0])
    k = -(s - t) / np.linalg.norm(s - t, axis=-1, keepdims=True)
    bk_pierce = settings.field.b_dot_k(pierce.position[:, 0], k)
    zen = pierce.zenith[:, 0]
    h_km = heights / 1e3
    params = iri.daily_parameters(dates, ut, plon, plat, f107_levels, settings.fof2_model, settings.monthly_medians)
    profiles = [iri.density_profiles(p, h_km) for p in params]  # (N, H) per level, at the pierce point
    vtec = np.stack([prof @ w for prof in profiles])
    if settings.method == "thin_shell":
        stec = vtec / np.cos(zen)
        return PathIntegrals(vtec, stec, stec * bk_pierce, bk_pierce, zen, f107_levels, settings.method)
    ray = ray_points(t, s, heights)
    ds = ray.path_per_height * w  # (N, H): path length per layer (m)
    bk = _b_dot_k_along(settings, t, s, heights)
    if settings.method == "pierce_profile":
        dens = profiles
    else:
        dens = _densities_along(ray, dates, ut, f107_levels, settings, h_km)
    stec = np.stack([np.sum(d * ds, -1) for d in dens])
    far = np.stack([np.sum(d * bk * ds, -1) for d in dens])
    return PathIntegrals(vtec, stec, far, bk_pierce, zen, f107_levels, settings.method)


def _densities_along(ray, dates, ut, f107_levels, settings, h_km) -> list:
    """N_e (N, H) at each ray's crossing of each height, for every solar level (IRI at each point)."""
    n, nh = ray.lat.shape
    lat = np.degrees(ray.lat).ravel()  # (N*H,) ordered point-major
    lon = np.degrees(ray.lon).ravel()
    uts = np.repeat(ut, nh)
    if isinstance(dates, (list, tuple, np.ndarray)):
        dates_rep = [d for d in dates for _ in range(nh)]
    else:
        dates_rep = dates
    params = iri.daily_parameters(dates_rep, uts, lon, lat, f107_levels, settings.fof2_model, settings.monthly_medians)
    out = []
    for p in params:
        dens = np.empty((n, nh))
        for j in range(nh):  # one height per call: pick that height's points
            idx = np.arange(n) * nh + j
            sub = tuple({kk: v[:, idx] for kk, v in d.items()} for d in p)
            dens[:, j] = iri.density_profiles(sub, h_km[j:j + 1])[:, 0]
        out.append(dens)
    return out


def vertical_tec_at(lat_deg, lon_deg, dates, ut_h, f107: float, top_height_m: float,
                    settings: SlantSettings) -> np.ndarray:
    """Vertical TEC (electrons/m^2) of the IRI profile at points, integrated from bottom_height_m to
    ``top_height_m`` (e.g. the satellite height)."""
    heights = _heights(settings.bottom_height_m, top_height_m, settings.layer_step_m)
    params = iri.daily_parameters(dates, ut_h, lon_deg, lat_deg, [f107], settings.fof2_model, settings.monthly_medians)
    return iri.density_profiles(params[0], heights / 1e3) @ _trapezoid_weights(heights)


def pierce_point_lat_lon(target_ecef, satellite_ecef, height_m) -> tuple:
    """(lat, lon) (rad) where rays cross the shell at ``height_m``."""
    ray = ray_points(target_ecef, satellite_ecef, np.array([height_m]))
    return ray.lat[..., 0], ray.lon[..., 0]


