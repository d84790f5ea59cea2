"""Where the mission does not acquire (issue 24, Build 5): the tracking-radar preset, a user's polygon and raster,
the "not acquired" state of a map cell in results.nc, its maps, summary.json and report, and bad inputs."""

import json

import numpy as np
import pytest
import xarray as xr
import yaml

from e2esim import api
from e2esim.cli import main
from e2esim.errors import ConfigError, Location
from e2esim.maps.acquisition import (
    ARCTIC_CIRCLE_DEG,
    EUROPE,
    NORTH_AMERICA,
    cell_area_km2,
    excluded_forest,
    in_polygon,
)
from e2esim.maps.grid import map_grid
from e2esim.maps.netcdf import cell_states, verdict_changes
from e2esim.runner.scenario import Scenario
from quick_runs import SCENARIOS

INSIDE_NORTH_AMERICA = {"Ottawa": (-75.7, 45.4), "Mexico City": (-99.1, 19.4), "Panama": (-79.5, 9.0),
                        "Havana": (-82.4, 23.1), "Anchorage": (-149.9, 61.2), "Nuuk": (-51.7, 64.2)}
INSIDE_EUROPE = {"Madrid": (-3.7, 40.4), "Moscow": (37.6, 55.8), "Reykjavik": (-21.9, 64.1), "Athens": (23.7, 38.0),
                 "Palermo": (13.4, 38.1), "Orenburg": (55.1, 51.8)}
OUTSIDE = {"Bogota": (-74.1, 4.7), "Caracas": (-66.9, 10.5), "Algiers": (3.0, 36.75), "Tunis": (10.2, 36.8),
           "Ankara": (32.9, 39.9), "Tbilisi": (44.8, 41.7), "Novosibirsk": (82.9, 55.0), "Manaus": (-60.0, -3.1),
           "Kinshasa": (15.3, -4.3), "Astana": (71.4, 51.2)}


def test_tracking_radar_polygons_hold_the_continents_named_by_quegan_2018():
    """'The N American continent, Europe and the Arctic' (Quegan et al. 2018, Section 1): cities inside and just
    outside each zone, on either side of the edges the polygons draw (Panama-Colombia, the Mediterranean, the
    Caucasus, the Urals)."""
    for name, (lon, lat) in INSIDE_NORTH_AMERICA.items():
        assert in_polygon(lon, lat, NORTH_AMERICA) and not in_polygon(lon, lat, EUROPE), name
    for name, (lon, lat) in INSIDE_EUROPE.items():
        assert in_polygon(lon, lat, EUROPE) and not in_polygon(lon, lat, NORTH_AMERICA), name
    for name, (lon, lat) in OUTSIDE.items():
        assert not in_polygon(lon, lat, EUROPE) and not in_polygon(lon, lat, NORTH_AMERICA), name


def test_in_polygon_of_a_square_and_a_cell_area():
    square = ((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0))
    assert in_polygon([5.0, 15.0, -1.0], [5.0, 5.0, 5.0], square).tolist() == [True, False, False]
    # the whole sphere: 4 pi R^2 (R = 6371.0088 km) from the cells of a 10 deg grid
    lat = np.arange(-85.0, 90.0, 10.0)
    assert float(np.sum(cell_area_km2(lat, 10.0)) * 36) == pytest.approx(4 * np.pi * 6371.0088 ** 2, rel=1e-12)


def test_excluded_forest_counts_area_times_forest_fraction():
    lat = np.array([0.0, 60.0])
    swept = np.array([[True, False], [False, False]])
    out = np.array([[False, False], [True, False]])
    forest = np.array([[0.5, 1.0], [1.0, 1.0]])
    e = excluded_forest(out, swept, forest, lat, 1.0)
    area = cell_area_km2(lat, 1.0)
    assert e["cells"] == 1 and e["forest_area_km2"] == pytest.approx(area[1], rel=1e-12)
    assert e["forest_area_fraction"] == pytest.approx(area[1] / (area[1] + 0.5 * area[0]), rel=1e-12)


def test_cell_states_are_the_four_states():
    passed = np.array([[[1.0, 0.0, np.nan, np.nan]]])
    has_case = np.array([[[True, True, True, False]]])
    state = cell_states(passed, has_case, np.array([[False, False, False, False]]))
    assert state.tolist() == [[[1, 0, 2, -1]]]
    assert cell_states(passed, has_case, np.array([[False, False, False, True]])).tolist() == [[[1, 0, 2, 3]]]


def _grid(**section):
    raw = Scenario.load(SCENARIOS / "biomass_global_map.yaml").raw
    m = dict(raw["sweep"]["map"], step_deg=10, **section)
    raw = dict(raw, ionosphere=dict(raw["ionosphere"], grid_step_deg=10))
    return map_grid(m, Location("t.yaml", ("sweep", "map")), raw)


def test_the_shipped_global_map_does_not_sweep_the_tracking_radar_zones():
    """With the preset, no forest cell of North America, Europe or the Arctic is swept; Siberia south of the
    Arctic Circle, Amazonia and the Congo are."""
    raw = Scenario.load(SCENARIOS / "biomass_global_map.yaml").raw
    assert raw["sweep"]["map"]["not_acquired"] == "tracking_radars"
    grid, free = _grid(), _grid(not_acquired="none")
    lat, lon = grid.lat_deg, grid.lon_deg
    lon2, lat2 = np.meshgrid(lon, lat)
    zones = in_polygon(lon2, lat2, NORTH_AMERICA) | in_polygon(lon2, lat2, EUROPE) | (lat2 > ARCTIC_CIRCLE_DEG)
    assert np.array_equal(grid.not_acquired, free.swept & zones) and grid.not_acquired.sum() > 10
    assert np.array_equal(grid.swept, free.swept & ~zones)
    for a, b in ((55.0, 85.0), (-5.0, -65.0), (-5.0, 25.0)):
        assert grid.swept[np.searchsorted(lat, a), np.searchsorted(lon, b)], (a, b)
    for a, b in ((55.0, -105.0), (55.0, 35.0)):
        assert grid.not_acquired[np.searchsorted(lat, a), np.searchsorted(lon, b)], (a, b)


def test_a_user_polygon_and_raster_add_to_the_mask(tmp_path):
    polygon = [10.0, -20.0, 40.0, -20.0, 40.0, 10.0, 10.0, 10.0]  # central Africa
    grid = _grid(not_acquired="none", not_acquired_polygon_deg=polygon)
    lat, lon = grid.lat_deg, grid.lon_deg
    assert grid.not_acquired[np.searchsorted(lat, -5.0), np.searchsorted(lon, 25.0)]
    assert not grid.not_acquired[np.searchsorted(lat, -5.0), np.searchsorted(lon, -65.0)]
    path = tmp_path / "mask.nc"
    values = np.zeros((18, 36))
    values[8, 11] = 1.0  # the cell centred at -5 N, -65 E (Amazonia)
    xr.Dataset({"not_acquired": (("lat", "lon"), values)},
               coords={"lat": np.arange(-85.0, 90.0, 10.0), "lon": np.arange(-175.0, 180.0, 10.0)}).to_netcdf(path)
    grid = _grid(not_acquired="none", not_acquired_file=str(path))
    assert np.argwhere(grid.not_acquired).tolist() == [[8, 11]]


@pytest.mark.parametrize("section, message", [
    ({"not_acquired_file": "no_such_mask.nc"}, r"sweep\.map\.not_acquired_file: cannot read the acquisition mask"),
    ({"not_acquired_polygon_deg": [0, 0, 10, 0]}, r"sweep\.map\.not_acquired_polygon_deg: 4 numbers do not make a"),
    ({"not_acquired_polygon_deg": [0, 0, 10, 0, 10, 95]}, r"the vertex \[10.0, 95.0\] is off the globe"),
    ({"not_acquired": "everywhere"}, r"sweep\.map\.not_acquired: 'everywhere'"),
])
def test_bad_masks_are_config_errors(section, message):
    with pytest.raises(ConfigError, match=message):
        _grid(**section)


@pytest.mark.parametrize("layout", ["wrong_variable", "three_d", "not_netcdf"])
def test_a_mask_file_of_the_wrong_layout_exits_with_status_2(tmp_path, capsys, layout):
    path = tmp_path / "mask.nc"
    if layout == "wrong_variable":
        xr.Dataset({"mask": (("lat", "lon"), np.zeros((2, 2)))}, coords={"lat": [0.0, 1.0], "lon": [0.0, 1.0]}) \
            .to_netcdf(path)
        expected = "has no variable 'not_acquired'"
    elif layout == "three_d":
        xr.Dataset({"not_acquired": (("t", "lat", "lon"), np.zeros((2, 2, 2)))},
                   coords={"lat": [0.0, 1.0], "lon": [0.0, 1.0]}).to_netcdf(path)
        expected = "expected two: latitude and longitude"
    else:
        path.write_text("lat,lon,not_acquired\n")
        expected = "as NetCDF"
    raw = Scenario.load(SCENARIOS / "biomass_global_map.yaml").raw
    raw["sweep"]["map"].update(step_deg=30, not_acquired_file=str(path))
    raw["ionosphere"]["grid_step_deg"] = 30
    file = tmp_path / "s.yaml"
    file.write_text(yaml.safe_dump(raw))
    assert main(["validate", str(file)]) == 2
    err = capsys.readouterr().err
    assert "sweep.map.not_acquired_file" in err and str(path) in err and expected in err


def test_a_map_run_marks_the_zones_not_acquired_everywhere_it_reports(tmp_path):
    """results.nc: the cells of the mask have state 3 (not acquired) in every month and pass, and no case; the
    share meeting a requirement leaves them out; summary.json and the report state the forest area left out; the
    verdict maps show them (issue 24, Done when: the global map shows the tracking-radar zones as not acquired)."""
    overrides = {"sweep.map.step_deg": 10, "ionosphere.grid_step_deg": 10, "sweep.map.months": [1],
                 "sweep.map.passes": ["dawn"], "sweep.map.lat_range_deg": [-10, 70],
                 "sweep.map.lon_range_deg": [-120, 100], "output.plots": ["global_maps"]}
    api.run(SCENARIOS / "biomass_global_map.yaml", set=overrides, output=tmp_path / "run")
    folder = tmp_path / "run"
    summary = json.loads((folder / "summary.json").read_text())
    excluded = summary["not_acquired"]
    with xr.open_dataset(folder / "results.nc") as ds:
        out = ds["not_acquired"].values == 1
        assert out.sum() == excluded["cells"] > 0 and ds["not_acquired"].attrs["flag_meanings"].endswith("not_acquired")
        state = ds["requirement0_state"]
        assert state.attrs["flag_meanings"] == "fails passes not_applicable not_acquired"
        assert np.all(state.values[..., out] == 3)
        assert np.all(np.isnan(ds["requirement0_value"].values[..., out]))
        lat = ds["lat"].values
        lon = ds["lon"].values
        assert out[np.searchsorted(lat, 55.0), np.searchsorted(lon, -105.0)]  # Canada
        assert out[np.searchsorted(lat, 55.0), np.searchsorted(lon, 35.0)]  # European Russia
        assert not out[np.searchsorted(lat, 55.0), np.searchsorted(lon, 85.0)]  # Siberia, acquired
        assert np.isfinite(ds["requirement0_value"].values[0, 0, 0, np.searchsorted(lat, 55.0),
                                                            np.searchsorted(lon, 85.0)])
        weight = ds["forest_area_weight"].values
        passed = ds["requirement0_passed"].values[0, 0, 0]
        has = np.isfinite(passed)
        expected = np.sum(weight[has & (passed > 0.5)]) / np.sum(weight[has])
        assert float(ds["requirement0_area_fraction"].values[0, 0, 0]) == pytest.approx(expected, rel=1e-12)
        forest = ds["forest_area_fraction"].values
        area = cell_area_km2(lat, 10.0)[:, None] * forest
        assert excluded["forest_area_km2"] == pytest.approx(float(area[out].sum()), rel=1e-12)
        assert excluded["forest_area_fraction"] == pytest.approx(
            float(area[out].sum() / (area[out].sum() + area[weight > 0].sum())), rel=1e-12)
    assert "North America, Europe and the Arctic" in excluded["mask"]
    report = (folder / "report.md").read_text()
    assert f"Not acquired: {excluded['cells']} forest cells" in report
    assert "not acquired" in report and (folder / "map_verdict_dawn_max.png").is_file()


def test_verdict_changes_of_an_error_term():
    """1 where the cell fails with the source and passes without it (margin without >= 0), -1 the reverse, 0 the
    same, -2 without a verdict."""
    passed = np.array([0.0, 1.0, 1.0, 0.0, np.nan])
    without = np.array([0.5, -0.1, 0.2, -0.3, 1.0])
    assert verdict_changes(passed, without).tolist() == [1, -1, 0, 0, -2]


def test_a_map_shows_where_an_error_term_changes_the_verdict(tmp_path):
    """Any error term switched on in a map sweep (here the rfi term, by --set): results.nc has, per requirement and
    per source, where it changes the verdict in each month (the margin without it is the margin plus its
    contribution) and the share of the forest area it breaks; the report maps it (issue 24, Build 6)."""
    overrides = {"sweep.map.step_deg": 30, "ionosphere.grid_step_deg": 30, "sweep.map.months": [1, 7],
                 "sweep.map.passes": ["dawn"], "sweep.map.not_acquired": "none", "output.plots": ["global_maps"],
                 "error_terms": [{"type": "rfi", "band_fraction_percent": 20.0, "compensated": True, "looks": 92}]}
    run = api.run(SCENARIOS / "biomass_global_map.yaml", set=overrides, output=tmp_path / "run")
    folder = tmp_path / "run"
    margin = np.asarray(run.margin[:, 1], float)
    contribution = np.asarray(run.details[1]["contribution.rfi_looks_percent"], float)
    assert np.any(margin < 0) and np.any(margin + contribution >= 0)  # the lost looks break the verdict somewhere
    with xr.open_dataset(folder / "results.nc") as ds:
        change = ds["requirement1_changed_by_rfi_looks"]
        assert change.attrs["flag_meanings"] == "rescues unchanged breaks"
        values = change.values
        lat, lon = np.asarray(run.inputs["scene.lat_deg"]), np.asarray(run.inputs["scene.lon_deg"])
        month = np.asarray(run.inputs["ionosphere.month"])
        for k in range(len(margin)):
            cell = values[0, 0, [1, 7].index(int(month[k])), np.searchsorted(ds["lat"].values, lat[k]),
                          np.searchsorted(ds["lon"].values, lon[k])]
            assert cell == (1 if margin[k] < 0 <= margin[k] + contribution[k] else 0)
        assert np.all(values[np.isnan(ds["requirement1_passed"].values)] == -2) or \
            np.all(np.isnan(values[np.isnan(ds["requirement1_passed"].values)]))
        broken = ds["requirement1_broken_by_rfi_looks_area_fraction"].values
        assert np.all((broken > 0) & (broken <= 1))
        notch = ds["requirement1_changed_by_rfi_notch"].values  # compensated: changes nothing
        assert np.all(notch[np.isfinite(notch)] <= 0) and not np.any(notch == 1)
    assert (folder / "map_change1_rfi_looks_dawn_max.png").is_file()
    assert not (folder / "map_change1_rfi_notch_dawn_max.png").exists()
