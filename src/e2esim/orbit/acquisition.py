"""The acquisitions of a site: every (date, pass, swath position) with its full geometry.

``AcquisitionGeometry`` is what the orbit module puts into ``CaseState.geometry`` and what the
ionosphere modules read.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.orbit.frames import EARTH_MEAN_RADIUS
from e2esim.orbit.geometry import RayPoints, ray_points, side_looking_angles, view_geometry
from e2esim.orbit.sunsync import PASSES, SunSynchronousOrbit


@dataclass(frozen=True)
class Site:
    """A target on the ground: name and geocentric latitude and longitude (rad) on the spherical Earth
    (``frames.EARTH_MEAN_RADIUS``; terrain height is not modelled)."""

    name: str
    lat: float
    lon: float

    def __post_init__(self):
        if not -np.pi / 2 <= self.lat <= np.pi / 2:
            raise PhysicsInputError(f"site latitude {np.degrees(self.lat):g} deg is outside [-90, 90]")


def swath_incidences(orbit: SunSynchronousOrbit, near: float, far: float, samples: int) -> np.ndarray:
    """Incidence angles (rad) at the centres of ``samples`` equal ground-range intervals between the
    near and far incidence (rad): a target is equally likely anywhere across the swath."""
    if not 0 < near < far < np.pi / 2:
        raise PhysicsInputError(
            f"need 0 < near < far < 90 deg incidence, got {np.degrees(near):g}, {np.degrees(far):g}")
    r_s, r_e = orbit.radius_m, EARTH_MEAN_RADIUS
    g0, g1 = side_looking_angles(np.array([near, far]), r_s)[1]
    gamma = g0 + (np.arange(samples) + 0.5) / samples * (g1 - g0)
    rho = np.sqrt(r_e**2 + r_s**2 - 2 * r_e * r_s * np.cos(gamma))
    return np.arccos((r_s * np.cos(gamma) - r_e) / rho)


@dataclass(frozen=True)
class AcquisitionGeometry:
    """Geometry of every acquisition of a site (Quegan et al. 2018, Sections 2, 3 and 6).

    Arrays have one entry per acquisition (shape (n,)), vectors shape (n, 3); acquisition i is
    (date i, pass i, swath position i).

    site : the target (``Site``). orbit : the ``SunSynchronousOrbit``.
    time_utc : acquisition instants, numpy datetime64[s], (n,).
    date_index : index into ``dates`` (the local calendar dates), (n,). dates : tuple of datetimes.
    pass_name : "ascending"/"descending", (n,). pass_label : "dawn"/"dusk"/"day"/"night", (n,).
    phase : mission phase of the date ("commissioning", ..., or "period"), (n,).
    local_time_h : local mean solar time at the target (h). ut_h : universal time of day (h).
    incidence : incidence angle at the target (rad). heading : ground-track heading at nadir (rad,
        clockwise from north, Earth rotation included). look_azimuth : azimuth of the horizontal look
        direction at the target (rad, clockwise from north).
    k_enu : unit look vector satellite -> target in the target's (east, north, up) axes, (n, 3).
    target_ecef, satellite_ecef : Earth-fixed positions (m), (n, 3).
    pierce_height_m : height of the reported ionospheric pierce points (m).
    pierce_lat, pierce_lon : geocentric latitude and longitude of the pierce point (rad).
    pierce_zenith : zenith angle of the ray at the pierce point (rad).
    k_enu_pierce : look vector in the pierce point's (east, north, up) axes, (n, 3).
    weight : probability weight of each acquisition (sums to 1).
    """

    site: Site
    orbit: SunSynchronousOrbit
    time_utc: np.ndarray
    date_index: np.ndarray
    dates: tuple
    pass_name: np.ndarray
    pass_label: np.ndarray
    phase: np.ndarray
    local_time_h: np.ndarray
    ut_h: np.ndarray
    incidence: np.ndarray
    heading: np.ndarray
    look_azimuth: np.ndarray
    k_enu: np.ndarray
    target_ecef: np.ndarray
    satellite_ecef: np.ndarray
    pierce_height_m: float
    pierce_lat: np.ndarray
    pierce_lon: np.ndarray
    pierce_zenith: np.ndarray
    k_enu_pierce: np.ndarray
    weight: np.ndarray

    @property
    def size(self) -> int:
        return int(self.incidence.size)

    def ray(self, heights_m) -> RayPoints:
        """Crossings of each acquisition's line of sight with shells at ``heights_m`` (m): (n, H) arrays."""
        return ray_points(self.target_ecef, self.satellite_ecef, heights_m)

    def months(self) -> np.ndarray:
        """Calendar month (1-12) of each acquisition's UTC instant."""
        return self.time_utc.astype("datetime64[M]").astype(int) % 12 + 1

    def describe(self) -> str:
        labels = ", ".join(sorted(set(self.pass_label.tolist())))
        return (f"{self.site.name} ({np.degrees(self.site.lat):.2f}, {np.degrees(self.site.lon):.2f} deg): "
                f"{len(self.dates)} dates, {labels}, incidence {np.degrees(self.incidence.min()):.1f}-"
                f"{np.degrees(self.incidence.max()):.1f} deg, local time {self.local_time_h.min():.2f}-"
                f"{self.local_time_h.max():.2f} h")


def acquisitions(orbit: SunSynchronousOrbit, site: Site, dates, passes, incidences, phases=None,
                 pierce_height_m: float = 350e3) -> AcquisitionGeometry:
    """Build the ``AcquisitionGeometry`` of a site for dates x passes x incidences.

    dates : local calendar dates (datetimes). passes : subset of ("ascending", "descending").
    incidences : swath incidence angles (rad). phases : mission phase label per date (default "period").
    Raises PhysicsInputError if the site is out of reach of a pass at every incidence.
    """
    dates = tuple(dates)
    if not dates:
        raise PhysicsInputError("no acquisition dates")
    phases = tuple(phases) if phases is not None else ("period",) * len(dates)
    inc = np.asarray(incidences, float)
    rows = []
    for p in passes:
        if p not in PASSES:
            raise PhysicsInputError(f"pass {p!r} is not one of {PASSES}")
        g = view_geometry(orbit, site.lat, site.lon, inc, p)
        if not np.all(g.valid):
            bad = np.degrees(inc[~g.valid])
            raise PhysicsInputError(
                f"site {site.name} at latitude {np.degrees(site.lat):.2f} deg is out of reach of the {p} pass at "
                f"incidence {', '.join(f'{b:.1f}' for b in bad)} deg (this orbit reaches "
                f"{90 - abs(90 - np.degrees(orbit.inclination_rad)):.1f} deg at nadir)"
            )
        rows.append((p, g))
    n_d, n_i = len(dates), inc.size
    fields: dict = {k: [] for k in ("date_index", "pass_name", "pass_label", "phase", "local_time_h", "incidence",
                                    "heading", "look_azimuth", "k_enu", "satellite_ecef", "target_ecef")}
    for p, g in rows:
        for d in range(n_d):
            fields["date_index"].append(np.full(n_i, d))
            fields["pass_name"].append(np.full(n_i, p, dtype=object))
            fields["pass_label"].append(np.full(n_i, orbit.pass_label(p), dtype=object))
            fields["phase"].append(np.full(n_i, phases[d], dtype=object))
            for key in ("local_time_h", "incidence", "heading", "look_azimuth"):
                fields[key].append(getattr(g, key))
            fields["k_enu"].append(g.k_enu)
            fields["satellite_ecef"].append(g.satellite_ecef)
            fields["target_ecef"].append(g.target_ecef)
    arr = {k: np.concatenate(v) for k, v in fields.items()}
    ut = np.mod(arr["local_time_h"] - np.degrees(site.lon) / 15.0, 24.0)
    day_offset = np.floor((arr["local_time_h"] - np.degrees(site.lon) / 15.0) / 24.0)
    base = np.array([np.datetime64(dates[i], "s") for i in arr["date_index"]])
    seconds = np.round((day_offset * 24 + ut) * 3600).astype("int64")
    time_utc = base + seconds.astype("timedelta64[s]")
    ray = ray_points(arr["target_ecef"], arr["satellite_ecef"], np.array([pierce_height_m]))
    n = arr["incidence"].size
    return AcquisitionGeometry(
        site=site, orbit=orbit, time_utc=time_utc, date_index=arr["date_index"], dates=dates,
        pass_name=arr["pass_name"].astype(str), pass_label=arr["pass_label"].astype(str),
        phase=arr["phase"].astype(str),
        local_time_h=arr["local_time_h"], ut_h=ut, incidence=arr["incidence"], heading=arr["heading"],
        look_azimuth=arr["look_azimuth"], k_enu=arr["k_enu"], target_ecef=arr["target_ecef"],
        satellite_ecef=arr["satellite_ecef"], pierce_height_m=float(pierce_height_m), pierce_lat=ray.lat[:, 0],
        pierce_lon=ray.lon[:, 0], pierce_zenith=ray.zenith[:, 0], k_enu_pierce=ray.k_enu[:, 0, :],
        weight=np.full(n, 1.0 / n),
    )


def date_from_iso(text: str) -> dt.datetime:
    try:
        return dt.datetime.fromisoformat(text)
    except ValueError as exc:
        raise PhysicsInputError(f"{text!r} is not an ISO date (YYYY-MM-DD)") from exc
