"""The command line and the outputs of a run (issue "Foundation", Build items 5-7 and "Done when")."""

import gc
import json
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

import e2esim
from e2esim.cli import COMMAND_GC_THRESHOLD, main
from e2esim.io.h5_datasets import read_text
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
    """Every number of every case in summary.json (not the provenance, not the labels)."""
    return [(c["index"], c["inputs"], c["results"], c["requirements"]) for c in summary["cases"]]


FIRST_TWO = ("sweep.cases=[{scene.forest: boreal_50, orbit.site.name: central_siberia, orbit.site.lat_deg: 60.0, "
             "orbit.site.lon_deg: 92.0}, {scene.forest: boreal_200, orbit.site.name: central_siberia, "
             "orbit.site.lat_deg: 60.0, orbit.site.lon_deg: 92.0}]")
"""The first two cases of the default scenario: a case's numbers depend only on the seed and its index."""


@pytest.fixture(scope="module")
def default_runs(tmp_path_factory, quick_run):
    """"a": the session's quick run of the default scenario; "b": its first two cases again, in another run;
    "c": the same two cases with another seed. "b" and "c" are read for their numbers only: they draw none of
    the auto plots ("a" has them), a second of CPU each."""
    tmp = tmp_path_factory.mktemp("runs")
    runs = {"a": quick_run("biomass_default")[1]}
    for name, extra in [("b", ["--set", FIRST_TWO]), ("c", ["--set", FIRST_TWO, "--set", "simulation.seed=1"])]:
        status, out = _run(tmp, name, *extra, "--set", "output.plots=[error_budget]")
        assert status == 0
        runs[name] = out
    return runs


def test_the_command_line_runs_with_workers_auto_and_says_what_it_chose(default_runs):
    summary = json.loads((default_runs["b"] / "summary.json").read_text())  # two cases: one block, run here
    assert summary["workers"] == "auto: this process (one block)" and "executor" not in summary


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
    assert len(b["cases"]) == 2 and _numbers(a)[:2] == _numbers(b)


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
    assert names == ["AGB error within +-20 % at 99.865 % (system errors)", "AGB RMSE <= 20 % (computed sources)"]
    case = s["cases"][1]
    assert case["inputs"] == {"scene.forest": "boreal_200", "orbit.site.name": "central_siberia",
                              "orbit.site.lat_deg": 60.0, "orbit.site.lon_deg": 92.0}
    assert case["results"]["scene.sigma_hv"] == 0.0726
    req = case["requirements"][0]
    assert set(req) >= {"name", "passed", "value", "limit", "margin", "unit", "basis", "details"}
    assert req["margin"] == pytest.approx(req["limit"] - req["value"])
    assert req["passed"] == (req["value"] <= req["limit"]) and req["status"] == ("pass" if req["passed"] else "fail")


def test_results_h5_layout_and_provenance(default_runs):
    with h5py.File(default_runs["a"] / "results.h5", "r") as f:
        assert f.attrs["e2esim_version"] == e2esim.__version__
        assert f.attrs["seed"] == 20250429
        assert "created_utc" in f.attrs
        resolved = yaml.safe_load(f["provenance/resolved_scenario"][()].decode())
        assert resolved["instrument"]["type"] == "biomass"
        assert resolved["instrument"]["crosstalk"]["level_db"] == -30.0  # defaults filled in
        assert f["cases/index"].shape == (5,)
        assert f["cases/inputs/scene.forest"].dtype.kind == "u"  # codes into the distinct texts (format 3)
        assert read_text(f["cases/inputs/scene.forest"]).tolist() == [
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
                   "--set", FIRST_TWO, "--set", "simulation.mode=analytic",
                   "--set", "requirements.0.tradeoff_curve=false", "--set", "requirements.0.level_margins=false"])
    assert status == 0
    printed = json.loads(capsys.readouterr().out)
    on_disk = json.loads((tmp_path / "j" / "summary.json").read_text())
    assert printed == on_disk
    assert "montecarlo.mean" not in printed["cases"][0]["results"]


def test_version_and_help(capsys):
    # `python -m e2esim` in a fresh interpreter once (the module entry point); the verbs' help in this process
    proc = subprocess.run([sys.executable, "-m", "e2esim", "--version"], capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stdout.strip() == f"e2esim {e2esim.__version__}"
    for verb in ("run", "validate", "modules", "reproduce"):
        with pytest.raises(SystemExit) as exit_:
            main([verb, "--help"])
        assert exit_.value.code == 0 and "usage: e2esim " + verb in capsys.readouterr().out
    assert main([]) == 2


def test_the_command_line_leaves_its_objects_to_the_os_and_a_call_does_not(capsys):
    """The process's own command line (``main()``) collects its youngest generation less often and freezes the
    garbage collector before the process ends, so that the interpreter's teardown does not search its objects for
    cycles; ``main(argv)`` called in a process that goes on (these tests, a notebook) leaves the collector as it
    was."""
    code = ("import atexit, gc, sys\nfrom e2esim.cli import main\n"
            "atexit.register(lambda: print('frozen at exit:', gc.get_freeze_count() > 0, gc.get_threshold()[0]))\n"
            "sys.argv = ['e2esim', 'modules', 'scene']\nprint('status:', main())\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.splitlines()[-2:] == ["status: 0", f"frozen at exit: True {COMMAND_GC_THRESHOLD}"]
    frozen, threshold = gc.get_freeze_count(), gc.get_threshold()
    assert main(["modules", "scene"]) == 0 and (gc.get_freeze_count(), gc.get_threshold()) == (frozen, threshold)


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


# Issue 11: a report a mission review can use ---------------------------------------------------------------
def test_report_first_screen_answers_the_question(default_runs):
    out = default_runs["a"]
    s = json.loads((out / "summary.json").read_text())
    report = (out / "report.md").read_text()
    worst = s["cases"][0]["requirements"][1]  # RMSE of every source, case 0 is the worst
    assert s["requirements"][1]["sources"] == "computed" and s["requirements"][0]["sources"] == "systematic"
    sentence = next(line for line in report.splitlines() if line.startswith("**FAIL** AGB RMSE"))
    assert "(computed sources) fails in 5 of 5 cases" in sentence
    assert "no regression/retrieval-model term in this chain" in sentence  # what it covers, from the chain
    assert f"{worst['value']:.3g} % against a limit of 20 %" in sentence
    speckle = worst["details"]["contribution.speckle_noise_percent"]
    alone = s["cases"][0]["results"]["agb.contribution.speckle_noise.rmse_percent"]
    assert f"speckle and noise contributes most (without it the value would be {speckle:.3g} percentage" in sentence
    assert f"on its own it gives an RMSE of {alone:.3g} of the {worst['value']:.3g} %" in sentence
    # the conclusions come before the first table, the budget before the plots, long tables are not collapsed
    assert report.index("## Conclusions") < report.index("## Requirement verdicts") < report.index("## Error budget")
    assert report.index("## Error budget") < report.index("## Plots") < report.index("## Cases")
    page = (out / "report.html").read_text()
    assert page.count('<span class="badge fail">FAIL</span>') >= 6 and '<span class="badge pass">PASS</span>' in page
    assert "AGB error 99.865 %, computed sources" in report and "(all sources)" not in report


def test_error_budget_in_summary_is_the_verdicts_attribution(default_runs):
    s = json.loads((default_runs["a"] / "summary.json").read_text())
    for case in s["cases"]:
        for req in case["requirements"]:
            budget = {r["source"]: r for r in req["budget"]}
            keys = [k for k in req["details"] if k.startswith("contribution.")]
            assert len(budget) == len(keys) > 0
            for k in keys:
                source = k[len("contribution."):-len("_percent")]
                assert budget[source]["contribution"] == req["details"][k] and budget[source]["unit"] == "%"
        groups = {r["source"]: r["group"] for r in case["requirements"][1]["budget"]}
        assert groups["speckle_noise"] == "random" and groups["crosstalk"] == "systematic"
        assert set(groups) > {r["source"] for r in case["requirements"][0]["budget"]}  # systematic only
        agb = {r["source"]: r for r in case["agb_budget"]}
        assert agb["speckle_noise"]["rmse_percent"] == case["results"]["agb.contribution.speckle_noise.rmse_percent"]
    assert "![" in (default_runs["a"] / "report.md").read_text().split("## Error budget")[1].split("## ")[0]


def test_margins_are_given_to_the_specification_and_to_the_residual(default_runs):
    s = json.loads((default_runs["a"] / "summary.json").read_text())
    d = s["cases"][0]["requirements"][0]["details"]
    # the scenario states crosstalk -30 dB and channel imbalance -34 dB (3-sigma), NESZ -27 dB
    assert d["crosstalk.spec_db"] == -30.0 and d["channel_imbalance.spec_db"] == -34.0 and d["nesz.spec_db"] == -27.0
    for level in ("crosstalk", "channel_imbalance", "nesz"):
        assert d[f"{level}.spec_margin_db"] == pytest.approx(d[f"{level}.limit_db"] - d[f"{level}.spec_db"])
        assert d[f"{level}.margin_db"] == pytest.approx(d[f"{level}.limit_db"] - d[f"{level}.residual_db"])
    # the transponder calibration leaves less crosstalk than specified: the two margins differ
    assert d["crosstalk.residual_db"] < d["crosstalk.spec_db"] - 1.0
    assert d["crosstalk.margin_db"] > d["crosstalk.spec_margin_db"] + 1.0
    report = (default_runs["a"] / "report.md").read_text()
    assert "margin to the specification (dB)" in report and "margin to the residual (dB)" in report


def test_assumptions_list_the_preset_values_with_their_sources(default_runs):
    report = (default_runs["a"] / "report.md").read_text()
    section = report.split("## Assumptions")[1].split("\n## ")[0]
    row = next(line for line in section.splitlines() if "observation.speckle_diverse_observations" in line)
    assert "| 1 |" in row and "speckle identical" in row and "budget preset 'biomass_200m'" in row
    assert next(line for line in section.splitlines() if "observation.observations`" in line).count("| 3 |") == 1
    assert "| `propagation.1.temporal.sd_percent` | 5 % | the scenario |" in section
    s = json.loads((default_runs["a"] / "summary.json").read_text())
    looks = sorted(c["results"]["budget.looks"] for c in s["cases"])
    assert f"| looks of the product (speckle) | {looks[0]:.3g} to {looks[-1]:.3g} |" in section or \
        f"| looks of the product (speckle) | {looks[0]:.3g} |" in section
    assert "| `instrument.crosstalk.level_db` | -30 dB | default of instrument type 'biomass'" in section
    assert "| `ionosphere.tec_variability` | 0.25 | the scenario |" in section


def test_default_report_draws_every_requested_plot(default_runs):
    out = default_runs["a"]
    report = (out / "report.md").read_text()
    assert "Warning" not in report
    for name in ("verdicts", "tradeoff", "error_histograms", "faraday_distributions", "error_budget", "site_map"):
        assert (out / f"{name}.png").is_file(), name
    assert "residual after calibration" in report  # the trade-off plot marks both points


def test_results_h5_stores_acquisitions_and_provenance(default_runs):
    import shutil

    with h5py.File(default_runs["a"] / "results.h5") as f:
        acq = f["acquisitions/case000000"]
        n = acq["omega_deg"].shape[0]
        assert (
            n == 7 * 2 * 2 and acq["incidence_deg"].shape == (n,) and acq["time_utc"].shape == (n,)
        )  # quick run: 7 dates, 2 passes, 2 swath positions
        inc = acq["incidence_deg"][()]
        assert inc.min() >= 23.0 - 1e-9 and inc.max() <= 33.75 + 1e-9  # the BIOMASS swath
        assert acq["weight"][()].sum() == pytest.approx(1.0)
        assert {x.decode() for x in acq["pass_label"][()]} == {"dawn", "dusk"}
        assert acq["omega_deg"].attrs["units"] == "deg"
        commit = f.attrs.get("source_commit")
    if shutil.which("git") and (ROOT / ".git").exists():
        described = subprocess.run(["git", "describe", "--always", "--dirty", "--tags"], cwd=ROOT, capture_output=True,
                                   text=True).stdout.strip()
        assert commit is not None and commit.split("-dirty")[0] == described.split("-dirty")[0]
