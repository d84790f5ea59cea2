"""The campaign's schedule search decided by the requirement itself, through the chain (issue 25, item 6): the
answer's schedule keeps the AGB requirement met at every date after commissioning when the campaign runs through
the normal chain, every cheaper schedule fails there, and the worst epochs the search keeps (the Pareto-maximal
residual dates) are the true worst of every date."""

from __future__ import annotations

import numpy as np
import pytest

from e2esim.campaign.campaign import worst_candidates
from e2esim.flowdown.campaign_schedule import campaign_answer
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario
from quick_runs import quick_overrides

NAME = "biomass_calibration_campaign"
SCENARIO = f"scenarios/{NAME}.yaml"


def _chain_margins(rows: list, raw: dict) -> np.ndarray:
    """The requirement's margin of the normal chain (the campaign module stating its residual at epoch_day) for
    rows of (transponder_per_year, opportunity, epoch_day)."""
    raw = {**raw, "output": {**raw.get("output", {}), "answer": False}}
    raw["sweep"] = {"mode": "grid", "parameters": {
        "calibration.0.transponder_per_year, calibration.0.opportunity, calibration.0.epoch_day": rows}}
    result = run_scenario(Scenario(raw, SCENARIO).resolve(), progress=False)
    return np.asarray(result.table.requirements[0].margin, float)


def test_the_answer_passes_through_the_chain_and_every_cheaper_schedule_fails():
    scenario = Scenario.load(SCENARIO, quick_overrides(NAME))
    answer = campaign_answer(scenario.resolve())
    assert answer["question"] == "campaign_schedule"
    found = answer["result"]
    schedules = found["schedules"]
    best = schedules[found["best"]]
    cheaper = [s for s in schedules if s["cost"] < best["cost"]]
    assert cheaper, "the quick scenario's answer must have cheaper schedules to compare with"
    step = scenario.raw["calibration"][0]["step_days"]
    epochs = np.arange(91.0 + step - 91.0 % step if 91.0 % step else 91.0, 5 * 365.25, step)
    # no target of opportunity is the empty list (null is all of them)
    def row(s, day):
        return [s["transponder_per_year"], s["opportunity"], float(day)]

    rows = [row(best, d) for d in epochs] + [row(s, s["worst_epoch_day"]) for s in cheaper]
    margins = _chain_margins(rows, scenario.raw)
    # the search's worst epoch and margin are the chain's, over every date after commissioning
    assert np.min(margins[:epochs.size]) == pytest.approx(best["requirement_margin"], rel=1e-9, abs=1e-9)
    assert epochs[np.argmin(margins[:epochs.size])] == best["worst_epoch_day"]
    assert np.min(margins[:epochs.size]) >= 0
    assert margins[epochs.size:] == pytest.approx([s["requirement_margin"] for s in cheaper], rel=1e-9, abs=1e-9)
    assert np.all(margins[epochs.size:] < 0)
    assert f"day {best['worst_epoch_day']:g}" in answer["lines"][0]


def test_worst_candidates_keep_exactly_the_undominated_dates(rng):
    v = rng.random((3, 200))
    kept = worst_candidates(v)
    dominated = [i for i in range(200) if any(np.all(v[:, k] >= v[:, i]) and k != i for k in range(200))]
    assert sorted(set(range(200)) - set(dominated)) == list(kept)
    # the maximum of any increasing function of the three variances lies among them
    f = v[0] + 3 * v[1] ** 2 + np.exp(v[2])
    assert np.argmax(f) in kept
