"""Orbit modules on real orbits (kind ``orbit``, types ``orbit_file`` and ``biomass_orbit_file``).

The orbit comes from a file: an EO CFI state-vector file, the orbit group of a NISAR product or a two-line element
set (e2esim.orbit.real). Every zero-Doppler pass over the site in the acquisition window, on the radar's side and
inside the swath's incidence range, is one acquisition (e2esim.orbit.real.passes); its incidence, heading, look
vector, local time, date and pierce point come from the orbit. The ``AcquisitionGeometry`` is the one the circular
orbit fills, so the chain downstream does not change. Its ``orbit`` is the circular orbit equivalent to the file
(mean radius, inclination and local time of the ascending node at the first acquisition), for the modules that
need orbit parameters rather than the acquisitions (the scintillation screen's orbit height, the global Faraday
climatology's map). docs/orbits.md.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np

from e2esim import products as P
from e2esim.errors import PhysicsInputError
from e2esim.input_files import scenario_relative
from e2esim.module import Stage
from e2esim.orbit.acquisition import AcquisitionGeometry, Site
from e2esim.orbit.frames import EARTH_MEAN_RADIUS, EARTH_ROTATION_RATE, ecef_to_enu, from_ecef
from e2esim.orbit.geometry import ray_points
from e2esim.orbit.modules import PASS_CHOICES, SITE_PARAMS
from e2esim.orbit.real.eocfi import file_head, read_eocfi_orbit
from e2esim.orbit.real.nisar import read_nisar_orbit
from e2esim.orbit.real.passes import SURFACES, site_on_surface, site_passes
from e2esim.orbit.real.tle import TLETrajectory, read_tle
from e2esim.orbit.real.trajectory import Trajectory
from e2esim.orbit.sunsync import PASSES, SunSynchronousOrbit
from e2esim.params import Ordered, Param, with_defaults

FORMATS = ("auto", "eocfi", "nisar", "tle")
SUFFIXES = {".eof": "eocfi", ".xml": "eocfi", ".eef": "eocfi", ".h5": "nisar", ".hdf5": "nisar", ".he5": "nisar",
            ".tle": "tle", ".3le": "tle", ".txt": "tle"}


def orbit_format(path: Path) -> str:
    """The format of an orbit file from its suffix, else from its first bytes."""
    if path.suffix.lower() in SUFFIXES:
        return SUFFIXES[path.suffix.lower()]
    head = file_head(path, "orbit file")
    if head.startswith(b"\x89HDF"):
        return "nisar"
    return "eocfi" if head.lstrip().startswith(b"<") else "tle"


def read_orbit(path: Path, fmt: str = "auto", group: str | None = None) -> Trajectory:
    """The trajectory of an orbit file in format ``fmt`` (``FORMATS``; "auto": by suffix, else by content)."""
    fmt = orbit_format(path) if fmt == "auto" else fmt
    if fmt == "eocfi":
        return read_eocfi_orbit(path)
    if fmt == "nisar":
        return read_nisar_orbit(path, group)
    return read_tle(path)


def equivalent_circular_orbit(trajectory: Trajectory, t_s: float, look_side: str, radius_m: float):
    """The circular orbit of radius ``radius_m`` with the inclination and local time of the ascending node of
    ``trajectory``'s osculating orbit plane at ``t_s`` (inertial velocity v + omega_E z x r; node = z x h)."""
    r, v = trajectory.state(np.array([t_s]))
    r, v = r[0], v[0]
    v_inertial = v + EARTH_ROTATION_RATE * np.array([-r[1], r[0], 0.0])
    h = np.cross(r, v_inertial)
    inclination = float(np.arccos(h[2] / np.linalg.norm(h)))
    node_lon = np.arctan2(h[0], -h[1])  # longitude of z x h = (-h_y, h_x, 0)
    ut_h = float((trajectory.instant(t_s) - trajectory.instant(t_s).astype("datetime64[D]"))
                 / np.timedelta64(1, "h"))
    ltan = float(np.mod(ut_h + np.degrees(node_lon) / 15.0, 24.0))
    return SunSynchronousOrbit(radius_m - EARTH_MEAN_RADIUS, ltan, look_side, True, inclination)


def _datetime(text, key: str, trajectory: Trajectory) -> float:
    try:
        return float(trajectory.seconds(np.datetime64(dt.datetime.fromisoformat(str(text)), "ns")))
    except ValueError as exc:
        raise PhysicsInputError(f"{text!r} is not an ISO date and time (YYYY-MM-DDThh:mm:ss, UTC)", key=key) from exc


class OrbitFileModule(Stage):
    """A side-looking SAR on a real orbit read from a file, imaging one site: every zero-Doppler pass over the
    site in the acquisition window on the radar's side and inside the swath (module docstring)."""

    kind = "orbit"
    type_name = "orbit_file"
    summary = "real orbit from an EO CFI state-vector file, a NISAR orbit group or a TLE: the site's passes"
    params = (
        Param("file", "str", "orbit file, relative to the scenario file: EO CFI Earth_Observation_File XML, NISAR "
              "HDF5 product or orbit file, or a two-line element set (extra 'orbits')", input_file=True),
        Param("format", "str", "file format; auto: from the suffix (.EOF/.xml, .h5, .tle), else the content",
              default="auto", choices=FORMATS),
        Param("group", "str", "NISAR: HDF5 path of the orbit group; null: the one group named metadata/orbit",
              default=None, nullable=True),
        Param("start", "str", "start of the acquisition window (ISO date and time, UTC); null: the file's first "
              "state vector (a TLE: its epoch)", default=None, nullable=True),
        Param("end", "str", "end of the acquisition window (ISO, UTC); null: the file's last state vector (a TLE: "
              "3 days after its epoch, the BIOMASS repeat)", default=None, nullable=True),
        Param("look_side", "str", "side the radar looks to", default="left", choices=("left", "right")),
        Param("incidence_near_deg", "float", "incidence angle at near range", unit="deg", exclusive_minimum=0.0,
              exclusive_maximum=90.0),
        Param("incidence_far_deg", "float", "incidence angle at far range", unit="deg", exclusive_minimum=0.0,
              exclusive_maximum=90.0),
        Param("passes", "str", "passes that image the site", default="both", choices=PASS_CHOICES),
        Param("surface", "str", "where the site lies: wgs84 (the ellipsoid, where real orbits place the ground) or "
              "sphere (the mean sphere of the circular orbit's geometry)", default="wgs84", choices=SURFACES),
        Param("pierce_height_km", "float", "height of the ionospheric pierce points reported in the geometry",
              default=350.0, unit="km", minimum=50.0, maximum=2000.0),
        SITE_PARAMS,
        Ordered("incidence_near_deg", "incidence_far_deg"),
    )
    provides = (P.GEOMETRY,)

    def setup(self):
        c = self.si
        path = scenario_relative(c["file"], self.location.source)
        try:
            self.trajectory = read_orbit(path, c["format"], c["group"])
        except PhysicsInputError as exc:
            raise PhysicsInputError(str(exc), key=exc.key or "file") from exc
        traj = self.trajectory
        tle = isinstance(traj, TLETrajectory)  # no span of its own: the epoch and 3 days after it (BIOMASS repeat)
        if c["start"] is not None:
            start = _datetime(c["start"], "start", traj)
        else:
            start = 0.0 if tle else traj.start_s
        end = _datetime(c["end"], "end", traj) if c["end"] is not None else \
            min(start + 3 * 86400.0, traj.end_s) if tle else traj.end_s
        for key, value in (("start", start), ("end", end)):
            if not traj.start_s <= value <= traj.end_s:
                raise PhysicsInputError(
                    f"{traj.source}: the acquisition {key} {np.datetime_as_string(traj.instant(value), unit='s')} UTC "
                    f"is outside the orbit's span, {traj.span_text()}" + (" (a TLE is used within its epoch +- 7 days)"
                                                                         if tle else ""), key=key)
        if end <= start:
            raise PhysicsInputError(f"the acquisition window ends ({c['end']}) before it starts ({c['start']})",
                                    key="end")
        lon_deg = ((self.config["site"]["lon_deg"] + 180.0) % 360.0) - 180.0
        site = Site(c["site"]["name"], c["site"]["lat_rad"], np.radians(lon_deg))
        target, normal = site_on_surface(site.lat, site.lon, c["surface"])
        plane = equivalent_circular_orbit(traj, start, c["look_side"], float(np.linalg.norm(traj.state([start])[0])))
        choice = c["passes"]
        try:
            passes = PASSES if choice == "both" else (choice,) if choice in PASSES else (plane.pass_for_label(choice),)
        except PhysicsInputError as exc:
            raise PhysicsInputError(str(exc), key="passes") from exc
        found = site_passes(traj, target, normal, start, end, c["look_side"],
                            (c["incidence_near_rad"], c["incidence_far_rad"]), passes)
        if not found.t_s.size:
            raise PhysicsInputError(
                f"{traj.source}: the orbit does not image site {site.name} ({np.degrees(site.lat):.2f}, {lon_deg:.2f} "
                f"deg) on the {c['look_side']} side at incidence {np.degrees(c['incidence_near_rad']):g}-"
                f"{np.degrees(c['incidence_far_rad']):g} deg between "
                f"{np.datetime_as_string(traj.instant(start), unit='s')} and "
                f"{np.datetime_as_string(traj.instant(end), unit='s')} UTC ({found.rejected})", key="file")
        radius = float(np.mean(np.linalg.norm(found.satellite, axis=-1)))
        self.orbit = equivalent_circular_orbit(traj, float(found.t_s[0]), c["look_side"], radius)
        if c["pierce_height_m"] >= self.orbit.altitude_m:
            raise PhysicsInputError(f"pierce height {c['pierce_height_m'] / 1e3:g} km is not below the orbit "
                                    f"({self.orbit.altitude_m / 1e3:.1f} km)", key="pierce_height_km")
        self.geometry = acquisition_geometry(traj, site, target, found, self.orbit, c["pierce_height_m"])

    def forward(self, case):
        return {"geometry": self.geometry}


def acquisition_geometry(traj: Trajectory, site: Site, target, found, orbit: SunSynchronousOrbit,
                         pierce_height_m: float) -> AcquisitionGeometry:
    """The ``AcquisitionGeometry`` of the passes ``found`` (``passes.SitePasses``) of ``site`` at ``target``."""
    n = found.t_s.size
    when = traj.instant(found.t_s)
    ut_h = (when - when.astype("datetime64[D]")) / np.timedelta64(1, "h")
    local = when + np.round(np.degrees(site.lon) / 15.0 * 3600e9).astype("int64").astype("timedelta64[ns]")
    local_days = local.astype("datetime64[D]")
    days, date_index = np.unique(local_days, return_inverse=True)
    dates = tuple(dt.datetime.fromisoformat(str(d)) for d in days)
    targets = np.broadcast_to(target, (n, 3)).copy()
    d = targets - found.satellite
    k = d / np.linalg.norm(d, axis=-1, keepdims=True)
    nadir_lat, nadir_lon, _ = from_ecef(found.satellite)
    v_enu = ecef_to_enu(found.velocity, nadir_lat, nadir_lon)
    k_enu = ecef_to_enu(k, site.lat, site.lon)
    pass_name = np.where(found.ascending, "ascending", "descending")
    ray = ray_points(targets, found.satellite, np.array([pierce_height_m]))
    return AcquisitionGeometry(
        site=site, orbit=orbit, time_utc=when.astype("datetime64[s]"), date_index=date_index.reshape(-1),
        dates=dates, pass_name=pass_name, pass_label=np.array([orbit.pass_label(p) for p in pass_name]),
        phase=np.full(n, "period"), local_time_h=np.mod(ut_h + np.degrees(site.lon) / 15.0, 24.0), ut_h=ut_h,
        incidence=found.incidence, heading=np.arctan2(v_enu[:, 0], v_enu[:, 1]),
        look_azimuth=np.arctan2(k_enu[:, 0], k_enu[:, 1]), k_enu=k_enu, target_ecef=targets,
        satellite_ecef=found.satellite, pierce_height_m=float(pierce_height_m), pierce_lat=ray.lat[:, 0],
        pierce_lon=ray.lon[:, 0], pierce_zenith=ray.zenith[:, 0], k_enu_pierce=ray.k_enu[:, 0, :],
        weight=np.full(n, 1.0 / n))


class BiomassOrbitFile(OrbitFileModule):
    """ESA BIOMASS on a real orbit: left-looking, incidence 23 deg to 33.75 deg (as ``biomass_orbit``)."""

    type_name = "biomass_orbit_file"
    summary = "ESA BIOMASS on a real orbit (state vectors or TLE): left-looking, incidence 23-33.75 deg"
    params = with_defaults(OrbitFileModule.params, {"look_side": "left", "incidence_near_deg": 23.0,
                                                    "incidence_far_deg": 33.75})
