"""Hostile user AGB maps (issue 22, item 10): a FIFO named like a map, a one-row map, absurd AGB values. Each
ends with a message naming the file and the problem (exit status 2), never a hang, a misleading message or a
verdict computed from nonsense."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from e2esim.errors import PhysicsInputError
from e2esim.scene.agb_map import MAX_MAP_AGB_T_HA, read_agb_map

LAT = np.arange(-4.5, 5.0, 1.0)
LON = np.arange(10.5, 16.0, 1.0)


def _netcdf(path, agb, lat=LAT, lon=LON, units="t/ha"):
    xr.Dataset({"agb": (("lat", "lon"), np.asarray(agb, float), {"units": units})},
               coords={"lat": lat, "lon": lon}).to_netcdf(path, engine="netcdf4")
    return path


def _scenario(folder: Path, map_name: str) -> Path:
    path = folder / f"s_{map_name.replace('.', '_')}.yaml"
    path.write_text(f"scene: {{type: agb_map, lat_deg: -0.5, lon_deg: 12.5, file: {map_name}}}\n"
                    "instrument: {type: biomass}\npropagation: [{type: hv_backscatter_error}]\n"
                    "retrieval: {type: power_law}\nrequirements: [{type: agb_rmse, max_percent: 20}]\n"
                    "simulation: {mode: analytic}\n")
    return path


def _validate(scenario: Path):
    return subprocess.run([sys.executable, "-m", "e2esim", "validate", str(scenario)], capture_output=True,
                          text=True, timeout=120)


@pytest.mark.parametrize("name", ["map.nc", "map.tif"])
def test_a_fifo_named_like_a_map_is_refused_not_read(tmp_path, name):
    """A FIFO blocks whoever opens it until a writer comes: ``validate`` used to hang for ever."""
    os.mkfifo(tmp_path / name)
    proc = _validate(_scenario(tmp_path, name))
    assert proc.returncode == 2, proc.stderr
    assert f"scene.file: the AGB map '{tmp_path / name}' is a FIFO (named pipe), not a regular file" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_directory_named_like_a_map_is_refused(tmp_path):
    (tmp_path / "map.nc").mkdir()
    with pytest.raises(PhysicsInputError, match="is a folder, not a regular file"):
        read_agb_map(tmp_path / "map.nc")


def test_a_one_row_map_is_refused_for_what_it_is(tmp_path):
    """Used to say "no latitude dimension" (the row was squeezed away before the axes were found)."""
    _netcdf(tmp_path / "row.nc", np.full((1, LON.size), 150.0), lat=LAT[:1])
    with pytest.raises(PhysicsInputError, match=r"has 1 latitude\(s\) and 6 longitude\(s\); expected at least two "
                                                r"of each, so that its pixel size is known") as info:
        read_agb_map(tmp_path / "row.nc")
    assert info.value.key == "file"
    _netcdf(tmp_path / "column.nc", np.full((LAT.size, 1), 150.0), lon=LON[:1])
    with pytest.raises(PhysicsInputError, match=r"has 10 latitude\(s\) and 1 longitude\(s\)"):
        read_agb_map(tmp_path / "column.nc")


def test_a_one_row_geotiff_is_refused_for_what_it_is(tmp_path):
    pytest.importorskip("rioxarray")
    from affine import Affine

    da = xr.DataArray(np.full((1, LON.size), 150.0, np.float32), dims=("y", "x"), coords={"y": LAT[:1], "x": LON})
    da = da.rio.write_crs("EPSG:4326").rio.write_transform(Affine(1.0, 0.0, 10.0, 0.0, -1.0, -4.0))
    da.rio.to_raster(tmp_path / "row.tif")
    with pytest.raises(PhysicsInputError, match=r"has 1 latitude\(s\) and 6 longitude\(s\)"):
        read_agb_map(tmp_path / "row.tif")


def test_a_time_axis_of_length_one_is_still_dropped(tmp_path):
    agb = np.full((1, LAT.size, LON.size), 150.0)
    xr.Dataset({"agb": (("time", "lat", "lon"), agb)}, coords={"lat": LAT, "lon": LON}).to_netcdf(tmp_path / "t.nc")
    assert read_agb_map(tmp_path / "t.nc").lookup(-0.5, 12.5) == 150.0


def test_absurd_agb_values_are_refused_with_the_largest_and_where(tmp_path):
    """1e30 t/ha used to be accepted, and the requirement passed."""
    agb = np.full((LAT.size, LON.size), 150.0)
    agb[3, 2] = 1e30
    agb[5, 5] = 7000.0
    with pytest.raises(PhysicsInputError, match=r"holds 2 value\(s\) above 5000 t/ha, the largest 1e\+30 t/ha at "
                                                r"latitude -1.5, longitude 12.5 deg; .*declare them as the variable's "
                                                r"_FillValue \(NetCDF\) or the nodata value \(GeoTIFF\)"):
        read_agb_map(_netcdf(tmp_path / "big.nc", agb))
    agb[:] = 150.0
    agb[0, 0] = np.inf
    with pytest.raises(PhysicsInputError, match=r"holds 1 value\(s\) above 5000 t/ha, the largest inf t/ha"):
        read_agb_map(_netcdf(tmp_path / "inf.nc", agb))
    agb[0, 0] = 600.0  # 6000 t/ha after the conversion of kg m-2
    with pytest.raises(PhysicsInputError, match=r"the largest 6000 t/ha \(after converting kg m-2 to t/ha\)"):
        read_agb_map(_netcdf(tmp_path / "kg.nc", agb, units="kg m-2"))


def test_the_densest_real_forests_and_no_forest_values_are_accepted(tmp_path):
    agb = np.full((LAT.size, LON.size), MAX_MAP_AGB_T_HA)  # the limit itself, above any forest measured
    agb[0, 0], agb[0, 1], agb[0, 2] = -1e30, np.nan, -np.inf  # no forest
    m = read_agb_map(_netcdf(tmp_path / "dense.nc", agb))
    assert np.isnan(m.agb_t_ha).sum() == 3 and np.nanmax(m.agb_t_ha) == MAX_MAP_AGB_T_HA


def test_validate_names_the_scenario_key_for_an_absurd_map(tmp_path):
    _netcdf(tmp_path / "big.nc", np.full((LAT.size, LON.size), 1e30))
    proc = _validate(_scenario(tmp_path, "big.nc"))
    assert proc.returncode == 2 and "scene.file: the AGB map" in proc.stderr and "above 5000 t/ha" in proc.stderr
