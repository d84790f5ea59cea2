"""Every input file a scenario names (here an orbit file and an AGB map) is recorded in the provenance (path as
given, size, SHA-256) of summary.json and results.h5, and enters the resume journal's identity: a resume after the
file changed is refused (exit 2) naming the file; an unchanged file resumes."""

import hashlib
import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

from e2esim.cli import main
from e2esim.params import Param
from e2esim.runner.journal import Journal
from e2esim.runner.run import run_block
from e2esim.runner.scenario import Scenario
from e2esim.runner.scenario_files import declared_files

ROOT = Path(__file__).resolve().parents[1]
CHAIN = ("instrument: {type: biomass}\npropagation: [{type: hv_backscatter_error}]\nretrieval: {type: power_law}\n"
         "requirements: [{type: agb_rmse, max_percent: 20}]\nsimulation: {mode: analytic}\n")


def _orbit_scenario(folder: Path) -> tuple[Path, Path, str]:
    (folder / "orbits").mkdir()
    orbit = folder / "orbits" / "pass.EOF"
    shutil.copyfile(ROOT / "scenarios" / "orbits" / "biomass_circular_siberia.EOF", orbit)
    path = folder / "orbit.yaml"
    path.write_text("orbit: {type: biomass_orbit_file, file: orbits/pass.EOF, site: {lat_deg: 60.0, lon_deg: 92.0}}\n"
                    "scene: {type: table1_forest}\n" + CHAIN
                    + "sweep: {parameters: {scene.forest: [boreal_200, boreal_350]}}\n")
    return path, orbit, "orbit.file"


def _map_scenario(folder: Path) -> tuple[Path, Path, str]:
    lat, lon = np.arange(-4.5, 5.0, 1.0), np.arange(10.5, 16.0, 1.0)
    agb = 100.0 + 10.0 * np.arange(lat.size)[:, None] + np.arange(lon.size)[None, :]
    agb_map = folder / "agb.nc"
    xr.Dataset({"agb": (("lat", "lon"), agb, {"units": "t/ha"})}, coords={"lat": lat, "lon": lon}).to_netcdf(
        agb_map, engine="netcdf4")
    path = folder / "map.yaml"
    path.write_text("scene: {type: agb_map, lat_deg: -0.5, lon_deg: 12.5, file: agb.nc}\n" + CHAIN
                    + "sweep: {parameters: {scene.lon_deg: [11.5, 12.5]}}\n")
    return path, agb_map, "scene.file"


WITH_FILES = [_orbit_scenario, _map_scenario]


def _entry(key: str, given: str, file: Path) -> dict:
    data = file.read_bytes()
    return {"key": key, "path": given, "size_bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}


def _interrupted(scenario: Path, out: Path) -> None:
    """A journal of the scenario's first case, as an interrupted run leaves it."""
    resolved = Scenario.load(scenario).resolve()
    journal = Journal(out, resolved)
    journal.start(resume=False)
    journal.record(run_block(resolved, [0]))
    journal.close()


@pytest.mark.parametrize("make", WITH_FILES)
def test_resume_after_the_input_file_changed_is_refused_naming_it(tmp_path, capsys, make):
    scenario, file, key = make(tmp_path)
    out = tmp_path / "out"
    _interrupted(scenario, out)
    file.write_bytes(file.read_bytes() + b"\n")  # one more byte: the same numbers perhaps, but not the same file
    assert main(["run", str(scenario), "-o", str(out), "--no-progress", "--resume"]) == 2
    err = capsys.readouterr().err
    assert f"input file {key} (" in err and "changed since the interrupted run" in err
    assert "Run without --resume" in err and "restore the file" in err
    assert not (out / "summary.json").exists()


@pytest.mark.parametrize("make", WITH_FILES)
def test_resume_with_the_input_file_unchanged_goes_on_and_the_provenance_lists_it(tmp_path, make):
    scenario, file, key = make(tmp_path)
    out = tmp_path / "out"
    _interrupted(scenario, out)
    assert main(["run", str(scenario), "-o", str(out), "--no-progress", "--resume"]) == 0
    given = Scenario.load(scenario).raw[key.split(".")[0]]["file"]
    expected = [_entry(key, given, file)]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["resumed_cases"] == 1 and summary["input_files"] == expected
    with h5py.File(out / "results.h5") as f:
        assert json.loads(f.attrs["input_files"]) == expected


def test_a_file_parameter_is_found_in_groups_and_only_when_set():
    params = (Param("file", "str", "a file", default=None, nullable=True, input_file=True),
              Param("name", "str", "not a file", default="x"))
    assert declared_files(params, {"file": "a.nc", "name": "b.nc"}, ("scene",)) == [("scene.file", "a.nc")]
    assert declared_files(params, {"file": None, "name": "b.nc"}, ("scene",)) == []
    with pytest.raises(TypeError, match="only a 'str' parameter names an input file"):
        Param("n", "int", "a count", input_file=True)
