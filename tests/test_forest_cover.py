"""Where forest is (issue 21, item 9): the MODIS 2019 land-cover grid (``e2esim.scene.forest_cover``), the map
sweep's forest mask and its forest-area weights, and a global map whose share of forest meeting the requirement
can fall below 100 %."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from e2esim.errors import Location
from e2esim.maps.grid import map_grid
from e2esim.maps.netcdf import map_dataset
from e2esim.runner.scenario import Scenario
from e2esim.scene.forest_cover import (
    DEFAULT_FOREST_GROUPS,
    GRID_FILE,
    NEVER_FOREST,
    cover_fraction,
    forest_fraction,
    land_cover_grid,
)
from quick_runs import SCENARIOS

ROOT = Path(__file__).resolve().parents[1]

NOT_FOREST = {  # 1 deg cells (centres) whose land cover is desert, ice or open water
    "Sahara (Tenere, Niger)": (18.5, 10.5),
    "Sahara (Libyan desert)": (24.5, 25.5),
    "Arabian desert (Rub' al Khali)": (20.5, 50.5),
    "Greenland ice sheet": (72.5, -40.5),
    "Antarctic ice sheet": (-80.5, 0.5),
    "open Pacific": (0.5, -150.5),
    "open Atlantic": (-20.5, -20.5),
}
FOREST = {  # 1 deg cells of closed forest in the tropical and boreal bands
    "Amazon (Manaus)": (-3.5, -60.5),
    "Congo basin": (0.5, 22.5),
    "Borneo": (1.5, 114.5),
    "Siberian taiga": (60.5, 100.5),
    "Canadian boreal forest": (55.5, -100.5),
}


def _cell(lat, lon, groups=DEFAULT_FOREST_GROUPS):
    return float(cover_fraction([lat], [lon], 1.0, groups)[0, 0])


@pytest.mark.parametrize("name", NOT_FOREST)
def test_deserts_ice_and_open_water_are_not_forest(name):
    lat, lon = NOT_FOREST[name]
    assert _cell(lat, lon) == 0.0
    assert _cell(lat, lon, ("savannas",)) == 0.0
    assert _cell(lat, lon, NEVER_FOREST) == 1.0  # the whole cell is water, snow and ice, or barren


@pytest.mark.parametrize("name", FOREST)
def test_closed_forests_are_forest(name):
    lat, lon = FOREST[name]
    assert _cell(lat, lon) > 0.8
    assert _cell(lat, lon, ("snow_ice", "barren")) == 0.0


def test_open_boreal_forest_counts_through_the_woody_savannas():
    # MODIS maps the open taiga of northern Manitoba as woody savanna (IGBP 8): 91 % of the cell
    assert _cell(55.5, -100.5, ("forests",)) < 0.05 < 0.9 < _cell(55.5, -100.5, ("woody_savannas",))


def test_no_pixel_is_both_forest_and_desert_ice_or_water():
    grid = land_cover_grid()
    forest = grid.share(("forests", "woody_savannas", "savannas"))
    never = grid.share(NEVER_FOREST)
    assert grid.counts["forests"].shape == (720, 1440) and grid.pixels_per_cell == 25
    assert np.all(forest + never <= 1.0)  # the groups are disjoint: every pixel counted once at most
    assert np.all(forest[never == 1.0] == 0.0)
    assert 0.30 < float(np.mean(never)) < 0.85 and 0.05 < float(np.mean(forest)) < 0.2  # water, ice, forest


def test_the_grid_says_where_it_comes_from():
    grid = land_cover_grid()
    p = grid.provenance
    assert p["doi"] == "10.5067/MODIS/MCD12C1.006"
    assert "Friedl" in p["citation"] and "Sulla-Menashe" in p["citation"] and p["doi"] in p["citation"]
    assert "MCD12C1" in p["product"] and "2019" in p["product"] and "IGBP" in p["product"]
    assert re.fullmatch(r"[0-9a-f]{64}", p["source_sha256"])
    assert "tools/forest_cover_grid.py" in p["derivation"]
    assert (ROOT / "tools" / "forest_cover_grid.py").is_file()
    readme = (GRID_FILE.parent / "README.md").read_text()
    assert p["doi"] in readme and "forest_cover_grid.py" in readme and GRID_FILE.name in readme
    assert GRID_FILE.stat().st_size < 500_000
    with np.load(GRID_FILE, allow_pickle=False) as data:  # plain arrays, nothing pickled
        assert all(data[name].dtype != object for name in data.files)
    pyproject = (ROOT / "pyproject.toml").read_text()  # shipped in the wheel
    assert '"scene/data/*.npz"' in pyproject and '"scene/data/README.md"' in pyproject


def test_the_fraction_of_a_large_cell_is_the_area_weighted_mean_of_its_parts():
    lat, lon = np.array([2.5]), np.array([112.5])  # a 5 deg cell of Borneo and the sea around it
    parts = forest_fraction(np.arange(0.5, 5.0), np.arange(110.5, 115.0), 1.0)
    weights = np.cos(np.radians(np.arange(0.5, 5.0)))[:, None] * np.ones((1, 5))
    # the 0.25 deg rows of a 1 deg cell have weights cos(latitude) that differ slightly from the 1 deg row's
    assert float(forest_fraction(lat, lon, 5.0)[0, 0]) == pytest.approx(
        float(np.sum(parts * weights) / np.sum(weights)), rel=1e-4)


def test_the_global_map_sweeps_no_desert_ice_or_water_cell():
    raw = Scenario.load(SCENARIOS / "biomass_global_map.yaml").raw
    grid = map_grid(raw["sweep"]["map"], Location("biomass_global_map.yaml", ("sweep", "map")), raw)
    lat, lon = grid.lat_deg, grid.lon_deg
    swept = grid.swept
    never = cover_fraction(lat, lon, 1.0, NEVER_FOREST)
    assert np.all(grid.forest_fraction[swept] >= 0.01) and not np.any(swept & (never >= 0.99))
    for name, (a, b) in NOT_FOREST.items():
        assert not swept[np.searchsorted(lat, a), np.searchsorted(lon, b)], name
    for name, (a, b) in FOREST.items():  # swept, or forest the mission does not acquire (tracking-radar zones)
        cell = np.searchsorted(lat, a), np.searchsorted(lon, b)
        assert swept[cell] or grid.not_acquired[cell], name
    # the tropical band's deserts and dry lands, swept before the forest mask, are out
    band = (np.abs(lat) <= 23.44)[:, None] & (grid.land_fraction >= 0.5)
    sahara = band & ((lat > 15)[:, None]) & ((lon > -15) & (lon < 35))[None, :]
    assert sahara.sum() > 150 and swept[sahara].sum() == 0


def test_without_a_forest_cover_every_land_cell_of_the_bands_counts():
    raw = Scenario.load(SCENARIOS / "biomass_global_map.yaml").raw
    section = dict(raw["sweep"]["map"], forest_cover="none", step_deg=5, lat_range_deg=[10, 30],
                   lon_range_deg=[0, 30])
    raw = dict(raw, ionosphere=dict(raw["ionosphere"], grid_step_deg=5))
    grid = map_grid(section, Location("t.yaml", ("sweep", "map")), raw)
    assert grid.swept[np.searchsorted(grid.lat_deg, 17.5), np.searchsorted(grid.lon_deg, 12.5)]  # the Sahara
    assert np.all(grid.forest_fraction == 1.0)


def test_the_map_weights_cells_by_their_forest_area(quick_run):
    _, folder = quick_run("biomass_global_map")
    with xr.open_dataset(folder / "results.nc") as ds:
        weight, forest = ds["forest_area_weight"].values, ds["forest_area_fraction"].values
        area = ds["cell_area_weight"].values
        np.testing.assert_array_equal(weight, area * forest)
        swept = area > 0
        assert np.all(forest[swept] >= 0.01) and np.ptp(forest[swept]) > 0.3  # shares that differ
        assert "10.5067/MODIS/MCD12C1.006" in ds["forest_area_fraction"].attrs["source"]
        assert "10.5067/MODIS/MCD12C1.006" in ds.attrs["references"]


def test_the_shipped_global_map_checks_every_error_source_and_can_fail():
    import e2esim

    raw = Scenario.load(SCENARIOS / "biomass_global_map.yaml").raw
    first = raw["requirements"][0]
    assert first["sources"] == "all" and first["type"] == "agb_rmse"
    kinds = [p["type"] for p in raw["propagation"]]
    assert "backscatter_error_budget" in kinds and raw["retrieval"]["regression"]["mode"] != "none"
    overrides = {"sweep.map.step_deg": 10, "ionosphere.grid_step_deg": 10, "sweep.map.months": [1],
                 "sweep.map.passes": ["dawn"], "sweep.map.lat_range_deg": [-10, 70],
                 "sweep.map.lon_range_deg": [10, 30], "ionosphere.table_lat_range_deg": [-10, 70],
                 "ionosphere.table_lon_range_deg": [10, 30]}
    results = e2esim.run(SCENARIOS / "biomass_global_map.yaml", set=overrides)
    fraction = map_dataset(results)["requirement0_area_fraction"].values  # the curve of map_fraction.png
    assert fraction.size and np.all(np.isfinite(fraction)) and np.any(fraction < 1.0)
