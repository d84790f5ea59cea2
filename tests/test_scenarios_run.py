"""Every scenario in scenarios/ runs and writes its outputs: once at reduced sizes in the default suite (the
shared ``quick_run``), at its own sizes in the slow suite. Where a case has both the analytic moments and the
Monte Carlo, they must agree within sampling uncertainty (eq. 18 of Men et al. 2021, with its standard
errors), which holds for any seed."""

import json

import numpy as np
import pytest

from e2esim.cli import main
from quick_runs import SCENARIOS, scenario_names

Z_MAX = 5.0  # two-sided false-failure probability 6e-7 per comparison


def _check_outputs(folder, cases=None):
    summary = json.loads((folder / "summary.json").read_text())
    assert (folder / "results.h5").is_file() and (folder / "report.html").is_file()
    pngs = sorted(p.name for p in folder.glob("*.png"))
    assert pngs, "no plot written"
    report = (folder / "report.md").read_text()
    assert all(f"]({png})" in report for png in pngs)
    assert not list(folder.glob(".*.tmp")), "a temporary file was left behind"
    if cases is not None:  # what was written is what was computed
        for written, case in zip(summary["cases"], cases):
            for key, value in case.scalars.items():
                if np.isfinite(value):
                    assert written["results"][key] == value, key
    assert "**Warning:**" not in report, "a requested plot was not drawn"  # issue 11: plots that went missing
    if summary["requirements"]:
        assert "## Error budget" in report and (folder / "error_budget.png").is_file()
    if summary["scenario"] == "biomass_latitude_sweep":
        _check_large_sweep_report(folder, report)
    for case in summary["cases"]:
        r = case["results"]
        if "comparison.var_rel_diff" in r and not case["notes"]:
            assert abs(r["comparison.bias_rel_diff"] / r["comparison.bias_rel_se"]) < Z_MAX, case["label"]
            assert abs(r["comparison.var_rel_diff"] / r["comparison.var_rel_se"]) < Z_MAX, case["label"]
    return summary


def _check_large_sweep_report(out, report):
    """The 120-case latitude sweep: plots against latitude, every case's Faraday rotation, tables collapsed."""
    assert "Requirement margins against site latitude (deg)" in report
    assert "One-way Faraday rotation before any correction against site latitude (deg), every case" in report
    assert "<details><summary>Every case (120 rows)</summary>" in report
    assert report.index("![") < report.index("<details><summary>Every case")
    assert (out / "site_map.png").is_file() and "against a limit of 20 %" in report


@pytest.mark.parametrize("name", scenario_names())
def test_scenario_runs_and_writes_its_outputs(name, quick_run):
    result, folder = quick_run(name)
    summary = _check_outputs(folder, result.cases)
    assert summary["n_cases"] == len(result.cases) == len(summary["cases"])
    for row in summary["requirements"]:
        assert row["passed_cases"] + row["failed_cases"] + row["not_applicable_cases"] == summary["n_cases"]


@pytest.mark.slow
@pytest.mark.parametrize("name", scenario_names())
def test_scenario_at_full_size(name, tmp_path):
    out = tmp_path / name
    assert main(["run", str(SCENARIOS / f"{name}.yaml"), "-o", str(out), "--no-progress"]) == 0
    _check_outputs(out)


def test_tradeoff_scenario_reports_axis_crossings(quick_run):
    _, folder = quick_run("men2021_tradeoff_over")
    s = json.loads((folder / "summary.json").read_text())
    fig6 = s["cases"][2]  # boreal 350 t/ha
    assert fig6["inputs"]["scene.forest"] == "boreal_350"
    details = fig6["requirements"][2]["details"]  # 20 % at 99.865 %
    assert details["over.crosstalk_axis_db"] == pytest.approx(-20.166, abs=0.005)  # Fig. 6: -20.16 dB
