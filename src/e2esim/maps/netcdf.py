"""results.nc: the results of a map sweep as a CF-1.8 NetCDF dataset on its grid (docs/output-format.md).

Every output scalar of the cases becomes a variable over (solar, pass, month, lat, lon), NaN where a cell is not
swept (ocean, no forest) or a case lacks it, with ``units`` (UDUNITS), ``long_name``, ``standard_name`` where CF
has one, and ``e2esim_name``/``e2esim_units`` (the name and unit of results.h5). Besides them: the land and
forest fractions of each cell (``e2esim.scene.land_mask``, ``e2esim.scene.forest_cover``), its area weight (cos
latitude), its forest-area weight (area weight times forest fraction) and, per requirement, the share of the
swept forest area that meets it in each month, pass and solar level: a cell counts by its forest area. The
dataset is built from the columns of a run (``map_dataset``, from a ``Results`` or, for the run in this process,
``map_dataset_of``, which keeps it with the run), which the report's maps also draw, and written atomically
(``write_map_netcdf``). The grid, its land and its forest come from ``e2esim.maps.grid``.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
from dataclasses import dataclass

import numpy as np

from e2esim.atomic import atomic_path
from e2esim.case import Services
from e2esim.errors import ConfigError, Location, PhysicsInputError, one_line
from e2esim.extras import optional_import
from e2esim.io.scalar_units import scalar_description, scalar_unit
from e2esim.io.swept_netcdf import swept_chunk_sizes, write_swept_netcdf
from e2esim.maps.acquisition import describe_mask, excluded_forest, not_acquired_cells
from e2esim.maps.grid import (
    LAT_KEYS,
    LON_KEYS,
    MONTH_KEY,
    PASS_KEY,
    SOLAR_KEY,
    forest_cover_citation,
    grid_of_section,
    map_grid,
    map_section,
    map_settings,
)
from e2esim.maps.swept_cells import SweptCells

DIMS = ("solar", "pass", "month", "lat", "lon")
"""Dimensions of every per-case variable, in order."""

CF_UNITS = {"deg": "degree", "%": "percent", "m^2/m^2": "1", "(m^2/m^2)^2": "1", "t/ha": "t ha-1",
            "TECU": "1e16 m-2", "uT": "uT", "sfu": "1e-22 W m-2 Hz-1", "count": "1", "MHz": "MHz", "Hz": "Hz",
            "m": "m", "1": "1", "dB": "1"}
"""e2esim units -> UDUNITS strings (dB values are logarithmic ratios: "1", with ``e2esim_units: dB``)."""

STANDARD_NAMES = {"scene.agb_t_ha": None}
"""CF standard names of output scalars; none of e2esim's quantities has one (AGB, Faraday rotation and the
error statistics are not in the CF standard name table), so only the coordinates and the land fraction carry
one. Kept as a table so that a name added to CF is added here."""


@dataclass(frozen=True)
class MapColumns:
    """What a map dataset is made of: the columns of a run's cases, as ``e2esim.results.Results`` holds them
    (a ``Results`` serves as well)."""

    scenario_name: str
    resolved_scenario: dict
    inputs: dict
    scalars: dict
    units: dict
    requirements: list
    provenance: dict
    term_margins: dict = None
    """{(j, source): (n,) margin of requirement j without the error term's source} for every source of the
    chain's error terms (``margin + contribution.<source>``; ``term_margins``): where a term changes the verdict."""

    @classmethod
    def of(cls, result) -> MapColumns:
        """From a ``ScenarioResult`` (``e2esim.runner.run``): its scalars in name order, each with its unit."""
        table = result.table
        requirement_units = tuple(r.unit[0] for r in table.requirements) if table.n else ()
        names = sorted(table.scalars)
        return cls(result.scenario.name, result.scenario.resolved, result.input_columns(),
                   {k: table.scalar(k).astype(float, copy=False) for k in names},
                   {k: scalar_unit(k, requirement_units) for k in names}, list(result.requirement_names),
                   dict(result.provenance), term_margins(result))


def term_margins(result) -> dict:
    """{(j, source): margin of requirement j without ``source`` per case} for the sources of the error terms of the
    run's chain (``ErrorTerm.sources``): the margin plus the source's contribution (the checked value less the
    value without it, ``e2esim.requirements.attribution``), NaN where a case has no attribution."""
    cases = result.scenario.cases
    sources = [s for m in (cases[0].modules if cases else ()) if m.kind == "error_terms" for s in m.sources]
    table, out = result.table, {}
    for j, r in enumerate(table.requirements if table.n else ()):
        for source in sources:
            key = next((k for k in r.details if k.startswith(f"contribution.{source}_")), None)
            if key is not None:
                out[(j, source)] = np.asarray(r.margin, float) + table.detail(j, key)
    return out


def map_dataset_of(result):
    """The map dataset of a run (a ``ScenarioResult`` of a map sweep), built once and kept with the run: the
    writer of results.nc and the report's maps read the same one (``ScenarioResult.map_dataset``)."""
    if result.map_dataset is None:
        result.map_dataset = map_dataset(MapColumns.of(result))
    return result.map_dataset


def map_dataset(results):
    """The map of ``results`` (``MapColumns``, or a ``e2esim.results.Results``, of a map sweep) as an xarray
    Dataset."""

    xr = optional_import("xarray", "maps", "the map of a map sweep (results.nc, Results.to_xarray)")
    optional_import("netCDF4", "maps", "the map of a map sweep (results.nc, Results.to_xarray)")

    section = map_section(results.resolved_scenario.get("sweep"))
    if section is None:
        raise ValueError("not a map sweep: its sweep section has no 'map'")
    lat, lon, step, land, forest, settings = grid_of_section(section)
    inputs = results.inputs
    solar = list(dict.fromkeys(inputs[SOLAR_KEY]))
    passes = list(dict.fromkeys(inputs[PASS_KEY]))
    months = sorted(dict.fromkeys(int(m) for m in inputs[MONTH_KEY]))
    index = (_positions(solar, inputs[SOLAR_KEY]), _positions(passes, inputs[PASS_KEY]),
             _positions(months, [int(m) for m in inputs[MONTH_KEY]]),
             grid_positions(lat, inputs[LAT_KEYS[0]], step), grid_positions(lon, inputs[LON_KEYS[0]], step))
    shape = (len(solar), len(passes), len(months), lat.size, lon.size)
    data = {}
    for name, values in results.scalars.items():  # the cases' values, made dense only when read (SweptCells)
        data[_var_name(name, data)] = xr.Variable(DIMS, SweptCells(shape, index, np.asarray(values, float), np.nan),
                                                  attrs=_scalar_attrs(name, results.units.get(name)))
    swept = np.zeros((lat.size, lon.size), bool)
    swept[index[3], index[4]] = True
    weight = np.where(swept, np.cos(np.radians(lat))[:, None], 0.0)
    data["cell_area_weight"] = xr.Variable(("lat", "lon"), weight, attrs={
        "units": "1", "long_name": "area weight of each swept cell: cos(latitude), 0 where not swept",
        "comment": "cells are equal in latitude and longitude, so their areas are proportional to cos(latitude)"})
    data["land_area_fraction"] = xr.Variable(("lat", "lon"), land, attrs={
        "units": "1", "standard_name": "land_area_fraction",
        "long_name": "share of the cell that is land (GSHHG shoreline, roaring-landmask)"})
    cover = settings["forest_cover"]
    if cover != "none":
        data["forest_area_fraction"] = xr.Variable(("lat", "lon"), forest, attrs={
            "units": "1", "long_name": "share of the cell that is forest (IGBP groups "
            f"{', '.join(dict.fromkeys(settings['forest_classes']))} of {cover})", "source": forest_cover_citation()})
    forest_weight = weight * forest
    data["forest_area_weight"] = xr.Variable(("lat", "lon"), forest_weight, attrs={
        "units": "1", "long_name": "forest area of each swept cell: cos(latitude) times its forest fraction, 0 where "
        "not swept" + (" (forest_cover none: every swept cell wholly forest)" if cover == "none" else "")})
    mask_text = describe_mask(settings)
    not_acquired = _not_acquired(section, results.resolved_scenario, settings, lat, lon) if mask_text else \
        np.zeros(swept.shape, bool)
    if mask_text:
        data["not_acquired"] = xr.Variable(("lat", "lon"), not_acquired.astype(np.int8), attrs={
            "units": "1", "flag_values": np.array([0, 1], np.int8), "flag_meanings": "acquired_or_not_forest "
            "not_acquired", "long_name": "forest cells the mission does not acquire (the acquisition mask), left "
            "out of the sweep and of the share meeting each requirement", "comment": f"mask: {mask_text}"})
    for j, name in enumerate(results.requirements):
        key = _var_name(f"requirement{j}.passed", {})
        if key in data:
            data[f"requirement{j}_area_fraction"] = xr.Variable(
                DIMS[:3], area_fraction(np.asarray(data[key].data), forest_weight), attrs={
                    "units": "1", "long_name": f"share of the swept forest area meeting requirement {j}: {name}",
                    "comment": "sum of forest_area_weight over cells that pass / over cells with a verdict; cells "
                    "not acquired have none and are left out"})
            data[f"requirement{j}_state"] = xr.Variable(DIMS, _states_of(data[key].data, not_acquired),
                                                        attrs=STATE_ATTRS | {"long_name": f"state of each cell for "
                                                                             f"requirement {j}: {name}"})
    for (j, source), margin in (getattr(results, "term_margins", None) or {}).items():
        passed = data.get(_var_name(f"requirement{j}.passed", {}))
        if passed is not None:
            name = results.requirements[j]
            change = verdict_changes(passed.data.case_values, margin)  # per case; no case: no verdict (-2)
            data[f"requirement{j}_changed_by_{source}"] = xr.Variable(DIMS, SweptCells(shape, index, change, -2),
                                                                      attrs=CHANGE_ATTRS | {
                "long_name": f"where the error source {source} changes the verdict of requirement {j}: {name}"})
            broken = SweptCells(shape, index, np.where(change > -2, (change == 1).astype(float), np.nan), np.nan)
            data[f"requirement{j}_broken_by_{source}_area_fraction"] = xr.Variable(
                DIMS[:3], area_fraction(broken.dense(), forest_weight), attrs={
                    "units": "1", "long_name": f"share of the swept forest area that fails requirement {j} only "
                    f"because of the error source {source}: {name}"})
    coords = {
        "solar": ("solar", np.array(solar, dtype=object), {"long_name": "solar activity level"}),
        "pass": ("pass", np.array(passes, dtype=object), {"long_name": "satellite pass (by its equator crossing)"}),
        "month": ("month", np.array(months, np.int32), {"long_name": "month of the year", "units": "1"}),
        "lat": ("lat", lat, {"units": "degrees_north", "standard_name": "latitude", "long_name": "latitude of the "
                             "cell centre", "axis": "Y"}),
        "lon": ("lon", lon, {"units": "degrees_east", "standard_name": "longitude", "long_name": "longitude of the "
                             "cell centre", "axis": "X"}),
    }
    f107 = results.scalars.get("faraday.f107_sfu")
    if f107 is not None:
        coords["f107"] = ("solar", np.array([np.nanmean(np.where(index[0] == k, f107, np.nan)) for k in
                                             range(len(solar))]), {"units": "1e-22 W m-2 Hz-1",
                                                                   "long_name": "F10.7 solar radio flux"})
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update(_global_attrs(results, step))
    if mask_text:
        excluded = excluded_forest(not_acquired, swept, forest, lat, step)
        ds.attrs.update({"not_acquired_mask": mask_text, "not_acquired_cells": excluded["cells"],
                         "not_acquired_forest_area_km2": excluded["forest_area_km2"],
                         "not_acquired_forest_area_fraction": excluded["forest_area_fraction"]})
    return ds


STATE_ATTRS = {"units": "1", "flag_values": np.array([0, 1, 2, 3], np.int8),
               "flag_meanings": "fails passes not_applicable not_acquired", "_FillValue": np.int8(-1),
               "comment": "fill (-1): no case (ocean, no forest, or a latitude the pass does not see); not_acquired: a "
               "forest cell in the acquisition mask (sweep.map.not_acquired*)"}
"""Attributes of the ``requirement<j>_state`` variables: the four states of a map cell."""


CHANGE_ATTRS = {"units": "1", "flag_values": np.array([-1, 0, 1], np.int8), "_FillValue": np.int8(-2),
                "flag_meanings": "rescues unchanged breaks",
                "comment": "1 (breaks): fails with the error term's source, passes without it; -1 (rescues): passes "
                "with it, fails without it (an offsetting bias); 0: the same verdict; fill (-2): no verdict"}
"""Attributes of the ``requirement<j>_changed_by_<source>`` variables (``verdict_changes``)."""


def verdict_changes(passed, margin_without) -> np.ndarray:
    """Per cell: 1 where the verdict fails (``passed`` 0) and passes without the source (its margin without it
    >= 0), -1 where the reverse, 0 where the same, -2 where there is no verdict (NaN)."""
    without = margin_without >= 0.0
    with np.errstate(invalid="ignore"):
        change = np.where(passed > 0.5, np.where(without, 0, -1), np.where(without, 1, 0))
    return np.where(np.isfinite(passed) & np.isfinite(margin_without), change, -2).astype(np.int8)


def cell_states(passed, has_case, not_acquired) -> np.ndarray:
    """State (int8, DIMS) of every cell: 0 fails, 1 passes, 2 not applicable (a case without a verdict), 3 not
    acquired, -1 no case (``passed``: 1, 0 or NaN per cell; ``not_acquired``: (lat, lon))."""
    state = np.where(has_case, np.where(np.isnan(passed), 2, (passed > 0.5).astype(np.int8)), -1).astype(np.int8)
    state[..., not_acquired] = 3
    return state


def _states_of(passed: SweptCells, not_acquired) -> SweptCells:
    """``cell_states`` from the cases' verdicts (``passed``, the requirement's ``SweptCells``): the same grid."""
    values = passed.case_values
    state = np.where(np.isnan(values), 2, (values > 0.5).astype(np.int8)).astype(np.int8)
    return SweptCells(passed.shape, passed.index, state, -1, (not_acquired, 3) if np.any(not_acquired) else None)


def _not_acquired(section, scenario, settings, lat, lon) -> np.ndarray:
    """The cells the map sweep left out as not acquired (``MapGrid.not_acquired``): from the run's scenario, or, if
    its sections cannot be read here again (a moved AGB map), the mask over the land and forest cells. The scene's
    AGB map is asked through a ``Services()`` of this process (its kernel memo: the run's read is found again)."""
    where = Location(key_path=("sweep", "map"))
    try:
        return map_grid(section, where, scenario, Services()).not_acquired
    except (ConfigError, PhysicsInputError, OSError):
        _, _, _, land, forest, _ = grid_of_section(section)
        eligible = (np.nan_to_num(land, nan=1.0) >= settings["min_land_percent"] / 100.0) & (forest > 0)
        return eligible & not_acquired_cells(settings, lat, lon, where)


def not_acquired_summary(result) -> dict | None:
    """What a map sweep left out as not acquired (``ScenarioResult``): {mask, cells, forest_area_km2,
    forest_area_fraction} from its map dataset, or None without an acquisition mask."""
    section = map_section(getattr(result.scenario, "raw", {}).get("sweep"))
    if section is None or not describe_mask(map_settings(section)):
        return None
    attrs = map_dataset_of(result).attrs
    return {"mask": attrs["not_acquired_mask"], "cells": int(attrs["not_acquired_cells"]),
            "forest_area_km2": float(attrs["not_acquired_forest_area_km2"]),
            "forest_area_fraction": float(attrs["not_acquired_forest_area_fraction"])}


def area_fraction(passed, weight) -> np.ndarray:
    """Share of the weight (lat, lon; the forest area) of the cells with a verdict that pass, for every leading
    index of ``passed`` (..., lat, lon: 1 pass, 0 fail, NaN no verdict)."""
    has = np.isfinite(passed)
    total = np.sum(np.where(has, weight, 0.0), axis=(-2, -1))
    good = np.sum(np.where(has & (passed > 0.5), weight, 0.0), axis=(-2, -1))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, good / total, np.nan)


def write_map_netcdf(ds, path) -> None:
    """Write a map dataset (``map_dataset``) to ``path`` (NetCDF-4, compressed), atomically.

    A variable held as its swept cases (``SweptCells``) is written in chunks of a few cells square
    (``e2esim.io.swept_netcdf``), only those that hold a case: HDF5 gives the fill value (NaN, or the flag's fill)
    for a chunk never written, so the file reads back as the dense grid, and no all-fill chunk is compressed."""
    # no shuffle filter: the variables are mostly NaN (unswept cells), which zlib packs as well without it, and
    # the filter costs a tenth of the writing time of a global map
    encoding = {name: {"zlib": True, "complevel": 1, "shuffle": False} for name in ds.data_vars}
    for name, variable in ds.data_vars.items():
        if isinstance(variable.data, SweptCells) and variable.ndim == len(DIMS):
            encoding[name]["chunksizes"] = swept_chunk_sizes(variable.shape)
    with atomic_path(path) as tmp:
        try:
            write_swept_netcdf(ds, tmp, encoding)
        except RuntimeError as exc:  # the NetCDF library says only "HDF error" when a write fails
            raise _write_error(tmp, exc) from exc


def _write_error(path, exc: RuntimeError) -> OSError:
    """The ``OSError`` of a failed NetCDF write: a full disk or the file-size limit where that is what happened
    (the folder has less than 1 MiB free; the file reached the limit), else the library's words."""
    code = None
    with contextlib.suppress(OSError, ImportError, ValueError):
        import resource

        limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
        if limit != resource.RLIM_INFINITY and os.path.getsize(path) >= limit - 2**20:
            code = errno.EFBIG
    with contextlib.suppress(OSError, AttributeError):
        fs = os.statvfs(os.path.dirname(os.path.abspath(path)))
        if fs.f_bavail * fs.f_frsize < 2**20:
            code = errno.ENOSPC
    if code is not None:
        return OSError(code, os.strerror(code))
    return OSError(errno.EIO, f"the NetCDF library could not write {os.path.basename(path)} ({one_line(exc)})")


def _positions(values: list, per_case) -> np.ndarray:
    where = {v: k for k, v in enumerate(values)}
    return np.array([where[v] for v in per_case], int)


def grid_positions(axis, per_case, step) -> np.ndarray:
    """Position on ``axis`` (cell centres, spaced ``step``) of every case's cell centre; ``ValueError`` for a cell
    off the grid."""
    k = np.rint((np.asarray(per_case, float) - axis[0]) / step).astype(int)
    if np.any(k < 0) or np.any(k >= axis.size) or not np.allclose(axis[np.clip(k, 0, axis.size - 1)], per_case):
        raise ValueError("a case's cell is not a cell of the map's grid")
    return k


def _var_name(name: str, taken) -> str:
    """A CF variable name (letters, digits, underscores): dots become underscores (two on a clash)."""
    simple = name.replace(".", "_")
    return simple if simple not in taken else name.replace(".", "__")


def _scalar_attrs(name: str, unit: str | None) -> dict:
    unit = unit or "unknown"
    attrs = {"long_name": scalar_description(name), "e2esim_name": name, "e2esim_units": unit}
    if name.endswith(".passed"):
        attrs.update(units="1", flag_values=np.array([0.0, 1.0]), flag_meanings="fails passes",
                     comment="NaN: no verdict (the requirement does not apply to the case, or the cell is not swept)")
    elif unit in CF_UNITS:
        attrs["units"] = CF_UNITS[unit]  # a unit e2esim does not know (a plug-in's output) gets none
    if STANDARD_NAMES.get(name):
        attrs["standard_name"] = STANDARD_NAMES[name]
    return attrs


def _global_attrs(results, step) -> dict:
    prov = {k: v for k, v in results.provenance.items() if v is not None}
    attrs = {
        "Conventions": "CF-1.8",
        "title": f"e2esim map sweep: {results.scenario_name}",
        "source": f"e2esim {prov.get('e2esim_version', '')}".strip(),
        "history": f"{prov.get('created_utc', '')}: e2esim run ({prov.get('command', '')})",
        "references": "Men, Quegan, Riembauer & Chen (2021), IEEE JSTARS 14, 4089-4100; Quegan et al. (2018), "
                      "IGARSS; Wessel & Smith (1996), J. Geophys. Res. 101(B4), 8741-8743 (GSHHG); Friedl & "
                      "Sulla-Menashe (2015), MCD12C1 MODIS/Terra+Aqua Land Cover Type Yearly L3 Global 0.05Deg CMG "
                      "V006, NASA LP DAAC, doi:10.5067/MODIS/MCD12C1.006",
        "comment": "NaN where a cell is not swept (ocean, no forest class) or a case lacks the quantity",
        "scenario": results.scenario_name,
        "grid_step_deg": step,
        "requirements": json.dumps(list(results.requirements)),
    }
    for key, value in prov.items():
        attrs[f"provenance_{key}"] = json.dumps(value) if isinstance(value, (list, dict)) else str(value)
    return attrs
