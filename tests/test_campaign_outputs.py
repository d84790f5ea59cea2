"""The campaign scenario's outputs (issue 25, items 5 and 6): summary scalars, results.h5's daily series and the
schedule search agree with each other, and the search's answer is the cheapest schedule that keeps the limits."""

from __future__ import annotations

import json

import h5py
import numpy as np

NAME = "biomass_calibration_campaign"


def test_summary_results_h5_and_the_schedule_answer_agree(quick_run):
    _, folder = quick_run(NAME)
    summary = json.loads((folder / "summary.json").read_text())
    with h5py.File(folder / "results.h5") as f:
        g = f["campaign"]
        day, xt, margin = g["day"][:], g["residual_crosstalk_db"][:], g["margin_db"][:]
        per_year, margins = g["schedule_transponder_per_year"][:], g["schedule_margin_db"][:]
        opportunity = [json.loads(o) for o in g["schedule_opportunity"].asstr()[:]]
        answer = int(g.attrs["schedule_answer"])
        used, site = g["visit_used"][:], g["visit_site"][:]
    assert day[0] == 0 and np.all(np.diff(day) > 0)
    prefix = "calibration.0.campaign."
    for case in summary["cases"]:
        values = case["results"]
        i = int(np.argmin(np.abs(day - values[prefix + "epoch_day"])))
        assert values[prefix + "residual_crosstalk_db"] == np.float64(xt[i])
        assert values[prefix + "worst_epoch_day"] == day[int(np.argmin(margin))]
        assert values[prefix + "visits_used"] == used.sum()
        # the scenario's instrument gives the frequency; the orbit is tuned to 44 revolutions in 3 days
        assert (values[prefix + "frequency_hz"], values[prefix + "frequency_assumed"]) == (435e6, 0)
        assert (values[prefix + "repeat_revolutions"], values[prefix + "repeat_days"]) == (44, 3.0)
    assert np.all(np.isinf(margin[day < 91])) and np.all(np.isfinite(margin[day >= 91]))
    cost = per_year + np.array([len(o) for o in opportunity])
    if answer >= 0:
        assert margins[answer] >= 0
        assert not np.any((margins >= 0) & (cost < cost[answer]))
        last = summary["cases"][0]["results"]
        assert last[prefix + "schedule_transponder_per_year"] == per_year[answer]
    else:
        assert np.all(margins < 0)
    assert set(site[used == 1]) <= set(range(4))
