"""Sensitivity (issue 23, item 5): with ``output.sensitivity: true`` every requirement gets, at its worst case, the
elasticity of its checked value to every numeric parameter of the chain (central differences through the engine),
a tornado chart and the parameters ranked by the margin they buy; parameters with no effect are reported as such."""

from __future__ import annotations

import json
import math

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


def test_without_the_setting_nothing_is_computed(tmp_path):
    result = run_scenario(_scenario(sensitivity=False).resolve(), progress=False)
    assert result.sensitivity is None
