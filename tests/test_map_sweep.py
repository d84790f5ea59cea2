"""Map sweeps (issue 14, item 3): land mask, default forest bands, AGB maps, the Faraday-rotation look-up in the
global climatology table, the expansion of ``sweep: {map: ...}``, results.nc and the report's maps."""

import json

import numpy as np
import pytest
import xarray as xr

from e2esim.errors import ConfigError, LimitError, Location
from e2esim.faraday.cell_lookup import cell_index, month_table
from e2esim.faraday.global_lookup import GlobalClimatologyLookup
from e2esim.maps.grid import MAP_KEYS
from e2esim.maps.netcdf import area_fraction
from e2esim.runner.scenario import Scenario
from e2esim.runner.sweep import sweep_table
from e2esim.scene.agb_map import read_agb_map
from e2esim.scene.forest_cover import forest_fraction
from e2esim.scene.land_mask import is_land, land_fraction
from e2esim.scene.map_forest import ForestSource
from e2esim.scene.map_modules import AGBMapScene
from e2esim.scene.table1 import TABLE1_FORESTS
from e2esim.testing import reference_case
from quick_runs import SCENARIOS

# ---------------------------------------------------------------------------------------------- land mask


def test_known_land_points_are_land_and_ocean_points_are_not():
    #                Lope (Gabon), central Siberia, Paris, mid-Atlantic, central Pacific, Southern Ocean
    lat = np.array([-0.2, 60.0, 48.85, 0.0, 0.0, -60.0])
    lon = np.array([11.6, 92.0, 2.35, -30.0, -150.0, 0.0])
    assert is_land(lat, lon).tolist() == [True, True, True, False, False, False]
    assert is_land(60.0, 92.0 + 360.0)  # longitudes wrap


def test_land_fraction_of_cells():
    frac = land_fraction(np.array([60.5, 0.5]), np.array([92.5, -30.5]), 1.0)
    assert frac[0, 0] == 1.0  # inside Siberia
    assert frac[1, 1] == 0.0  # mid-Atlantic
    assert frac.shape == (2, 2)


# ---------------------------------------------------------------------------------------- forest of a cell


def test_default_bands_give_the_table1_forest_of_each_band():
    source = ForestSource()
    biome, agb = source.forest(np.array([0.5, -23.0, 60.5, 40.5, -30.5, 75.0]), 20.5)
    assert biome.tolist() == ["tropical", "tropical", "boreal", "", "", ""]
    assert agb[:3].tolist() == [338.0, 338.0, 200.0] and np.all(np.isnan(agb[3:]))
    stand_in = ForestSource(temperate_biome="boreal")
    assert stand_in.forest(40.5, 0.5)[0][()] == "boreal" and stand_in.forest(40.5, 0.5)[1][()] == 200.0


def test_agb_map_scene_uses_the_table1_covariance_of_the_band_and_refuses_a_cell_without_forest():
    scene = AGBMapScene(lat_deg=60.5, lon_deg=92.5)
    _, agb, hh, hv, vv, _, _ = TABLE1_FORESTS["boreal_200"]
    cov = scene.covariance
    assert (cov.biome, cov.agb_t_ha, cov.sigma_hh, cov.sigma_hv, cov.sigma_vv) == ("boreal", agb, hh, hv, vv)
    assert AGBMapScene(lat_deg=-5.5, lon_deg=20.5, tropical_forest="tropical_341").covariance.sigma_hv == 0.086
    with pytest.raises(ConfigError, match=r"lat_deg: no forest class here: latitude 40.5 deg is in no forest band"):
        AGBMapScene(lat_deg=40.5, lon_deg=0.5)


def _write_netcdf(path, units="t/ha"):
    lat = np.arange(-4.5, 5.0, 1.0)  # 10 pixels, south to north
    lon = np.arange(10.5, 16.0, 1.0)  # 6 pixels
    agb = 100.0 + 10.0 * np.arange(lat.size)[:, None] + np.arange(lon.size)[None, :]
    agb[0, 0] = np.nan  # no forest
    agb[1, 0] = 0.0  # no forest either
    ds = xr.Dataset({"agb": (("lat", "lon"), agb, {"units": units})}, coords={"lat": lat, "lon": lon})
    ds = ds.isel(lat=slice(None, None, -1))  # stored north to south, as many maps are
    ds.to_netcdf(path, engine="netcdf4")
    return lat, lon, agb


def test_netcdf_agb_map_is_read_back(tmp_path):
    lat, lon, agb = _write_netcdf(tmp_path / "agb.nc")
    m = read_agb_map(tmp_path / "agb.nc")
    assert m.lat_deg.tolist() == lat.tolist() and m.lon_deg.tolist() == lon.tolist()
    assert m.lookup(lat[3], lon[2]) == agb[3, 2] == 132.0
    assert m.lookup(lat[3] + 0.4, lon[2] - 0.4) == 132.0  # the pixel containing the point
    assert np.isnan(m.lookup(lat[0], lon[0])) and np.isnan(m.lookup(lat[1], lon[0]))  # NaN, 0: no forest
    assert np.isnan(m.lookup(10.0, 12.0)) and not m.covers(10.0, 12.0)  # outside
    _write_netcdf(tmp_path / "kg.nc", units="kg m-2")
    assert read_agb_map(tmp_path / "kg.nc").lookup(lat[3], lon[2]) == pytest.approx(1320.0)


@pytest.mark.filterwarnings("ignore::PendingDeprecationWarning")  # rioxarray's use of affine
def test_geotiff_agb_map_is_read_back(tmp_path):
    import rioxarray  # noqa: F401  (the .rio accessor)

    lat, lon, agb = _write_netcdf(tmp_path / "agb.nc")
    da = xr.DataArray(agb[::-1].astype(np.float32), dims=("y", "x"), coords={"y": lat[::-1], "x": lon})
    da.rio.write_crs("EPSG:4326", inplace=True).rio.to_raster(tmp_path / "agb.tif")
    m = read_agb_map(tmp_path / "agb.tif")
    assert m.lookup(lat[3], lon[2]) == 132.0 and m.lookup(lat[9], lon[5]) == agb[9, 5]
    assert np.allclose(m.lat_deg, lat) and np.allclose(m.lon_deg, lon)


def test_agb_map_scene_reads_the_cell_and_refuses_cells_outside_the_map(tmp_path):
    _write_netcdf(tmp_path / "agb.nc")
    scene = AGBMapScene(lat_deg=-1.5, lon_deg=12.5, file=str(tmp_path / "agb.nc"))
    assert scene.covariance.agb_t_ha == 132.0 and scene.covariance.biome == "tropical"
    with pytest.raises(ConfigError, match=r"outside the AGB map .*agb.nc \(latitude -4.5 to 4.5"):
        AGBMapScene(lat_deg=-10.5, lon_deg=12.5, file=str(tmp_path / "agb.nc"))
    with pytest.raises(ConfigError, match=r"file: cannot read the AGB map"):
        AGBMapScene(lat_deg=-1.5, lon_deg=12.5, file=str(tmp_path / "missing.nc"))
    with pytest.raises(ConfigError, match=r"variable: the AGB map .* has no variable 'biomass'; its variables: agb"):
        AGBMapScene(lat_deg=-1.5, lon_deg=12.5, file=str(tmp_path / "agb.nc"), variable="biomass")


# ------------------------------------------------------------------------------------- Faraday rotation


def test_lookup_equals_the_climatology_statistics_of_the_cell():
    config = dict(lat_deg=15.0, lon_deg=25.0, month=3, grid_step_deg=10.0, table_lat_range_deg=[-10, 20],
                  table_lon_range_deg=[0, 30], variability_nodes=3, cache_dir="off")
    case = reference_case(("instrument",))
    frequency = case["instrument"].centre_frequency_hz
    for pass_name, p in (("dawn", 0), ("dusk", 1)):
        module = GlobalClimatologyLookup(**config, **{"pass": pass_name, "solar": "max"})
        fr = module.forward(case)["faraday.geophysical"]
        table = month_table(module.orbit, 10.0, 3, 180.0, module.incidence_deg, module.settings, (-10, 20), (0, 30),
                            memo=case.services.memo)  # the table the forward made
        assert table.passes == ("ascending", "descending") and table.pass_labels[p] == pass_name
        stats = table.statistics(frequency, 0.25, 3, months=[3])
        i, j = cell_index(table.lat_deg, 15.0)[0], cell_index(table.lon_deg, 25.0)[0]
        assert (table.lat_deg[i], table.lon_deg[j]) == (15.0, 25.0)
        assert np.degrees(fr.mean_rad) == pytest.approx(stats["mean_deg"][p, 0, i, j], rel=1e-6)
        assert np.degrees(fr.sd_rad) == pytest.approx(stats["sd_deg"][p, 0, i, j], rel=1e-5)
        assert fr.f107 == 180.0 and fr.samples.size == 3 * 3  # swath positions x variability nodes


def test_cell_index_wraps_longitude_and_finds_the_containing_cell():
    axis = np.arange(-175.0, 180.0, 10.0)
    k, inside = cell_index(axis, np.array([-180.0, -170.1, 179.9, 185.0, 0.0]), periodic=True)
    assert axis[k].tolist() == [-175.0, -175.0, 175.0, -175.0, 5.0] and inside.all()
    k, inside = cell_index(np.arange(-85.0, 90.0, 10.0), np.array([-90.0, 89.99, 95.0]))
    assert inside.tolist() == [True, True, False]


def test_a_point_outside_the_table_is_refused_with_its_key():
    module = GlobalClimatologyLookup(lat_deg=40.0, lon_deg=25.0, month=3, grid_step_deg=10.0,
                                     table_lat_range_deg=[-10, 20], table_lon_range_deg=[0, 30], variability_nodes=2,
                                     cache_dir="off")
    with pytest.raises(ConfigError, match=r"lat_deg: latitude 40 deg is outside the climatology table's grid"):
        module.forward(reference_case(("instrument",)))


# ------------------------------------------------------------------------------------------- expansion


def _map_scenario(**sweep_map):
    return {"scene": {"type": "agb_map"}, "instrument": {"type": "biomass"},
            "ionosphere": {"type": "global_climatology", "grid_step_deg": sweep_map.get("step_deg", 1.0)},
            "sweep": {"map": sweep_map}}


def test_map_sweep_expands_to_forest_land_cells_months_passes_and_solar_levels():
    raw = _map_scenario(step_deg=10, lat_range_deg=[-30, 70], lon_range_deg=[-20, 60], months=[1, 7],
                        passes=["dawn", "dusk"], solar=["min", "max"])
    table = sweep_table(raw["sweep"], Location("t.yaml", ("sweep",)), raw)
    cases, keys = table.all_inputs(), table.keys
    assert keys == MAP_KEYS
    lat = np.arange(-25.0, 70.0, 10.0)
    lon = np.arange(-15.0, 60.0, 10.0)
    land = land_fraction(lat, lon, 10.0) >= 0.5
    band = ForestSource().forest(lat[:, None], lon[None, :])[0] != ""
    forest = forest_fraction(lat, lon, 10.0) >= 0.01  # MODIS 2019: forests and woody savannas, 1 % or more
    cells = int((land & band & forest).sum())
    assert int((land & band).sum()) == 28 and cells == 20 and len(cases) == cells * 2 * 2 * 2
    assert cases[0] == {"scene.lat_deg": -15.0, "scene.lon_deg": 15.0, "ionosphere.lat_deg": -15.0,
                        "ionosphere.lon_deg": 15.0, "ionosphere.month": 1, "ionosphere.pass": "dawn",
                        "ionosphere.solar": "min"}
    assert [c["ionosphere.solar"] for c in cases[:: cells * 4]] == ["min", "max"]


def test_map_sweep_over_an_agb_map_keeps_its_forest_land_cells(tmp_path):
    lat, lon, agb = _write_netcdf(tmp_path / "agb.nc")
    raw = _map_scenario(step_deg=1, lat_range_deg=[-6, 6], lon_range_deg=[9, 17], months=[4], passes=["dusk"])
    raw["scene"]["file"] = str(tmp_path / "agb.nc")
    resolved = Scenario(raw, "map.yaml").resolve()
    cells = {(c.inputs["scene.lat_deg"], c.inputs["scene.lon_deg"]) for c in resolved.cases}
    land = land_fraction(lat, lon, 1.0) >= 0.5
    expected = {(a, b) for i, a in enumerate(lat) for j, b in enumerate(lon) if land[i, j] and np.isfinite(agb[i, j])
                and agb[i, j] > 0}
    assert cells == expected and 0 < len(cells) < lat.size * lon.size  # the map's edge, no-forest pixels, ocean
    case = next(c for c in resolved.cases if c.inputs["scene.lat_deg"] == -1.5 and c.inputs["scene.lon_deg"] == 12.5)
    scene = next(m for m in case.modules if m.kind == "scene")  # one module for every cell: it reads the case's
    slot = next(s for s in resolved.plan.slots if s.kind == "scene")
    assert len(slot.objects) == 1 and scene.scene_at(-1.5, 12.5).agb_t_ha == 132.0


def test_cells_beyond_the_orbits_reach_are_left_out():
    from e2esim.faraday.global_lookup import _ORBIT, visible_latitudes
    from e2esim.params import to_si, validate_section

    orbit = to_si((_ORBIT,), validate_section((_ORBIT,), {}, Location()))["orbit"]  # BIOMASS
    for pass_name in ("dawn", "dusk"):  # left-looking from 98 deg inclination: 78.5 N to 84.5 S at 1 deg
        assert visible_latitudes(orbit, [-85.5, -84.5, 0.5, 78.5, 79.5], pass_name).tolist() == [
            False, True, True, True, False]
    raw = _map_scenario(step_deg=10, lat_range_deg=[70, 90], lon_range_deg=[0, 20], land_only=False,
                        forest_cover="none", months=[1])
    raw["scene"]["tropical_lat_deg"] = 90  # every latitude forest
    cases = Scenario(raw, "map.yaml").resolve().cases
    assert sorted({c.inputs["scene.lat_deg"] for c in cases}) == [75.0] and len(cases) == 2 * 2


def test_map_sweep_errors_name_the_key():
    def resolve(raw):
        return Scenario(raw, "map.yaml").resolve()

    raw = _map_scenario(step_deg=10, lat_range_deg=[-30, 70], lon_range_deg=[-20, 60])
    raw["ionosphere"]["grid_step_deg"] = 5
    with pytest.raises(ConfigError, match=r"ionosphere.grid_step_deg: 5 differs from the map's step_deg 10"):
        resolve(raw)
    raw = _map_scenario(step_deg=10, lat_range_deg=[-30, 70], lon_range_deg=[-20, 60])
    raw["ionosphere"]["table_lat_range_deg"] = [-30, 60]
    with pytest.raises(ConfigError, match=r"ionosphere.table_lat_range_deg: \[-30, 60\] does not cover the map's "):
        resolve(raw)
    raw = _map_scenario(step_deg=10, lat_range_deg=[30, 40], lon_range_deg=[-40, -30])  # mid-Atlantic
    with pytest.raises(ConfigError, match=r"sweep.map: no cell of the grid is swept"):
        resolve(raw)
    raw = _map_scenario(step_deg=10, months=[13])
    with pytest.raises(ConfigError, match=r"sweep.map.months"):
        resolve(raw)
    raw = _map_scenario(step_deg=10)
    raw["scene"] = {"type": "table1_forest"}
    with pytest.raises(ConfigError, match=r"scene.type: 'table1_forest' has no parameter 'lat_deg'.*use scene type "
                                          "agb_map"):
        resolve(raw)
    raw = _map_scenario(step_deg=0.1, months=list(range(1, 13)), passes=["dawn", "dusk"], land_only=False,
                        forest_only=False)
    with pytest.raises(LimitError, match=r"grid cells exceed the limit of 5,000,000"):
        resolve(raw)


# ----------------------------------------------------------------------------- outputs of the quick run


def _summary(folder):
    return json.loads((folder / "summary.json").read_text())


def test_results_nc_holds_the_map_with_cf_attributes(quick_run):
    _, folder = quick_run("biomass_global_map")
    summary = _summary(folder)
    with xr.open_dataset(folder / "results.nc") as ds:
        assert ds.attrs["Conventions"] == "CF-1.8" and ds.attrs["scenario"] == "biomass_global_map"
        assert "e2esim" in ds.attrs["source"] and ds.attrs["provenance_seed"] == "14"
        assert dict(ds.sizes) == {"solar": 1, "pass": 2, "month": 2, "lat": 10, "lon": 8}
        assert ds["lat"].attrs["units"] == "degrees_north" and ds["lat"].attrs["standard_name"] == "latitude"
        assert ds["lon"].attrs["units"] == "degrees_east" and ds["lon"].attrs["standard_name"] == "longitude"
        assert ds["month"].values.tolist() == [1, 7] and ds["pass"].values.tolist() == ["dawn", "dusk"]
        fr = ds["faraday_omega_mean_abs_deg"]
        assert fr.attrs["units"] == "degree" and fr.attrs["e2esim_name"] == "faraday.omega_mean_abs_deg"
        assert ds["scene_agb_t_ha"].attrs["units"] == "t ha-1"
        assert ds["land_area_fraction"].attrs["standard_name"] == "land_area_fraction"
        case = summary["cases"][5]
        where = dict(solar=case["inputs"]["ionosphere.solar"], month=case["inputs"]["ionosphere.month"],
                     lat=case["inputs"]["scene.lat_deg"], lon=case["inputs"]["scene.lon_deg"])
        where["pass"] = case["inputs"]["ionosphere.pass"]
        assert float(fr.sel(where)) == case["results"]["faraday.omega_mean_abs_deg"]
        assert float(ds["requirement0_value"].sel(where)) == case["results"]["requirement0.value"]
        assert np.isnan(float(fr.sel(solar="max", month=1, lat=35.0, lon=-15.0, **{"pass": "dawn"})))  # Atlantic
        assert int(np.isfinite(fr.values).sum()) == summary["n_cases"]


def test_results_to_xarray_of_a_map_is_its_grid(quick_run):
    import e2esim

    result, folder = quick_run("biomass_global_map")
    for results in (e2esim.Results.from_run(result), e2esim.open_results(folder)):
        ds = results.to_xarray()
        assert ds["faraday_omega_mean_abs_deg"].dims == ("solar", "pass", "month", "lat", "lon")
        with xr.open_dataset(folder / "results.nc") as written:
            np.testing.assert_array_equal(ds["requirement0_value"].values, written["requirement0_value"].values)


def test_fraction_of_forest_area_meeting_the_requirement(quick_run):
    _, folder = quick_run("biomass_global_map")
    cases = _summary(folder)["cases"]
    passed = [c["results"]["requirement0.passed"] for c in cases]
    assert 0 < sum(passed) < len(passed), "the quick run should have cells that pass and cells that fail"
    with xr.open_dataset(folder / "results.nc") as ds:
        fraction = ds["requirement0_area_fraction"]
        for month in (1, 7):
            for pass_name in ("dawn", "dusk"):
                mine = [c for c in cases if c["inputs"]["ionosphere.month"] == month
                        and c["inputs"]["ionosphere.pass"] == pass_name]
                lat = np.array([c["inputs"]["scene.lat_deg"] for c in mine])
                lon = np.array([c["inputs"]["scene.lon_deg"] for c in mine])
                forest = np.array([forest_fraction([a], [b], 10.0)[0, 0] for a, b in zip(lat, lon)])
                w = np.cos(np.radians(lat)) * forest
                assert np.all(w > 0) and np.ptp(w / np.cos(np.radians(lat))) > 0.1  # forest shares that differ
                ok = np.array([c["results"]["requirement0.passed"] for c in mine])
                expected = float(np.sum(w * ok) / np.sum(w))
                assert float(fraction.sel(solar="max", month=month, **{"pass": pass_name})) == pytest.approx(
                    expected, rel=1e-12)


def test_area_fraction_ignores_cells_without_a_verdict():
    passed = np.array([[[1.0, 0.0], [np.nan, 1.0]]])
    weight = np.array([[1.0, 2.0], [5.0, 3.0]])
    assert area_fraction(passed, weight).tolist() == [4.0 / 6.0]


def test_report_draws_the_maps_and_the_fraction_plot(quick_run):
    _, folder = quick_run("biomass_global_map")
    report = (folder / "report.md").read_text()
    for stem in ("map_faraday", "map_sigma_hv_error", "map_agb_error", "map_verdict"):
        for pass_name in ("dawn", "dusk"):
            name = f"{stem}_{pass_name}_max.png"
            assert (folder / name).is_file() and f"]({name})" in report
    assert (folder / "map_fraction.png").is_file() and "](map_fraction.png)" in report
    assert "results.nc, one variable per output on the map's grid" in report
    assert "<details><summary>Every case" not in report  # no per-case tables for a map


def test_shipped_map_scenario_is_the_1_deg_global_map():
    raw = Scenario.load(SCENARIOS / "biomass_global_map.yaml").raw
    m = raw["sweep"]["map"]
    assert (m["step_deg"], m["lat_range_deg"], m["lon_range_deg"]) == (1, [-90, 90], [-180, 180])
    assert m["months"] == list(range(1, 13)) and m["passes"] == ["dawn", "dusk"] and m["solar"] == ["max"]
    assert raw["simulation"]["mode"] == "analytic" and raw["ionosphere"]["grid_step_deg"] == 1


def test_a_map_on_worker_processes_gives_the_serial_numbers(quick_run):
    """Issue 27, Build 7: a map's set-up (its orbit, slant settings and forest) and its month tables reach the
    kernels the same way in one process and on workers (``--workers 2``): every number of every cell, and the map
    dataset kept with the run (``ScenarioResult.map_dataset``, made once), are the serial run's, bit for bit."""
    from e2esim.maps.netcdf import map_dataset_of
    from e2esim.runner.run import run_scenario

    serial, _ = quick_run("biomass_global_map")
    parallel = run_scenario(serial.scenario, progress=False, workers=2)
    assert parallel.provenance["executor"] == "2 local processes" and "executor" not in serial.provenance
    assert serial.table.n == parallel.table.n == 80  # 20 cells, 2 months, 2 passes
    for name in serial.table.scalars:
        np.testing.assert_array_equal(parallel.table.scalar(name), serial.table.scalar(name), err_msg=name)
    for mine, theirs in zip(serial.table.requirements, parallel.table.requirements, strict=True):
        np.testing.assert_array_equal(mine.value, theirs.value)
        np.testing.assert_array_equal(mine.passed, theirs.passed)
    kept = map_dataset_of(serial)  # the writers of the quick run made it
    assert map_dataset_of(serial) is kept is serial.map_dataset and parallel.map_dataset is None
    assert map_dataset_of(parallel).equals(kept)
