"""Where the mission does not acquire: the acquisition mask of a map sweep (``sweep.map.not_acquired``,
``not_acquired_polygon_deg``, ``not_acquired_file``; docs/user-guide.md, "Global maps").

A cell whose centre lies in the mask is **not acquired**: a fourth state beside pass, fail and not applicable. The
map sweep runs no case there; results.nc marks it (``not_acquired``, ``requirement<j>_state``), the maps show it,
and the share of the forest area meeting a requirement leaves it out, with the forest area left out stated
(``excluded_forest``).

The preset ``tracking_radars``: BIOMASS does not acquire where the space-object tracking radars (SOTR) operate,
"the N American continent, Europe and the Arctic" (Quegan et al. 2018, Section 1; the ITU Radio Regulations,
footnote 5.279A, make the mission's 432-438 MHz allocation secondary to radiolocation). No boundary of these zones
is published with the seeds, so the preset draws them from their words: North America (with Central America to
the Panama-Colombia border, the Caribbean and Greenland) and Europe (to the Urals, the Ural river, the Caspian and
the Caucasus, with Iceland and the Mediterranean islands) as coarse polygons, and the Arctic north of the Arctic
Circle (66.56 deg N). Their edges are uncertain by about 2-5 deg: the real zones follow the radars' lines of sight
and the mission's planning, not the continents' outlines, so cells near an edge may be acquired or not.
"""

from __future__ import annotations

import numpy as np

from e2esim.errors import ConfigError, Location, PhysicsInputError
from e2esim.input_files import scenario_relative
from e2esim.scene.lat_lon_raster import read_lat_lon_raster

EARTH_RADIUS_KM = 6371.0088
"""Mean radius of the Earth, R1 of GRS 80 (Moritz 2000, J. Geodesy 74, 128-133), for the cells' areas."""

ARCTIC_CIRCLE_DEG = 66.56
"""Latitude of the Arctic Circle (deg N, 2020 epoch): the Arctic of the tracking-radar preset."""

NORTH_AMERICA = ((-170.0, 50.0), (-170.0, 72.0), (-125.0, 76.0), (-75.0, 84.0), (-10.0, 84.0), (-10.0, 70.0),
                 (-45.0, 58.0), (-50.0, 45.0), (-65.0, 38.0), (-58.0, 16.0), (-58.5, 12.6), (-76.0, 12.6),
                 (-77.4, 8.6), (-77.9, 7.2), (-83.0, 6.5), (-93.0, 13.0), (-106.0, 18.0), (-118.0, 28.0),
                 (-128.0, 40.0), (-135.0, 52.0), (-160.0, 52.0))
"""(lon, lat) vertices (deg) of North America, Central America and the Caribbean, Greenland: the tracking-radar
preset (module docstring)."""

EUROPE = ((-32.0, 36.3), (-32.0, 68.0), (-10.0, 72.0), (30.0, 72.0), (66.0, 70.0), (60.0, 60.0), (59.0, 51.5),
          (52.0, 47.0), (49.5, 41.3), (40.0, 43.5), (29.1, 40.9), (26.2, 40.3), (26.5, 38.0), (28.5, 35.8),
          (23.0, 34.5), (14.0, 35.5), (11.7, 37.4), (8.0, 38.5), (0.0, 37.5), (-5.6, 36.0), (-7.0, 36.3))
"""(lon, lat) vertices (deg) of Europe with Iceland: to the Urals (60 E), the Ural river, the Caspian and the
Caucasus, the Bosporus and the Mediterranean (module docstring)."""

PRESETS = ("none", "tracking_radars")
PRESET_TEXT = {"tracking_radars": "the space-object tracking radar zones: North America, Europe and the Arctic "
                                  "(Quegan et al. 2018, Section 1; e2esim's polygons, edges uncertain by 2-5 deg)"}
RASTER_VARIABLE = "not_acquired"
"""The variable of a mask file: 1 where the mission does not acquire, 0 where it does."""


def in_polygon(lon, lat, vertices) -> np.ndarray:
    """True where the points (deg, broadcast) lie inside the polygon of (lon, lat) ``vertices`` (even-odd rule,
    straight edges in longitude and latitude; O'Rourke 1998, Computational Geometry in C, Section 7.4)."""
    x, y = np.broadcast_arrays(np.asarray(lon, float), np.asarray(lat, float))
    v = np.asarray(vertices, float)
    inside = np.zeros(x.shape, bool)
    for (x0, y0), (x1, y1) in zip(v, np.roll(v, -1, axis=0)):
        crosses = (y0 > y) != (y1 > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            at = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
        inside ^= crosses & (x < at)
    return inside


def polygon_vertices(flat, where: Location) -> tuple:
    """(lon, lat) pairs of ``not_acquired_polygon_deg`` (lon1, lat1, lon2, lat2, ...), at least three."""
    values = [float(v) for v in flat]
    if len(values) % 2 or len(values) < 6:
        raise ConfigError(where, f"{len(values)} numbers do not make a polygon", "give at least three vertices as "
                          "lon1, lat1, lon2, lat2, lon3, lat3, ... (degrees)")
    pairs = tuple(zip(values[::2], values[1::2]))
    bad = next((p for p in pairs if not (-180.0 <= p[0] <= 360.0 and -90.0 <= p[1] <= 90.0)), None)
    if bad is not None:
        raise ConfigError(where, f"the vertex {list(bad)} is off the globe", "longitudes -180 to 360, latitudes "
                          "-90 to 90 degrees")
    return pairs


def not_acquired_cells(m: dict, lat, lon, where: Location) -> np.ndarray:
    """Cells (n_lat, n_lon) whose centres lie in the acquisition mask of the validated ``sweep.map`` ``m``: the
    preset, the user's polygon and the user's raster together; ``where`` is ``sweep.map`` (its source the
    scenario file, against which a relative mask file is found)."""
    lat2, lon2 = np.meshgrid(np.asarray(lat, float), np.mod(np.asarray(lon, float) + 180.0, 360.0) - 180.0,
                             indexing="ij")
    mask = np.zeros(lat2.shape, bool)
    if m.get("not_acquired", "none") == "tracking_radars":
        mask |= in_polygon(lon2, lat2, NORTH_AMERICA) | in_polygon(lon2, lat2, EUROPE) | (lat2 > ARCTIC_CIRCLE_DEG)
    if m.get("not_acquired_polygon_deg"):
        vertices = polygon_vertices(m["not_acquired_polygon_deg"], where.child("not_acquired_polygon_deg"))
        mask |= in_polygon(lon2, lat2, vertices) | in_polygon(lon2 + 360.0, lat2, vertices)
    if m.get("not_acquired_file"):
        path = scenario_relative(m["not_acquired_file"], where.source)
        try:
            raster = read_lat_lon_raster(path, RASTER_VARIABLE, "acquisition mask", 0.0, 1.0)
        except PhysicsInputError as exc:
            raise ConfigError(where.child("not_acquired_file"), str(exc), "a NetCDF file with a variable "
                              f"'{RASTER_VARIABLE}' (1: not acquired, 0: acquired) over lat and lon") from exc
        mask |= raster.lookup(lat2, lon2, outside=0.0) > 0.5
    return mask


def describe_mask(m: dict) -> str:
    """The acquisition mask of ``m`` in words ("" when there is none)."""
    parts = [PRESET_TEXT[m["not_acquired"]]] if m.get("not_acquired", "none") != "none" else []
    if m.get("not_acquired_polygon_deg"):
        parts.append(f"a polygon of {len(m['not_acquired_polygon_deg']) // 2} vertices (not_acquired_polygon_deg)")
    if m.get("not_acquired_file"):
        parts.append(f"the raster {m['not_acquired_file']} (variable {RASTER_VARIABLE})")
    return "; ".join(parts)


def cell_area_km2(lat, step_deg: float) -> np.ndarray:
    """Area (km^2) of a cell of ``step_deg`` x ``step_deg`` centred at each latitude ``lat`` (deg): R^2 dlon
    (sin(lat + step/2) - sin(lat - step/2)), on a sphere of the Earth's mean radius."""
    half = np.radians(step_deg) / 2.0
    lat_rad = np.radians(np.asarray(lat, float))
    north, south = np.minimum(lat_rad + half, np.pi / 2), np.maximum(lat_rad - half, -np.pi / 2)
    return EARTH_RADIUS_KM ** 2 * np.radians(step_deg) * (np.sin(north) - np.sin(south))


def excluded_forest(not_acquired, swept, forest_fraction, lat, step_deg: float) -> dict:
    """What the mask leaves out of the map: the number of forest cells not acquired, their forest area (km^2) and
    its share of the forest area of the map (the swept cells' and theirs, cells weighted by area times forest
    fraction)."""
    forest = np.nan_to_num(np.asarray(forest_fraction, float)) * cell_area_km2(lat, step_deg)[:, None]
    out_km2 = float(np.sum(np.where(not_acquired, forest, 0.0)))
    total = out_km2 + float(np.sum(np.where(swept, forest, 0.0)))
    return {"cells": int(np.count_nonzero(not_acquired)), "forest_area_km2": out_km2,
            "forest_area_fraction": out_km2 / total if total > 0 else 0.0}


__all__ = ["ARCTIC_CIRCLE_DEG", "EARTH_RADIUS_KM", "EUROPE", "NORTH_AMERICA", "PRESETS", "RASTER_VARIABLE",
           "cell_area_km2", "describe_mask", "excluded_forest", "in_polygon", "not_acquired_cells",
           "polygon_vertices"]
