"""Sensitivity (issue 23, item 5): with ``output.sensitivity: true`` every requirement gets, at its worst case, the
elasticity of its checked value to every numeric parameter of the chain (central differences through the engine),
a tornado chart and the parameters ranked by the margin they buy; parameters with no effect are reported as such."""

from __future__ import annotations

import json
import math
from functools import partial

import h5py
import numpy as np
import pytest

from e2esim.runner.outputs import write_outputs
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario
from e2esim.runner.sensitivity import RELATIVE_STEP, chain_parameters


def _scenario(sensitivity=True):
    """Men et al. (2021), Fig. 4 (boreal 200 t/ha, Faraday rotation pi/3 held fixed, paper form), one requirement:
    the AGB underestimated by less than 20 % at 99.865 %."""
    return Scenario({
        "name": "sensitivity_check", "scene": {"type": "table1_forest", "forest": "boreal_200"},
        "instrument": {"type": "biomass"}, "ionosphere": {"type": "constant_faraday", "value_deg": 60},
        "propagation": {"type": "hv_backscatter_error", "variance_form": "paper"},
        "retrieval": {"type": "power_law", "exponent": 2.2},
        "requirements": [{"type": "agb_error_bound", "sources": "systematic", "side": "under", "bound_percent": 20,
                          "confidence_percent": 99.865}],
        "simulation": {"mode": "analytic"}, "output": {"sensitivity": sensitivity}})


@pytest.fixture(scope="module")
def sensitive(tmp_path_factory):
    result = run_scenario(_scenario().resolve(), progress=False)
    folder = tmp_path_factory.mktemp("sensitivity")
    write_outputs(result, folder)
    return result, folder


def test_the_exponent_elasticity_is_the_power_laws(sensitive):
    """Under-side bound: V = -100 q, q = (1 + x)^p - 1 with x fixed, so d ln V / d ln p = (1 + q) ln(1 + q) / q
    (Men et al. 2021, eq. 15); the central difference of step h is within O(h^2) of it."""
    result, _ = sensitive
    req = result.sensitivity["requirements"][0]
    q = -req["value"] / 100
    params = {p["key"]: p for p in req["parameters"]}
    exact = (1 + q) * math.log(1 + q) / q
    assert params["retrieval.exponent"]["elasticity"] == pytest.approx(exact, rel=RELATIVE_STEP**2)
    assert params["retrieval.exponent"]["kind"] == "relative" and params["retrieval.exponent"]["sides"] == 2
    assert req["value"] == pytest.approx(result.cases[0].verdicts[0].value, rel=1e-12)  # one case: same stream


def test_every_parameter_is_reported_and_ranked_by_the_margin_it_buys(sensitive):
    result, _ = sensitive
    req = result.sensitivity["requirements"][0]
    keys = [k for k, _, _ in chain_parameters(result.scenario.cases[0].modules)]
    assert [p["key"] for p in req["parameters"]] == keys and len(keys) > 5
    nesz = next(p for p in req["parameters"] if p["key"] == "instrument.nesz_db")
    # the noise bias sigma_n/2 raises the HV estimate (Men et al. 2021, eq. 11): more noise, less underestimation
    assert nesz["kind"] == "per_db" and nesz["effect"] and nesz["elasticity"] < 0
    bought = [next(p for p in req["parameters"] if p["key"] == k)["margin_bought"] for k in req["ranked"]]
    assert bought == sorted(bought, reverse=True) and bought[0] > 0
    idle = [p for p in req["parameters"] if p["effect"] is False]
    assert idle and all("no effect on the checked value" in p["note"] for p in idle)  # reported, not dropped
    assert all(p["note"] for p in req["parameters"] if p["effect"] is None)  # e.g. at zero: said why


def test_summary_and_report_carry_the_sensitivity(sensitive):
    result, folder = sensitive
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["sensitivity"]["requirements"][0]["ranked"] == result.sensitivity["requirements"][0]["ranked"]
    assert summary["sensitivity"]["relative_step"] == RELATIVE_STEP
    report = (folder / "report.md").read_text()
    assert "sensitivity.png" in report and "the parameters that buy the most margin" in report
    assert (folder / "sensitivity.png").exists()
    req = result.sensitivity["requirements"][0]
    with h5py.File(folder / "results.h5", "r") as f:  # the same table in results.h5
        g = f["sensitivity/0"]
        assert g.attrs["name"] == req["name"] and g.attrs["value"] == req["value"]
        assert [k.decode() for k in g["ranked"][()]] == req["ranked"]
        assert [k.decode() for k in g["key"][()]] == [p["key"] for p in req["parameters"]]
        expected = [math.nan if p["elasticity"] is None else p["elasticity"] for p in req["parameters"]]
        assert np.array_equal(g["elasticity"][()], expected, equal_nan=True)
        assert f["sensitivity"].attrs["relative_step"] == RELATIVE_STEP


def test_without_the_setting_nothing_is_computed(tmp_path):
    result = run_scenario(_scenario(sensitivity=False).resolve(), progress=False)
    assert result.sensitivity is None


def _drawing_scenario(seed):
    """HH after a stated Faraday-rotation residual (calibration draws it from the case's generator, so the checked
    value depends on the stream), two cases; the second (the larger residual) is the worst."""
    return Scenario({
        "name": "sensitivity_streams", "scene": {"type": "table1_forest", "forest": "boreal_200"},
        "instrument": {"type": "biomass"}, "ionosphere": {"type": "gaussian_faraday", "mean_deg": 20.0, "sd_deg": 5.0},
        "calibration": [{"type": "residual_faraday", "bias_deg": 1.0, "sd_deg": 2.0}],
        "propagation": {"type": "polarimetric_error"},
        "retrieval": {"type": "multichannel_power_law", "estimator": "hh"},
        "requirements": [{"type": "agb_rmse", "max_percent": 20}],
        "simulation": {"mode": "analytic", "seed": seed % 2**32, "looks": 2000, "realisations": 50},
        "sweep": {"parameters": {"calibration.0.sd_deg": [2.0, 8.0]}}, "output": {"sensitivity": True}})


def test_the_batched_steps_draw_the_streams_of_separate_runs(seed):
    """Common random numbers: the steps run as one batch, each with the stream of its unstepped case
    (simulation.stream), and give bit for bit the values of one run per step; the unstepped value is the run's own
    value of the worst case (case 1: its stream is not that of a one-case run's case 0)."""
    from e2esim.runner.sensitivity import checked_values

    scenario = _drawing_scenario(seed)
    scenario.raw["output"]["sensitivity"] = False
    result = run_scenario(scenario.resolve(), progress=False)
    base = {"calibration.0.sd_deg": 8.0, "simulation.stream": 1}
    rows = [base, {**base, "calibration.0.sd_deg": 8.4}, {**base, "instrument.nesz_db": -26.5}]
    batched = checked_values(result.scenario, rows, run_scenario)
    assert batched.tobytes() == checked_values(result.scenario, rows, run_scenario, batched=False).tobytes()
    assert batched[0, 0] == float(result.table.requirements[0].value[1])
    assert batched[0, 1] > batched[0, 0]  # a larger residual rotation, a larger HH error


@pytest.mark.slow
def test_the_batched_table_is_that_of_separate_runs(seed, monkeypatch):
    """The whole sensitivity table, batched, is bit for bit that of one run per step."""
    from e2esim.runner import sensitivity

    result = run_scenario(_drawing_scenario(seed).resolve(), progress=False)
    req = result.sensitivity["requirements"][0]
    assert req["case"] == 1 and req["value"] == float(result.table.requirements[0].value[1])
    sd = next(p for p in req["parameters"] if p["key"] == "calibration.0.sd_deg")
    assert sd["effect"] and sd["elasticity"] > 0  # a larger residual rotation, a larger HH error
    monkeypatch.setattr(sensitivity, "checked_values", partial(sensitivity.checked_values, batched=False))
    assert sensitivity.parameter_sensitivity(result, run_scenario) == result.sensitivity
