"""Allocation tables (issue 23, item 2): a requirement allots its limit to error sources (``allocation_percent``,
``allocation_share``); the verdict, summary.json, results.h5 and the report's first screen compare each allocation
with the source's share of the checked value, and bad allocations are clear errors with exit status 2."""

from __future__ import annotations

import json

import h5py
import pytest

from e2esim.cli import main
from quick_runs import SCENARIOS, quick_overrides

DEFAULT = SCENARIOS / "biomass_default.yaml"
SHARES = "requirements.1.allocation_share={speckle_noise: 0.6, temporal: 0.15, area_projection: 0.1, noise: 0.05}"


@pytest.fixture(scope="module")
def allocated(tmp_path_factory):
    """The default scenario's quick run with allocation shares; read for its numbers and report, not its plots: it
    draws none of the auto plots (those of the default scenario are checked on its quick run), a second of CPU less."""
    out = tmp_path_factory.mktemp("allocated")
    only_budget = "output.plots=[error_budget]"
    sets = [a for s in (*quick_overrides("biomass_default"), SHARES, only_budget) for a in ("--set", s)]
    assert main(["run", str(DEFAULT), "-o", str(out), "--no-progress", "--force", *sets]) == 0
    return out


def test_each_allocation_is_compared_with_the_sources_share(allocated):
    summary = json.loads((allocated / "summary.json").read_text())
    allotted = {"speckle_noise": 0.6, "temporal": 0.15, "area_projection": 0.1, "noise": 0.05}
    for case in summary["cases"]:
        v = case["requirements"][1]
        d = v["details"]
        for source, fraction in allotted.items():
            assert d[f"allocation.{source}_percent"] == pytest.approx(20.0 * fraction, rel=1e-12)
            assert d[f"allocation_margin.{source}_percent"] == pytest.approx(
                20.0 * fraction - d[f"share.{source}_percent"], rel=1e-12, abs=1e-12)
        assert d["allocation.total_percent"] == 20.0
        assert d["allocation.unallocated_percent"] == pytest.approx(20.0 * (1 - sum(allotted.values())), rel=1e-12)
        assert not any(k.startswith("allocation") for k in case["requirements"][0]["details"])  # none given there
    table = summary["requirements"][1]["allocation"]
    worst = summary["requirements"][1]["worst_case"]
    assert table["case"] == worst and table["unit"] == "%"
    rows = {r["source"]: r for r in table["rows"]}
    assert set(allotted) < set(rows) and "interactions" in rows
    # at the worst case the estimates add up to the checked value, and the total is the verdict's own
    value = summary["cases"][worst]["requirements"][1]["value"]
    assert sum(r["estimate"] for r in table["rows"]) == pytest.approx(value, rel=1e-12)
    assert table["total"] == pytest.approx({"allocation": 20.0, "estimate": value, "margin": 20.0 - value})
    for source in allotted:
        margins = [c["requirements"][1]["details"][f"allocation_margin.{source}_percent"] for c in summary["cases"]]
        assert rows[source]["worst_margin"] == min(margins) and margins[rows[source]["worst_case"]] == min(margins)
    assert "allocation" not in summary["requirements"][0]
    with h5py.File(allocated / "results.h5") as f:
        column = f["requirements/details/1/allocation_margin.speckle_noise_percent"][:]
    assert list(column) == [c["requirements"][1]["details"]["allocation_margin.speckle_noise_percent"]
                            for c in summary["cases"]]


def test_the_allocation_table_is_on_the_reports_first_screen(allocated):
    report = (allocated / "report.md").read_text()
    table = report.index("(computed sources): allocation")
    assert report.index("## Requirement verdicts") < table < report.index("## Error budget")
    assert "| speckle and noise | 12 |" in report and "| **total** | **20** |" in report


@pytest.mark.parametrize(("setting", "message"), [
    ("requirements.1.allocation_share={speckle: 0.5}",
     "no error source 'speckle' in this chain; sources of this requirement's checked value: crosstalk, "
     "channel_imbalance, noise, faraday_rotation, gain, speckle_noise"),
    ("requirements.0.allocation_percent={speckle_noise: 5}",  # a systematic requirement has no random terms
     "no error source 'speckle_noise' in this chain; sources of this requirement's checked value: crosstalk"),
    ("requirements.1.allocation_share={speckle_noise: 0.7, temporal: 0.4}", "the allocation shares sum to 1.1"),
    ("requirements.1.allocation_share={speckle_noise: 1.5}", "allocation_share.speckle_noise: 1.5 is out of range"),
    ("requirements.1.allocation_percent={noise: -2}", "allocation_percent.noise: -2 is out of range"),
    ("requirements.1.allocation_percent=[1, 2]", "allocation_percent: [1, 2] is not a mapping"),
    ("requirements.1.allocation_percent={noise: 1}", "allocation_percent, allocation_share are all given"),
])
def test_bad_allocations_are_clear_errors_with_status_2(setting, message, tmp_path, capsys):
    sets = [a for s in (*quick_overrides("biomass_default"), "orbit.acquisitions.step_days=180", setting)
            for a in ("--set", s)]
    if "are all given" in message:
        sets += ["--set", "requirements.1.allocation_share={noise: 0.1}"]
    assert main(["run", str(DEFAULT), "-o", str(tmp_path / "o"), "--no-progress", *sets]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
