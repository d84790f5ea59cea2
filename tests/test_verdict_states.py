"""Three states (issue 21, item 3): a verdict passes, fails, or does not apply (with its reason); a case the
requirement does not apply to has no margin, never counts as passing and is never drawn as a margin, in
summary.json, results.h5, ``Results``, the report, the site map and ``e2esim compare``."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
import yaml

import e2esim
from e2esim.cli import main
from e2esim.compare import compare_report
from e2esim.requirements.verdict import RequirementVerdict, RequirementVerdicts
from e2esim.results import Results
from e2esim.runner.columns import batched_requirement_columns
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario

SMALL = """
name: states
scene: {type: table1_forest}
instrument: {type: biomass}
ionosphere: {type: gaussian_faraday, mean_deg: 60, sd_deg: 5}
propagation: [{type: hv_backscatter_error}, {type: backscatter_error_budget}]
requirements:
  - {type: agb_rmse_absolute, max_t_ha: 20, applies_below_t_ha: 100}
simulation: {mode: analytic}
sweep:
  parameters:
    scene.forest: [boreal_50, boreal_200, boreal_350]
"""


def test_nisar_cases_outside_the_range_are_not_applicable_not_passing(quick_run):
    """nisar_lband stored {"passed": true, "value": 186.06, "limit": 20.0, "margin": -166.06} for the 100 t/ha cases,
    outside "AGB < 100 t/ha", and its site map coloured them at about -165 t/ha."""
    result, folder = quick_run("nisar_lband")
    summary = json.loads((folder / "summary.json").read_text())
    outside = [c for c in summary["cases"] if c["inputs"]["scene.agb_t_ha"] >= 100]
    inside = [c for c in summary["cases"] if c["inputs"]["scene.agb_t_ha"] < 100]
    assert len(outside) == 4 and len(inside) == 8
    for c in outside:
        v = c["requirements"][0]
        assert (v["status"], v["passed"], v["margin"]) == ("not_applicable", False, None)
        assert "not below 100 t/ha" in v["reason"] and v["value"] > 100  # the value is kept; no margin
        assert c["results"]["requirement0.passed"] is None and c["results"]["requirement0.margin"] is None
    for c in inside:
        v = c["requirements"][0]
        assert v["status"] in ("pass", "fail") and v["passed"] == (v["status"] == "pass") and v["reason"] == ""
        assert v["margin"] == pytest.approx(v["limit"] - v["value"])
    overview = summary["requirements"][0]
    margins = [c["requirements"][0]["margin"] for c in inside]
    assert overview["not_applicable_cases"] == 4
    assert overview["passed_cases"] + overview["failed_cases"] == 8
    assert overview["passed_cases"] == sum(c["requirements"][0]["status"] == "pass" for c in inside)
    assert overview["worst_margin"] == min(margins) and overview["status"] == "fail"
    # Results, from the run and read back from results.h5
    for results in (Results.from_run(result), e2esim.open_results(folder)):
        na = results.status[:, 0] == "not_applicable"
        assert na.sum() == 4 and not results.passed[na, 0].any() and np.isnan(results.margin[na, 0]).all()
        assert np.isnan(results.scalars["requirement0.passed"][na]).all()
    # the site map: each site's worst margin over the cases the requirement applies to, never -165 t/ha
    from e2esim.report.map_plots import site_margins, site_position

    positions = [site_position(c) for c in result.cases]
    sites = sorted(set(positions))
    worst = site_margins(result.cases, positions, {p: i for i, p in enumerate(sites)}, 0)
    for p, w in zip(sites, worst):
        assert w == min(c.verdicts[0].margin for c, q in zip(result.cases, positions)
                        if q == p and c.verdicts[0].status != "not_applicable")
        assert w > -50


def test_a_verdict_that_does_not_apply_has_no_margin_and_does_not_pass():
    v = RequirementVerdict("r", True, 186.0, 20.0, -166.0, "t/ha", "analytic", applicable=False, reason="outside")
    assert (v.status, v.passed, v.reason) == ("not_applicable", False, "outside") and np.isnan(v.margin)
    w = RequirementVerdict("r", True, 12.0, 20.0, 8.0, "t/ha", "analytic", reason="outside")
    assert (w.status, w.passed, w.margin, w.reason) == ("pass", True, 8.0, "")
    block = RequirementVerdicts((RequirementVerdict(
        "r", np.array([True, True, False]), np.array([1.0, 186.0, 30.0]), 20.0, np.array([19.0, -166.0, -10.0]),
        "t/ha", "analytic", applicable=np.array([True, False, True]), reason="outside"),), 3)
    assert [block.item(i)[0].status for i in range(3)] == ["pass", "not_applicable", "fail"]
    assert [block.item(i)[0].reason for i in range(3)] == ["", "outside", ""]
    columns = batched_requirement_columns(block)[0]
    assert columns.status.tolist() == ["pass", "not_applicable", "fail"]
    np.testing.assert_array_equal(columns.margin, [19.0, np.nan, -10.0])
    np.testing.assert_array_equal(block.scalar_columns()["requirement0.passed"], [1.0, np.nan, 0.0])


def test_report_cli_and_summary_name_the_not_applicable_cases(tmp_path, capsys):
    path = tmp_path / "states.yaml"
    path.write_text(SMALL)
    assert main(["run", str(path), "-o", str(tmp_path / "out"), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "cases pass, 2 not applicable; worst margin" in out
    report = (tmp_path / "out" / "report.md").read_text()
    assert "**N/A** (" in report and "not applicable: the case's AGB is not below 100 t/ha" in report
    assert "1/1 (2 N/A)" in report
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert [c["requirements"][0]["status"] for c in summary["cases"]][1:] == ["not_applicable"] * 2


def test_a_requirement_that_applies_to_no_case_has_no_worst_margin(tmp_path):
    data = yaml.safe_load(SMALL)
    data["requirements"][0]["applies_below_t_ha"] = 10
    result = run_scenario(Scenario(data, "none.yaml").resolve(), progress=False)
    from e2esim.io.summary import requirement_overview
    from e2esim.report.document import verdict_lines

    row = requirement_overview(result)[0]
    assert row["status"] == "not_applicable" and row["worst_case"] is None and np.isnan(row["worst_margin"])
    assert not row["all_passed"] and row["passed_cases"] == row["failed_cases"] == 0
    assert verdict_lines(result)[0].startswith("N/A  ") and "applies to none of the 3 cases" in verdict_lines(result)[0]


def test_compare_tells_not_applicable_from_pass_and_fail():
    data = yaml.safe_load(SMALL)
    a = e2esim.run(data)
    data["requirements"][0]["applies_below_t_ha"] = 1000
    data["requirements"][0]["name"] = a.requirements[0]  # the same requirement, another range
    b = e2esim.run(data)
    text, differ = compare_report(a, b, "A", "B")
    assert differ and "| N/A (speckle_noise) | FAIL (speckle_noise) |" in text


def test_a_results_file_of_format_3_reads_its_out_of_range_cases_as_not_applicable(tmp_path):
    data = yaml.safe_load(SMALL)
    e2esim.run(data, output=tmp_path / "run")
    path = tmp_path / "run" / "results.h5"
    with h5py.File(path, "r+") as f:  # as format 3 wrote it: passing, with a margin, and an applies detail
        req = f["requirements"]
        for name in ("status", "reason", "coverage_sources", "coverage_text"):
            del req[name], req[f"{name}_text"]
        passed, margin, value = req["passed"][()], req["margin"][()], req["value"][()]
        passed[1:, 0] = True
        margin[1:, 0] = 20.0 - value[1:, 0]
        req["passed"][...], req["margin"][...] = passed, margin
        req["details/0"].create_dataset("applies", data=np.array([1.0, 0.0, 0.0]))
        f.attrs["format_version"] = 3
    old = e2esim.open_results(path)
    assert old.status[1:, 0].tolist() == ["not_applicable"] * 2 and old.status[0, 0] in ("pass", "fail")
    assert not old.passed[1:, 0].any() and np.isnan(old.margin[1:, 0]).all()
    assert old.verdict_table(0)["reason"].tolist()[1:] == ["outside the requirement's AGB range"] * 2
