"""Map sweeps: ``sweep: {map: ...}``, every forest cell of a latitude-longitude grid x months x passes x solar
levels, as sweep cases of plain values (docs/user-guide.md, "Global maps").

The grid is that of the global climatology (``e2esim.faraday.global_climatology.grid_axes``): square cells of
``step_deg`` over ``lat_range_deg`` x ``lon_range_deg``. A cell is kept when it is land (at least
``min_land_percent`` of it, GSHHG shoreline: ``e2esim.scene.land_mask``), when at least ``min_forest_percent``
of it is forest in the land-cover product ``forest_cover`` (MODIS 2019 IGBP classes:
``e2esim.scene.forest_cover``; deserts, ice and water are never forest) and, with ``forest_only``, when the
scenario's scene (type ``agb_map``) gives it a forest class (``e2esim.scene.map_forest``), and when the mission
acquires it (``not_acquired``: a cell in the acquisition mask, ``e2esim.maps.acquisition``, is "not acquired",
``MapGrid.not_acquired``, and has no case). A cell stands for
its forest area (its area times its forest fraction) in the share of the forest that meets a requirement
(``e2esim.maps.netcdf``). Each case sets

    scene.lat_deg, scene.lon_deg, ionosphere.lat_deg, ionosphere.lon_deg    the cell centre (deg)
    ionosphere.month, ionosphere.pass, ionosphere.solar                        when

so the scene looks up the cell's forest and the ionosphere (type ``global_climatology``) its Faraday rotation in
the climatology table: everything that scales with the globe is computed once, before or outside the cases.
Cases run solar level by solar level, month by month, pass by pass, cells in rows of latitude (south to north)
and longitude (west to east), so that the cases of one climatology table follow each other.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim import registry
from e2esim.errors import ConfigError, Location, ModuleLookupError
from e2esim.extras import require_extra
from e2esim.faraday.global_climatology import grid_axes
from e2esim.limits import MAX_MAP_CASES, check_count
from e2esim.maps.acquisition import PRESETS, not_acquired_cells
from e2esim.module import takes_services
from e2esim.params import Ordered, Param, find_param, validate_section
from e2esim.scene.forest_cover import DEFAULT_FOREST_GROUPS, FOREST_GROUPS, PRODUCTS

MONTHS = tuple(range(1, 13))

MAP_PARAMS = (
    Param("step_deg", "float", "cell size of the grid (square cells; the ionosphere's grid_step_deg must equal it)",
          default=1.0, unit="deg", minimum=0.1, maximum=30.0, convert=False),
    Param("lat_range_deg", "float", "latitudes of the grid: [south, north]", default=(-90.0, 90.0), unit="deg",
          length=2, minimum=-90.0, maximum=90.0, convert=False),
    Param("lon_range_deg", "float", "longitudes of the grid: [west, east]", default=(-180.0, 180.0), unit="deg",
          length=2, minimum=-180.0, maximum=360.0, convert=False),
    Param("land_only", "bool", "keep land cells only (GSHHG shoreline)", default=True),
    Param("min_land_percent", "float", "share of a cell that must be land for it to count as land", default=50.0,
          unit="%", exclusive_minimum=0.0, maximum=100.0, convert=False),
    Param("forest_cover", "str", "land-cover product that says where forest is: modis_igbp_2019 (MODIS MCD12C1 "
          "2019, IGBP classes; e2esim.scene.forest_cover), or none (every land cell counts as wholly forest)",
          default="modis_igbp_2019", choices=PRODUCTS + ("none",)),
    Param("forest_classes", "str", "IGBP class groups of forest_cover that count as forest: forests (classes 1-5), "
          "woody_savannas (8), savannas (9)", default=DEFAULT_FOREST_GROUPS, variable_length=True,
          choices=FOREST_GROUPS),
    Param("min_forest_percent", "float", "share of a cell that must be forest (forest_cover) for it to be swept",
          default=1.0, unit="%", exclusive_minimum=0.0, maximum=100.0, convert=False),
    Param("forest_only", "bool", "keep only cells the scene (type agb_map) gives a forest class: in its latitude "
          "bands, and forest in its AGB map", default=True),
    Param("months", "int", "months of the year", default=MONTHS, variable_length=True, minimum=1, maximum=12),
    Param("passes", "str", "passes", default=("dawn", "dusk"), variable_length=True,
          choices=("dawn", "dusk", "ascending", "descending")),
    Param("solar", "str", "solar activity levels (min: F10.7 70 sfu, max: 180 sfu, f107: the ionosphere's f107_sfu)",
          default=("max",), variable_length=True, choices=("min", "max", "f107")),
    Param("not_acquired", "str", "where the mission does not acquire (cells left out as 'not acquired'): none, or "
          "tracking_radars (North America, Europe and the Arctic; e2esim.maps.acquisition)", default="none",
          choices=PRESETS),
    Param("not_acquired_polygon_deg", "float", "a polygon of cells not acquired: lon1, lat1, lon2, lat2, ... (deg, "
          "at least three vertices)", default=None, nullable=True, variable_length=True, unit="deg", convert=False),
    Param("not_acquired_file", "str", "NetCDF raster of cells not acquired: variable not_acquired (1 not acquired, "
          "0 acquired) over lat and lon", default=None, nullable=True, input_file=True),
    Ordered("lat_range_deg"),
    Ordered("lon_range_deg"),
)

LAT_KEYS = ("scene.lat_deg", "ionosphere.lat_deg")
LON_KEYS = ("scene.lon_deg", "ionosphere.lon_deg")
MONTH_KEY, PASS_KEY, SOLAR_KEY = "ionosphere.month", "ionosphere.pass", "ionosphere.solar"
MAP_KEYS = (LAT_KEYS[0], LON_KEYS[0], LAT_KEYS[1], LON_KEYS[1], MONTH_KEY, PASS_KEY, SOLAR_KEY)
"""The sweep keys of a map sweep, in order."""


@dataclass(frozen=True)
class MapGrid:
    """The grid of a map sweep: cell-centre axes (deg), the land and forest fractions of each cell (n_lat,
    n_lon; NaN without land_only, 1 without forest_cover), which cells are swept (bool, n_lat x n_lon), and the
    months, passes and solar levels; ``seen`` (pass -> bool per latitude): the latitudes each pass of the
    ionosphere's orbit sees (all, without a global_climatology)."""

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    step_deg: float
    land_fraction: np.ndarray
    forest_fraction: np.ndarray
    swept: np.ndarray
    months: tuple
    passes: tuple
    solar: tuple
    seen: dict
    not_acquired: np.ndarray | None = None
    """Cells (bool, n_lat x n_lon) that would be swept but lie in the acquisition mask (none swept)."""


def map_section(sweep) -> dict | None:
    """The ``map`` mapping of a sweep section, or None when the sweep is not a map sweep."""
    if isinstance(sweep, dict) and isinstance(sweep.get("map"), dict):
        return sweep["map"]
    return None


def is_map_sweep(scenario) -> bool:
    """True for a resolved scenario (or its raw dict) whose sweep is a map sweep."""
    raw = getattr(scenario, "raw", scenario)
    return isinstance(raw, dict) and map_section(raw.get("sweep")) is not None


def map_grid(section, where: Location, scenario: dict | None = None, services=None) -> MapGrid:
    """Validate ``sweep.map`` and build its grid; ``scenario`` (the raw scenario) gives the scene's forest, its
    stage's ``map_cells`` handed ``services`` (or None) where it takes them."""
    if not isinstance(section, dict):
        raise ConfigError(where, f"{section!r} is not a mapping", "expected step_deg, lat_range_deg, months, ...")
    m = validate_section(MAP_PARAMS, section, where)
    lat, lon = map_axes(m)
    if lat.size == 0 or lon.size == 0:
        raise ConfigError(where.child("step_deg"), f"{m['step_deg']:g} deg is larger than the grid's ranges",
                          "give a step that fits lat_range_deg and lon_range_deg")
    check_count("grid cells", lat.size * lon.size, MAX_MAP_CASES, where.describe())
    require_extra("maps", "a map sweep (sweep.map)")
    if m["land_only"]:
        from e2esim.scene.land_mask import land_fraction  # lazy: start-up time of runs without a map

        land = land_fraction(lat, lon, m["step_deg"])
        swept = land >= m["min_land_percent"] / 100.0
    else:
        land = np.full((lat.size, lon.size), np.nan)
        swept = np.ones((lat.size, lon.size), bool)
    forest = cell_forest_fraction(m, lat, lon)
    if m["forest_cover"] != "none":
        swept &= (forest > 0) & (forest >= m["min_forest_percent"] / 100.0)
    passes = tuple(dict.fromkeys(m["passes"]))
    seen = {p: np.ones(lat.size, bool) for p in passes}
    if scenario is not None:
        _check_sections(scenario, m, where)
        if m["forest_only"]:
            swept &= _forest_cells(scenario, lat, lon, where, services)
        seen = _seen_latitudes(scenario, lat, passes, where) or seen
    not_acquired = swept & not_acquired_cells(m, lat, lon, where)
    swept &= ~not_acquired
    return MapGrid(lat, lon, float(m["step_deg"]), land, forest, swept, tuple(dict.fromkeys(m["months"])), passes,
                   tuple(dict.fromkeys(m["solar"])), seen, not_acquired)


def map_axes(m: dict) -> tuple:
    """(lat, lon): the cell centres (deg) of the validated ``sweep.map`` ``m``, rounded to 1e-9 deg as the cases'
    cells are (the grid of the global climatology, ``e2esim.faraday.global_climatology.grid_axes``)."""
    lat, lon = grid_axes(m["step_deg"], tuple(m["lat_range_deg"]), tuple(m["lon_range_deg"]))
    return np.round(lat, 9), np.round(lon, 9)


def map_settings(section, where: Location | None = None) -> dict:
    """``sweep.map`` validated and complete with its defaults."""
    return validate_section(MAP_PARAMS, section, where or Location(key_path=("sweep", "map")))


def cell_forest_fraction(m: dict, lat, lon) -> np.ndarray:
    """Forest share (0-1) of each cell (n_lat, n_lon) in the land-cover product of the validated ``sweep.map``
    ``m``; 1 everywhere with ``forest_cover: none``."""
    if m["forest_cover"] == "none":
        return np.ones((np.size(lat), np.size(lon)))
    from e2esim.scene.forest_cover import forest_fraction  # lazy: start-up time of runs without a map

    return forest_fraction(lat, lon, m["step_deg"], tuple(dict.fromkeys(m["forest_classes"])))


def map_table(section, where: Location, scenario: dict | None = None, services=None) -> tuple:
    """``sweep.map`` -> its cases (module docstring) as (groups, positions): four groups of keys (the cell, the
    month, the pass, the solar level), each (keys, values) with one tuple of values per position, and per case the
    position of each group ((n, 4) int array); nothing else is stored per case. ``e2esim.runner.sweep`` makes them
    the sweep's ``SweepTable`` (layout "map")."""
    grid = map_grid(section, where, scenario, services)
    i, j = np.nonzero(grid.swept)
    n = i.size * len(grid.months) * len(grid.passes) * len(grid.solar)
    if n == 0:
        raise ConfigError(where, "no cell of the grid is swept (no land, or no forest, in the region, or none "
                          "acquired)",
                          "widen lat_range_deg / lon_range_deg, lower min_forest_percent, or set land_only or "
                          "forest_only to false or forest_cover to none")
    check_count("map sweep cases", n, MAX_MAP_CASES, where.describe())
    lat, lon = grid.lat_deg[i].tolist(), grid.lon_deg[j].tolist()
    cells = (LAT_KEYS[:1] + LON_KEYS[:1] + LAT_KEYS[1:] + LON_KEYS[1:],
             tuple((la, lo, la, lo) for la, lo in zip(lat, lon)))
    seen = {p: np.nonzero(grid.seen[p][i])[0] for p in grid.passes}  # cell positions each pass sees
    parts = []
    for s, _ in enumerate(grid.solar):
        for m, _ in enumerate(grid.months):
            for p, pass_name in enumerate(grid.passes):
                c = seen[pass_name]
                parts.append(np.stack([c, np.full(c.size, m), np.full(c.size, p), np.full(c.size, s)], axis=-1))
    table = np.concatenate(parts).astype(np.int64)
    if not len(table):
        raise ConfigError(where, "no swept cell is seen by the passes of the ionosphere's orbit",
                          "restrict lat_range_deg to latitudes the orbit reaches")
    groups = (cells, ((MONTH_KEY,), tuple((m,) for m in grid.months)),
              ((PASS_KEY,), tuple((p,) for p in grid.passes)), ((SOLAR_KEY,), tuple((s,) for s in grid.solar)))
    return groups, table


def grid_of_section(section) -> tuple:
    """(lat, lon, step_deg, land fraction, forest fraction, settings) of a ``sweep.map`` (validated): the cell
    centres (deg, rounded as the cases' are), the land fraction of each cell (NaN without land_only) and its
    forest fraction (1 with forest_cover none), as results.nc stores them beside the cases' values."""
    m = map_settings(section)
    step = float(m["step_deg"])
    lat, lon = map_axes(m)
    if m["land_only"]:
        from e2esim.scene.land_mask import land_fraction  # lazy: loaded for a map only

        land = land_fraction(lat, lon, step)
    else:
        land = np.full((lat.size, lon.size), np.nan)
    return lat, lon, step, land, cell_forest_fraction(m, lat, lon), m


def forest_cover_citation() -> str:
    """The source of the land-cover product (``e2esim.scene.forest_cover``), for results.nc."""
    from e2esim.scene.forest_cover import citation  # lazy: loaded for a map only

    return citation()


def _section_class(scenario: dict, kind: str, where: Location):
    raw = scenario.get(kind)
    type_name = raw.get("type") if isinstance(raw, dict) else None
    if not isinstance(type_name, str):
        return None, {}
    try:
        return registry.lookup(kind, type_name), raw
    except ModuleLookupError:
        return None, raw  # reported where the section is resolved


def _check_sections(scenario: dict, m: dict, where: Location) -> None:
    """The scene and ionosphere must take the cell (and the ionosphere the month, pass and solar level), and
    the climatology table must have the map's cells."""
    for kind, keys, advice in (("scene", LAT_KEYS[:1] + LON_KEYS[:1], "agb_map"),
                               ("ionosphere", (LAT_KEYS[1], LON_KEYS[1], MONTH_KEY, PASS_KEY, SOLAR_KEY),
                                "global_climatology")):
        cls, _ = _section_class(scenario, kind, where)
        if cls is None:
            if kind not in scenario:
                raise ConfigError(Location(where.source, (kind,), where.lines), "section is missing",
                                  f"a map sweep needs a '{kind}:' section of type {advice}")
            continue
        missing = [k for k in keys if find_param(cls.params, k.split(".", 1)[1]) is None]
        if missing:
            raise ConfigError(Location(where.source, (kind, "type"), where.lines),
                              f"{cls.type_name!r} has no parameter {missing[0].split('.', 1)[1]!r}, which a map sweep "
                              f"sets ({', '.join(keys)})", f"use {kind} type {advice}")
    cls, raw = _section_class(scenario, "ionosphere", where)
    if cls is not None and cls.type_name == "global_climatology":
        step = raw.get("grid_step_deg", 1.0)
        if isinstance(step, (int, float)) and not np.isclose(step, m["step_deg"]):
            raise ConfigError(Location(where.source, ("ionosphere", "grid_step_deg"), where.lines),
                              f"{step!r} differs from the map's step_deg {m['step_deg']:g}",
                              "set them equal, so that each map cell is one cell of the climatology table")
        for key, default, full in (("lat", (-90.0, 90.0), 180.0), ("lon", (-180.0, 180.0), 360.0)):
            table = raw.get(f"table_{key}_range_deg", default)
            want = m[f"{key}_range_deg"]
            if _pair(table) and table[1] - table[0] < full and (want[0] < table[0] or want[1] > table[1]):
                raise ConfigError(Location(where.source, ("ionosphere", f"table_{key}_range_deg"), where.lines),
                                  f"{list(table)} does not cover the map's {key}_range_deg {list(want)}",
                                  "let the climatology table cover the map (or leave the table global)")


def _pair(value) -> bool:
    return isinstance(value, (list, tuple)) and len(value) == 2 and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)


def _seen_latitudes(scenario: dict, lat, passes, where: Location) -> dict | None:
    """pass -> latitudes (bool) the ionosphere's orbit sees (its stage's ``map_latitudes_seen``); None where it
    has no orbit."""
    cls, raw = _section_class(scenario, "ionosphere", where)
    if cls is None:
        return None
    return cls.map_latitudes_seen(raw, lat, passes, Location(where.source, ("ionosphere",), where.lines))


def _forest_cells(scenario: dict, lat, lon, where: Location, services=None) -> np.ndarray:
    """Cells (n_lat, n_lon) the scenario's scene gives a forest (its stage's ``map_cells``, handed ``services``
    where its signature takes them: a plug-in's hook of the older four-argument form keeps working; all where it
    says nothing)."""
    cls, raw = _section_class(scenario, "scene", where)
    cells = None
    if cls is not None:
        extra = {"services": services} if takes_services(cls.map_cells) else {}
        cells = cls.map_cells(raw, lat, lon, Location(where.source, ("scene",), where.lines), **extra)
    return np.ones((lat.size, lon.size), bool) if cells is None else cells
