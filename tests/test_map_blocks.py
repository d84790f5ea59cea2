"""Map sweeps run block by block (issue 14): one scene and one ionosphere module for every cell, month and pass
(``Stage.case_params``), and block products that give each case exactly its one-case products."""

from __future__ import annotations

import numpy as np
import pytest

from e2esim.errors import ConfigError
from e2esim.faraday.climatology import FaradayClimatology
from e2esim.runner.blocks import BlockRun
from e2esim.runner.run import default_services, run_case
from e2esim.runner.scenario import Scenario


def test_a_block_of_map_cases_gets_each_cases_own_climatology_and_scene(quick_run):
    result, _ = quick_run("biomass_global_map")
    resolved = result.scenario
    plan = resolved.plan
    slots = {s.kind: s for s in plan.slots}
    assert len(slots["scene"].objects) == 1 and slots["scene"].case_keys == ("scene.lat_deg", "scene.lon_deg")
    assert len(slots["ionosphere"].objects) == 1 and len(slots["ionosphere"].case_keys) == 5
    indices = np.arange(len(resolved.cases))
    products = BlockRun(plan, indices, default_services()).run()
    faraday = products["faraday.geophysical"]
    assert isinstance(faraday, FaradayClimatology) and products["faraday.residual"] is faraday
    assert faraday.case_shape == (len(indices),)
    columns, weights, trig = faraday.scalar_columns(), faraday.even_quadrature()[1], faraday.trig_moments()
    seen = np.isfinite(faraday.acquisition_omega).sum(-1)
    picks = {0, len(indices) - 1, int(np.argmin(seen)), int(np.argmax(seen))}  # cells seen at fewer positions
    for k in sorted(picks):
        case = run_case(resolved.cases[k], default_services())
        one = case.products["faraday.geophysical"]
        item = faraday.item(k)
        assert item.label == one.label and one.label.startswith("global climatology ")
        assert np.array_equal(item.samples, one.samples) and np.array_equal(item.weights, one.weights)
        for name in ("acquisition_omega", "vtec", "stec", "b_dot_k", "range_delay_m", "phase_advance_rad",
                     "pass_label", "acquisition_weight"):  # what results.h5 writes per acquisition
            assert np.array_equal(getattr(item, name), getattr(one, name), equal_nan=name != "pass_label"), name
        assert (item.site, item.frequency_hz, item.f107, item.method) == (one.site, one.frequency_hz, one.f107,
                                                                          one.method)
        assert item.describe() == one.describe() and item.item(0) is item  # one case: a block of one
        for name, value in one.scalars().items():  # bit for bit, not to a tolerance
            assert columns[name][k] == value or (np.isnan(value) and np.isnan(columns[name][k])), name
        assert np.array_equal(weights[k], one.even_quadrature()[1])
        assert all(trig[name][k] == value for name, value in one.trig_moments().items())
        assert products["scene.covariance"].item(k) is case.products["scene.covariance"]
        assert faraday.item(k) is item  # made once per block: the error model, its wrappers and the AGB error share it
    part = faraday.take(np.array(sorted(picks)))
    assert "_items" not in vars(part) and part.item(0).mean_rad == faraday.item(min(picks)).mean_rad
    assert np.array_equal(part.mean_rad, faraday.mean_rad[sorted(picks)])
    joined = FaradayClimatology.concatenate([part, faraday])  # parts with different items made: a fresh memo
    assert "_items" not in vars(joined) and len(joined) == len(part) + len(faraday)
    assert joined.item(len(part)).label == faraday.item(0).label
    assert len(products["scene.covariance"].values) == 2  # the tropical and the boreal forest, not one per cell


def test_values_a_sweep_gives_a_case_parameter_are_each_validated():
    raw = {"scene": {"type": "forest_agb_model", "biome": "tropical"}, "instrument": {"type": "biomass"},
           "ionosphere": {"type": "global_climatology", "lat_deg": 0.5, "lon_deg": 20.5, "month": 1},
           "sweep": {"parameters": {"ionosphere.month": [1, 13]}}}
    with pytest.raises(ConfigError, match="month"):
        Scenario(raw, "months.yaml").resolve()
    raw["sweep"]["parameters"]["ionosphere.month"] = [1, 7]
    plan = Scenario(raw, "months.yaml").resolve().plan
    assert len(next(s for s in plan.slots if s.kind == "ionosphere").objects) == 1


def test_a_case_parameter_some_cases_leave_unset_makes_modules_as_any_key():
    raw = {"scene": {"type": "forest_agb_model", "biome": "tropical"}, "instrument": {"type": "biomass"},
           "ionosphere": {"type": "global_climatology", "lat_deg": 0.5, "lon_deg": 20.5, "month": 1},
           "sweep": {"cases": [{"ionosphere.month": 3}, {"scene.agb_t_ha": 100}]}}
    resolved = Scenario(raw, "cases.yaml").resolve()
    months = [next(m for m in resolved.cases[i].modules if m.kind == "ionosphere").config["month"] for i in (0, 1)]
    assert months == [3, 1]  # the second case has the scenario's own month, not the first case's
