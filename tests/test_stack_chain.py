"""The multi-pass stages in scenarios: bad input named by its key path, and what the shipped ground-cancellation
scenario reports (its quick run, shared with tests/test_scenarios_run.py)."""

import json
import textwrap

import pytest

from e2esim.errors import ConfigError
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario
from e2esim.stack.sites import SITES, ground_cancelled_exponent

BASE = textwrap.dedent("""\
    name: t
    scene: {type: rvog_stack, site: tropical}
    instrument: {type: biomass}
    ionosphere: {type: gaussian_faraday, mean_deg: 10, sd_deg: 3}
    propagation:
      - {type: stack_backscatter_error}
    retrieval: {type: stack_power_law}
    requirements:
      - {type: agb_rmse}
    simulation: {mode: analytic, looks: 1000}
""")


def _run(tmp_path, *overrides, text=BASE):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return run_scenario(Scenario.load(path, overrides).resolve(), progress=False)


@pytest.mark.parametrize("override, message", [
    ("propagation.0.estimator=stacked", r"propagation\[0\]\.estimator: 'stacked' is not allowed; expected one of "
                                       "'single_date', 'multi_date', 'ground_cancelled'"),
    ("scene.kz_rad_m=[0.0, 0.1]", "kz_rad_m has 2 values but the interferometric phase has 3 passes"),
    ("scene.ground_to_volume_db=[-20, -3, -20]", "scene: the ground part of .* is not a covariance"),
    ("propagation.0.system_error_correlation=1.5", r"propagation\[0\]\.system_error_correlation: 1\.5 is out of "
                                                   "range"),
    ("propagation.0.channels=both", r"propagation\[0\]\.channels: 'both' is not allowed; expected one of 'hv', 'all'"),
])
def test_bad_stack_input_names_its_key(tmp_path, override, message):
    with pytest.raises(ConfigError, match=message):
        _run(tmp_path, override)


def test_errors_met_while_running_name_the_parameter(tmp_path):
    with pytest.raises(ConfigError, match=r"propagation\[0\]\.pair: subtraction needs two different passes of 3, "
                       "got 2, 4"):
        _run(tmp_path, "propagation.0.cancellation=subtraction", "propagation.0.pair=[2, 4]")
    with pytest.raises(ConfigError, match=r"propagation\[0\]\.emphasised_height_m: no reference pass brackets"):
        _run(tmp_path, "propagation.0.emphasised_height_m=5")
    text = BASE.replace("  - {type: stack_backscatter_error}",
                        "  - {type: hv_backscatter_error}\n  - {type: stack_error_budget}")
    assert "stack_error_budget" in text
    with pytest.raises(ConfigError, match="needs the error model of stack_backscatter_error, got a HVErrorModel"):
        _run(tmp_path, text=text)


def test_bad_multichannel_input_names_its_key(tmp_path):
    joint = ("retrieval.type=stack_multichannel_power_law", "propagation.0.channels=all")
    with pytest.raises(ConfigError, match=r"retrieval\.ground_cancelled_exponents\[1\]: 'linear' is not allowed; "
                       "expected a list of 3 items, each one of 'rvog', 'volume', 'same'"):
        _run(tmp_path, *joint, "retrieval.ground_cancelled_exponents=[same, linear, rvog]")
    with pytest.raises(ConfigError, match=r"retrieval: needs the errors of all channels, but backscatter\.error is a "
                       "single-channel StackHVErrorModel.*channels: all"):
        _run(tmp_path, joint[0])
    assert _run(tmp_path, *joint).cases[0].scalars["agb.exponent"] == 1.0  # the joint estimate's log error


def test_ground_cancelled_retrieval_uses_the_rvog_exponent(tmp_path):
    result = _run(tmp_path)
    p = result.cases[0].scalars["agb.exponent"]
    assert p == pytest.approx(ground_cancelled_exponent(1.9, SITES["tropical"].ground_to_volume_db[1]), rel=1e-14)
    same = _run(tmp_path, "retrieval.ground_cancelled_exponent=same")
    assert same.cases[0].scalars["agb.exponent"] == 1.9


def test_the_ground_cancellation_scenario_answers_its_question(quick_run):
    _, folder = quick_run("biomass_ground_cancelled")
    assert (folder / "agb_error_vs_faraday_difference.png").is_file()
    summary = json.loads((folder / "summary.json").read_text())
    by = {}
    for case in summary["cases"]:
        i = case["inputs"]
        estimator = i["propagation.0.estimator"] + ("_multichannel" if i["propagation.0.channels"] == "all" else "")
        by[(i["scene.site"], estimator, i["orbit.passes"], i["propagation.0.faraday_difference_sd_deg"])] = case
    for site in ("tropical", "boreal"):
        # the 20 % goal (RMS of every source): ground-cancelled HH, HV and VV together meet it, with the smallest
        # error of the four estimators; ground-cancelled HV only just, in the boreal forest (19.9 %)
        rmse = {e: by[(site, e, "dawn", None)]["requirements"][1] for e in
                ("single_date", "multi_date", "ground_cancelled", "ground_cancelled_multichannel")}
        passing = [e for e, v in rmse.items() if v["passed"]]
        gc_hv = rmse["ground_cancelled"]["value"]
        if site == "tropical":
            assert passing == ["ground_cancelled_multichannel"] and gc_hv > 22.0
        else:
            assert passing == ["ground_cancelled", "ground_cancelled_multichannel"] and 19.5 < gc_hv < 20.0
        assert rmse["ground_cancelled_multichannel"]["value"] == min(v["value"] for v in rmse.values())
        joint = by[(site, "ground_cancelled_multichannel", "dawn", None)]["results"]
        assert joint["cancellation.hh.ground_suppression_db"] < -15.0  # HH's large ground is cancelled too
        looks = {e: by[(site, e, "dawn", None)]["results"]["estimator.speckle_diversity"]
                 for e in ("single_date", "multi_date", "ground_cancelled")}
        assert looks["single_date"] == 1.0 < looks["ground_cancelled"] < looks["multi_date"] < 3.0
        gc = by[(site, "ground_cancelled", "dawn", None)]["results"]
        assert gc["cancellation.ground_suppression_db"] < -15.0  # the ground is cancelled ...
        assert gc["cancellation.ground_residual_ideal_fraction"] < 0.02  # ... by the operator itself
        for estimator in ("single_date", "multi_date", "ground_cancelled"):
            quiet = by[(site, estimator, "dawn", None)]  # the quick run sets no day-to-day TEC variability
            swept = by[(site, estimator, "dawn", 30.0)]
            assert quiet["results"]["estimator.faraday_difference_sd_deg"] == 0.0
            # the symmetrised HV depends on Faraday rotation only through crosstalk: 30 deg changes the systematic
            # AGB error by less than 0.5 percentage points
            assert abs(quiet["requirements"][0]["value"] - swept["requirements"][0]["value"]) < 0.5
            for verdict in quiet["requirements"]:
                assert verdict["dominant"], verdict["name"]


def test_the_joint_estimate_refuses_a_linear_budget(tmp_path):
    text = BASE.replace("  - {type: stack_backscatter_error}",
                        "  - {type: stack_backscatter_error, channels: all}\n"
                        "  - {type: stack_error_budget, combination: linear}")
    with pytest.raises(ConfigError, match=r"retrieval: case 0: the joint multi-channel estimate combines independent "
                       "budget terms only, got combination 'linear'.*combination: independent"):
        _run(tmp_path, "retrieval.type=stack_multichannel_power_law", text=text)
