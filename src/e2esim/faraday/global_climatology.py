"""Global Faraday-rotation climatology on a latitude-longitude grid: maps of mean |Omega| and its SD.

Every grid cell is a target. For each pass, month (IRI monthly median on the 15th), solar level and
swath position the ray from the cell to the satellite gives the path integrals of
``e2esim.ionosphere.slant``; the acquisition geometry depends on latitude only and is rotated to every
longitude, and the UT of a cell is its local solar time of the pass minus longitude / 15 deg. The table
stores the frequency-independent integrals (F, STEC, VTEC), float32, shape
(pass, solar level, month, swath position, lat, lon); Omega at a frequency and its statistics over months,
swath positions and day-to-day variability are computed on demand. Cached in HDF5.
"""

from __future__ import annotations

import datetime as dt
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.faraday.climatology import settings_description
from e2esim.ionosphere.propagation import faraday_rotation_integral
from e2esim.ionosphere.slant import SlantSettings, path_integrals
from e2esim.ionosphere.variability import lognormal_nodes
from e2esim.orbit.geometry import rotation_z, view_geometry
from e2esim.orbit.sunsync import SunSynchronousOrbit


@dataclass(frozen=True)
class GlobalClimatology:
    """Path integrals on a global grid; see the module docstring.

    lat_deg (n_lat,), lon_deg (n_lon,) : cell centres. months : (12,) or fewer. passes : pass names;
    pass_labels : "dawn"/"dusk". f107 : solar levels (sfu). incidence_deg : swath positions.
    faraday, stec, vtec : float32 arrays (pass, solar, month, swath, lat, lon) of F (T electrons/m^2),
    slant and vertical TEC (electrons/m^2); NaN where the pass cannot see the cell.
    year : year of the dates. settings : the SlantSettings description. compute_s : seconds it took.
    """

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    months: tuple
    passes: tuple
    pass_labels: tuple
    f107: tuple
    incidence_deg: np.ndarray
    faraday: np.ndarray
    stec: np.ndarray
    vtec: np.ndarray
    year: int
    settings: dict = field(default_factory=dict)
    compute_s: float = float("nan")

    def omega(self, frequency_hz: float) -> np.ndarray:
        """Omega (rad) at the IRI median, same shape as ``faraday``."""
        return faraday_rotation_integral(self.faraday.astype(float), frequency_hz)

    def statistics(self, frequency_hz: float, variability: float = 0.25, nodes: int = 15,
                   months=None) -> dict:
        """Mean, SD and mean |Omega| (deg) per (pass, solar, lat, lon) over months, swath positions and
        day-to-day variability (log-normal factors X: E[X Omega] = E[X] E[Omega], etc.).

        months : subset of months (1-12) to pool (default all)."""
        om = self.omega(frequency_hz)
        if months is not None:
            om = om[:, :, [self.months.index(m) for m in months]]
        x = lognormal_nodes(variability, nodes)
        ex, ex2 = x.mean(), np.mean(x**2)
        axes = (2, 3)
        with np.errstate(invalid="ignore"):
            m1 = np.mean(om, axis=axes) * ex
            m2 = np.mean(om**2, axis=axes) * ex2
            mabs = np.mean(np.abs(om), axis=axes) * ex
        return {"mean_deg": np.degrees(m1), "sd_deg": np.degrees(np.sqrt(np.maximum(m2 - m1**2, 0))),
                "mean_abs_deg": np.degrees(mabs)}

    def latitude_profiles(self, frequency_hz: float, variability: float = 0.25, nodes: int = 15) -> dict:
        """Zonal means over longitude of mean |Omega| and SD (deg), arrays (pass, solar, lat)."""
        s = self.statistics(frequency_hz, variability, nodes)
        with warnings.catch_warnings():  # rows beyond the orbit's reach are all NaN
            warnings.simplefilter("ignore", RuntimeWarning)
            return {k: np.nanmean(v, axis=-1) for k, v in s.items()}


    def map(self, frequency_hz: float, variability: float = 0.25, nodes: int = 15) -> FaradayMap:
        """The statistics and latitude profiles at one radar frequency (product ``faraday.global_map``)."""
        return FaradayMap(self.lat_deg, self.lon_deg, self.passes, self.pass_labels, self.f107, float(frequency_hz),
                          float(variability), self.statistics(frequency_hz, variability, nodes),
                          self.latitude_profiles(frequency_hz, variability, nodes))


@dataclass(frozen=True)
class FaradayMap:
    """Maps of the Faraday-rotation climatology at one radar frequency, pooled over months, swath positions
    and day-to-day variability (product ``faraday.global_map``, drawn by the report).

    lat_deg, lon_deg : cell centres (deg). passes, pass_labels, f107 : the axes of the maps.
    frequency_hz : radar frequency. variability : coefficient of variation of TEC pooled in.
    statistics : "mean_deg", "sd_deg", "mean_abs_deg" -> arrays (pass, solar, lat, lon), deg.
    profiles : the same quantities' zonal means, arrays (pass, solar, lat), deg.
    """

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    passes: tuple
    pass_labels: tuple
    f107: tuple
    frequency_hz: float
    variability: float
    statistics: dict
    profiles: dict


def grid_axes(step_deg: float, lat_range=(-90.0, 90.0), lon_range=(-180.0, 180.0)) -> tuple:
    """Cell-centre latitudes and longitudes (deg) of a grid of square cells of ``step_deg`` covering
    ``lat_range`` x ``lon_range`` (deg; the whole globe by default, a latitude band or a region otherwise)."""
    if not (-90 <= lat_range[0] < lat_range[1] <= 90 and -180 <= lon_range[0] < lon_range[1] <= 360):
        raise PhysicsInputError(f"bad grid ranges: latitude {lat_range}, longitude {lon_range}")
    lat = np.arange(lat_range[0] + step_deg / 2, lat_range[1], step_deg)
    lon = np.arange(lon_range[0] + step_deg / 2, lon_range[1], step_deg)
    return lat, lon


def _grid_rays(orbit, lat_deg, lon_deg, incidence, passes):
    """Target/satellite positions (pass, swath, lat, lon, 3), UT (h) and validity of every cell."""
    out_t, out_s, out_ut, out_ok = [], [], [], []
    lon = np.radians(lon_deg)
    rot = rotation_z(lon)  # (n_lon, 3, 3)
    for p in passes:
        g = view_geometry(orbit, np.radians(lat_deg)[None, :], 0.0, incidence[:, None], p)  # (swath, lat)
        t = np.einsum("oij,slj->sloi", rot, g.target_ecef)
        s = np.einsum("oij,slj->sloi", rot, np.nan_to_num(g.satellite_ecef))
        ut = np.mod(g.local_time_h[:, :, None] - lon_deg[None, None, :] / 15.0, 24.0)
        out_t.append(t)
        out_s.append(s)
        out_ut.append(ut)
        out_ok.append(np.broadcast_to(g.valid[:, :, None], ut.shape))
    return np.stack(out_t), np.stack(out_s), np.stack(out_ut), np.stack(out_ok)


def _month_task(args):
    year, month, t, s, ut, ok, f107, settings = args
    n_solar = len(f107)
    shape = ok.shape
    res = {k: np.full((n_solar,) + shape, np.nan, np.float32) for k in ("faraday", "stec", "vtec")}
    if np.any(ok):
        pi = path_integrals(t[ok], s[ok], dt.date(year, month, 15), ut[ok], f107, settings)
        for k in res:
            res[k][:, ok] = getattr(pi, k)
    return month, res


def compute_global_climatology(orbit: SunSynchronousOrbit, step_deg: float = 2.0, months=range(1, 13),
                               passes=("ascending", "descending"), f107=(70.0, 180.0), incidence_deg=None,
                               settings: SlantSettings | None = None, year: int = 2026, executor=None,
                               progress=None, lat_range=(-90.0, 90.0),
                               lon_range=(-180.0, 180.0)) -> GlobalClimatology:
    """Compute the table (no cache; see ``global_climatology``). ``executor`` (a ``concurrent.futures``
    executor, or None to compute here) shares the months among processes; ``progress(iterable, total,
    description)`` reports them as they finish; ``lat_range``, ``lon_range`` (deg) restrict the grid to a
    latitude band or region."""
    settings = settings or SlantSettings()
    if incidence_deg is None:
        incidence_deg = (25.0, 28.4, 31.7)
    inc = np.radians(np.asarray(incidence_deg, float))
    lat, lon = grid_axes(step_deg, lat_range, lon_range)
    t, s, ut, ok = _grid_rays(orbit, lat, lon, inc, passes)
    months = tuple(int(m) for m in months)
    tasks = [(year, m, t, s, ut, ok, tuple(f107), settings) for m in months]
    start = time.perf_counter()
    done = executor.map(_month_task, tasks) if executor is not None else map(_month_task, tasks)
    if progress is not None:
        done = progress(done, len(tasks), "FR climatology (months)")
    results = dict(done)
    stack = {k: np.stack([results[m][k] for m in months], axis=2) for k in ("faraday", "stec", "vtec")}
    # (solar, pass, swath, lat, lon) per month -> (pass, solar, month, swath, lat, lon)
    stack = {k: np.moveaxis(v, 1, 0) for k, v in stack.items()}
    return GlobalClimatology(lat, lon, months, tuple(passes), tuple(orbit.pass_label(p) for p in passes),
                             tuple(float(f) for f in f107), np.asarray(incidence_deg, float), stack["faraday"],
                             stack["stec"], stack["vtec"], year, settings_description(settings),
                             time.perf_counter() - start)


def global_climatology(orbit: SunSynchronousOrbit, step_deg: float = 2.0, months=range(1, 13),
                       passes=("ascending", "descending"), f107=(70.0, 180.0), incidence_deg=None,
                       settings: SlantSettings | None = None, year: int = 2026, executor=None,
                       cache=None, progress=None, lat_range=(-90.0, 90.0),
                       lon_range=(-180.0, 180.0)) -> GlobalClimatology:
    """The table (global, or a latitude band / region with ``lat_range``, ``lon_range`` in deg), from ``cache``
    (an object with ``get`` and ``put``, e.g. ``e2esim.io.array_cache.ArrayCache``) if it holds it, else
    computed (``compute_global_climatology``) and stored there."""
    settings = settings or SlantSettings()
    if incidence_deg is None:
        incidence_deg = (25.0, 28.4, 31.7)
    desc = {"orbit": [orbit.altitude_m, orbit.ltan_h, orbit.look_side, orbit.earth_rotation, orbit.inclination_rad],
            "step_deg": step_deg, "months": list(months), "passes": list(passes), "f107": [float(f) for f in f107],
            "incidence_deg": [float(i) for i in incidence_deg], "year": year,
            "lat_range": [float(x) for x in lat_range], "lon_range": [float(x) for x in lon_range],
            "settings": settings_description(settings)}
    if cache is not None:
        stored = cache.get("global", desc, None, ("lat_deg", "lon_deg", "months", "f107", "incidence_deg", "faraday",
                                                  "stec", "vtec", "year"))
        if stored is not None:
            a = stored["attrs"]
            return GlobalClimatology(stored["lat_deg"], stored["lon_deg"], tuple(stored["months"].tolist()),
                                     tuple(passes), tuple(orbit.pass_label(p) for p in passes),
                                     tuple(stored["f107"].tolist()), stored["incidence_deg"], stored["faraday"],
                                     stored["stec"], stored["vtec"], int(a["year"]), desc["settings"],
                                     float(a.get("compute_s", np.nan)))
    clim = compute_global_climatology(orbit, step_deg, months, passes, f107, incidence_deg, settings, year, executor,
                                      progress, lat_range, lon_range)
    if cache is not None:
        cache.put("global", desc, None, {"lat_deg": clim.lat_deg, "lon_deg": clim.lon_deg,
                                         "months": np.array(clim.months), "f107": np.array(clim.f107),
                                         "incidence_deg": clim.incidence_deg, "faraday": clim.faraday,
                                         "stec": clim.stec, "vtec": clim.vtec},
                  {"year": year, "compute_s": clim.compute_s, "description": desc})
    return clim
