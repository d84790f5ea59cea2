"""summary.json's per-case entries, made from the block columns (``e2esim.io.case_entries``), are byte for byte the
entries of the straightforward construction from each case's ``CaseResult`` (kept here as the reference)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from e2esim.block import Values
from e2esim.io.case_entries import json_safe
from e2esim.io.error_budget import agb_budget, source_groups, verdict_budget
from e2esim.io.summary import summary_dict
from e2esim.runner.columns import Column
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario

SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "biomass_error_budget.yaml"


def _number(x):
    x = float(x)
    return x if np.isfinite(x) else None


def reference_entries(result) -> list:
    """The per-case construction summary.json used before the column one: one ``CaseResult`` per case."""
    cases = []
    for c in result.cases:
        groups = source_groups(c)
        cases.append({
            "index": c.index, "label": c.label, "inputs": c.inputs, "notes": list(c.notes),
            "results": {k: _number(v) for k, v in c.scalars.items()},
            "agb_budget": agb_budget(c.scalars, groups),
            "requirements": [
                {"name": v.name, "status": v.status, "reason": v.reason, "passed": v.passed,
                 "value": _number(v.value), "limit": _number(v.limit), "margin": _number(v.margin), "unit": v.unit,
                 "basis": v.basis, "dominant": v.dominant, "coverage": list(v.coverage),
                 "coverage_text": v.coverage_text, "details": {k: _number(x) for k, x in v.details.items()},
                 "budget": verdict_budget(v, groups), "notes": list(v.notes)}
                for v in c.verdicts]})
    return json_safe(cases)


@pytest.fixture(scope="module")
def hostile_result():
    """biomass_error_budget (two requirements, one not applicable in some cases, AGB and verdict budgets), its
    columns given NaN and infinities, a scalar and a detail missing in some cases, and notes."""
    result = run_scenario(Scenario.load(str(SCENARIO)).resolve(), progress=False)
    block = result.blocks[0]
    n = len(block)
    assert n >= 3 and len(block.requirements) >= 2 and block.products is not None
    names = list(block.scalars)
    block.scalars[names[0]].values[:3] = (np.nan, np.inf, -np.inf)
    masked = block.scalars[names[1]]
    block.scalars[names[1]] = Column(masked.values, np.arange(n) % 2 == 0)
    contribution = next(k for k in block.scalars if k.startswith("agb.contribution.") and k.endswith("rmse_percent"))
    block.scalars[contribution].values[1] = np.nan  # an AGB budget row with a missing RMSE: its sort key
    block.notes = Values([(), ("a note", "another"), ("only one",)], np.arange(n) % 3)
    r = block.requirements[0]
    r.value = np.array(r.value, dtype=float)
    r.value[0] = np.nan
    key = next(k for k in r.details if k.startswith("contribution."))
    r.details[key] = Column(np.where(np.arange(n) == 2, np.inf, r.details[key].values),
                            np.arange(n) != 1)
    other = block.requirements[1]  # not applicable in case 0, its raw columns not normalised (as from a plug-in)
    other.applicable = np.arange(n) != 0
    other.passed = np.ones(n, dtype=bool)
    other.reason = Values.repeated("outside the stated range", n)
    return result


def test_entries_are_the_per_case_construction_byte_for_byte(hostile_result):
    expected = json.dumps(reference_entries(hostile_result), indent=2, allow_nan=False)
    entries = summary_dict(hostile_result)["cases"]
    assert json.dumps(entries, indent=2, allow_nan=False) == expected
    # the case really holds what the test is about: non-finite values as null, notes, several requirements
    assert entries[0]["results"][next(iter(entries[0]["results"]))] is None
    assert entries[1]["notes"] == ["a note", "another"]
    assert len(entries[0]["requirements"]) >= 2 and entries[0]["requirements"][0]["value"] is None
    assert [r["status"] for r in entries[0]["requirements"]][1] == "not_applicable"
    assert entries[0]["requirements"][1]["margin"] is None and entries[1]["requirements"][1]["reason"] == ""
    assert any(e["agb_budget"] for e in entries)
    assert all(e["requirements"][j]["budget"] for e in entries for j in (0, 1))  # per case, and from the columns
