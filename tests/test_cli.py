"""The command line and the outputs of a run (issue "Foundation", Build items 5-7 and "Done when")."""

import json
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

import e2esim
from e2esim.cli import main
from quick_runs import quick_overrides

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ROOT / "scenarios" / "biomass_default.yaml"
QUICK = [arg for item in quick_overrides("biomass_default") for arg in ("--set", item)]
"""The default scenario at the reduced sizes of the default suite (tests/quick_runs.py)."""


def _run(tmp_path, name, *extra, capsys=None):
    out = tmp_path / name
    status = main(["run", str(DEFAULT), "-o", str(out), "--no-progress", *QUICK, *extra])
    return status, out


def _numbers(summary: dict):
    """Every number in summary.json except the provenance time."""
    return [(c["inputs"], c["results"], c["requirements"]) for c in summary["cases"]], summary["requirements"]


@pytest.fixture(scope="module")
def default_runs(tmp_path_factory, quick_run):
    """"a": the session's quick run of the default scenario; "b": the same again; "c": another seed."""
    tmp = tmp_path_factory.mktemp("runs")
    runs = {"a": quick_run("biomass_default")[1]}
    for name, extra in [("b", []), ("c", ["--set", "simulation.seed=1"])]:
        status, out = _run(tmp, name, *extra)
        assert status == 0
        runs[name] = out
    return runs


def test_default_scenario_writes_every_output(default_runs):
    out = default_runs["a"]
    for name in ("results.h5", "summary.json", "report.md", "report.html"):
        assert (out / name).is_file()
    pngs = list(out.glob("*.png"))
    assert pngs
    report = (out / "report.md").read_text()
    assert "## Requirement verdicts" in report and "PASS" in report
    for png in pngs:
        assert f"]({png.name})" in report
    assert not list(out.glob(".*.tmp"))  # no temporary files left behind
    page = (out / "report.html").read_text()
    assert page.startswith("<!DOCTYPE html>") and page.count("data:image/png;base64,") == len(pngs)
    assert "<table>" in page and "src=\"" not in page.replace('src="data:', "")  # nothing linked from outside


def test_same_seed_gives_identical_numbers(default_runs):
    a = json.loads((default_runs["a"] / "summary.json").read_text())
    b = json.loads((default_runs["b"] / "summary.json").read_text())
    assert _numbers(a) == _numbers(b)


def test_other_seed_changes_monte_carlo_numbers_only(default_runs):
    a = json.loads((default_runs["a"] / "summary.json").read_text())
    c = json.loads((default_runs["c"] / "summary.json").read_text())
    ra, rc = a["cases"][1]["results"], c["cases"][1]["results"]
    assert ra["montecarlo.mean"] != rc["montecarlo.mean"]
    assert ra["montecarlo.variance"] != rc["montecarlo.variance"]
    assert ra["scene.sigma_hv"] == rc["scene.sigma_hv"]
    assert a["seed"] != c["seed"]


def test_summary_json_content(default_runs):
    s = json.loads((default_runs["a"] / "summary.json").read_text())
    assert s["e2esim_version"] == e2esim.__version__
    assert s["n_cases"] == len(s["cases"]) == 5
    names = [r["name"] for r in s["requirements"]]
    assert names == ["AGB error within +-20 % at 99.865 % (system errors)", "AGB RMSE <= 20 %"]
    case = s["cases"][1]
    assert case["inputs"] == {"scene.forest": "boreal_200", "orbit.site.name": "central_siberia",
                              "orbit.site.lat_deg": 60.0, "orbit.site.lon_deg": 92.0}
    assert case["results"]["scene.sigma_hv"] == 0.0726
    req = case["requirements"][0]
    assert set(req) >= {"name", "passed", "value", "limit", "margin", "unit", "basis", "details"}
    assert req["margin"] == pytest.approx(req["limit"] - req["value"])
    assert req["passed"] == (req["value"] <= req["limit"])


def test_results_h5_layout_and_provenance(default_runs):
    with h5py.File(default_runs["a"] / "results.h5", "r") as f:
        assert f.attrs["e2esim_version"] == e2esim.__version__
        assert f.attrs["seed"] == 20250429
        assert "created_utc" in f.attrs
        resolved = yaml.safe_load(f["provenance/resolved_scenario"][()].decode())
        assert resolved["instrument"]["type"] == "biomass"
        assert resolved["instrument"]["crosstalk"]["level_db"] == -30.0  # defaults filled in
        assert f["cases/index"].shape == (5,)
        assert [x.decode() for x in f["cases/inputs/scene.forest"][()]] == [
            "boreal_50", "boreal_200", "boreal_350", "tropical_338", "tropical_341"]
        np.testing.assert_allclose(f["cases/results/scene.sigma_hv"][()], [0.0404, 0.0726, 0.0919, 0.0482, 0.086])
        assert f["requirements/passed"].shape == (5, 2)
        assert f["arrays/case000001/hv_errors"].shape == (400, 1)  # realisations of the quick run
        assert "requirement0/crosstalk_db" in f["arrays/case000001"]
        summary = json.loads((default_runs["a"] / "summary.json").read_text())
        assert f["cases/results/analytic.mean"][1] == summary["cases"][1]["results"]["analytic.mean"]


def test_existing_output_folder_needs_force(default_runs, capsys):
    status = main(["run", str(DEFAULT), "-o", str(default_runs["a"]), "--no-progress"])
    assert status == 2
    assert "exists and is not empty; use --force" in capsys.readouterr().err


def test_json_flag_prints_the_summary(tmp_path, capsys):
    status = main(["run", str(DEFAULT), "-o", str(tmp_path / "j"), "--no-progress", "--json", *QUICK,
                   "--set", "simulation.mode=analytic", "--set", "requirements.0.tradeoff_curve=false",
                   "--set", "requirements.0.level_margins=false"])
    assert status == 0
    printed = json.loads(capsys.readouterr().out)
    on_disk = json.loads((tmp_path / "j" / "summary.json").read_text())
    assert printed == on_disk
    assert "montecarlo.mean" not in printed["cases"][0]["results"]


def test_version_and_help():
    proc = subprocess.run([sys.executable, "-m", "e2esim", "--version"], capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stdout.strip() == f"e2esim {e2esim.__version__}"
    for verb in ("run", "validate", "modules", "reproduce"):
        proc = subprocess.run([sys.executable, "-m", "e2esim", verb, "--help"], capture_output=True, text=True)
        assert proc.returncode == 0 and "usage: e2esim " + verb in proc.stdout
    assert main([]) == 2


def test_modules_lists_every_kind_with_parameters(capsys):
    assert main(["modules", "--json"]) == 0
    records = json.loads(capsys.readouterr().out)
    by_name = {(r["kind"], r["type"]): r for r in records}
    assert ("instrument", "biomass") in by_name and ("scene", "table1_forest") in by_name
    params = {p["name"]: p for p in by_name[("instrument", "biomass")]["parameters"]}
    assert params["crosstalk.level_db"]["default"] == -30.0 and params["crosstalk.level_db"]["unit"] == "dB"
    assert main(["modules", "instrument"]) == 0
    assert "crosstalk.convention" in capsys.readouterr().out
    assert main(["modules", "antenna"]) == 2
