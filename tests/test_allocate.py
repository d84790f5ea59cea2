"""Allocation from the top (issue 23, item 6): ``e2esim allocate`` splits a requirement's total among its sources
(shares of the checked value's square), finds each source's specification through the forward model and checks it
back over every case; its YAML carries the specification and the requirement's allocation keys."""

import json

import numpy as np
import pytest
import yaml

import e2esim
from e2esim.cli import main

XT, CI, NESZ = "calibration.0.crosstalk_db", "calibration.0.channel_imbalance_db", "calibration.0.nesz_db"


def chain(max_percent=35):
    return {
        "name": "alloc",
        "scene": {"type": "table1_forest", "forest": "boreal_200"},
        "instrument": {"type": "biomass"},
        "ionosphere": {"type": "gaussian_faraday", "mean_deg": 20.0, "sd_deg": 5.0},
        "calibration": [{"type": "residual_system", "crosstalk_db": -30, "channel_imbalance_db": -34,
                         "nesz_db": -27}],
        "propagation": [{"type": "hv_backscatter_error"},
                        {"type": "backscatter_error_budget", "preset": "biomass_200m"}],
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_rmse", "max_percent": max_percent}],
        "simulation": {"mode": "analytic", "seed": 7},
        "sweep": {"parameters": {"scene.forest": ["boreal_200", "tropical_338"]}},
        "allocate": {"sources": {"crosstalk": {"key": XT, "bounds": [-60, -12]},
                                 "channel_imbalance": {"key": CI, "bounds": [-60, -12]},
                                 "noise": {"key": NESZ, "bounds": [-60, 0]}}},
    }


def test_one_source_gets_the_whole_budget_and_is_where_the_requirement_is_met():
    """With one source the specification is the value where the requirement is exactly met in the worst case: the
    answer of solve, to 0.01 dB; the check back holds with a zero margin in the binding case."""
    raw = chain()
    raw["allocate"]["sources"] = {"noise": {"key": NESZ, "bounds": [-60, 0]}}
    result = e2esim.allocate(raw)
    solved = e2esim.solve(raw, NESZ, bounds=(-60, 0), worst_case=True)
    assert result.specification[0] == pytest.approx(solved.answers[0].limit, abs=0.01)
    assert result.holds and abs(np.min(result.margins)) < 1e-3
    assert result.budget[0] == pytest.approx(result.limit**2 - result.floor**2)


def test_equal_and_weighted_splits_share_the_budget_and_sum_to_the_total():
    equal = e2esim.allocate(chain())
    assert np.allclose(equal.budget, equal.budget[0])
    assert equal.budget.sum() + equal.floor**2 == pytest.approx(equal.limit**2)
    weighted = e2esim.allocate(chain(), split="weighted", weights={"crosstalk": 3.0, "channel_imbalance": 1.0,
                                                                    "noise": 1.0})
    assert weighted.budget[0] == pytest.approx(3 * weighted.budget[1])
    assert weighted.specification[0] > equal.specification[0]  # a larger share: a looser crosstalk
    assert weighted.specification[1] < equal.specification[1]


def test_a_fixed_source_keeps_its_value_and_the_others_share_the_rest():
    free = e2esim.allocate(chain())
    fixed = e2esim.allocate(chain(), fixed={NESZ: -35.0})
    assert fixed.specification[2] == -35.0
    assert fixed.budget[2] < free.budget[2] and fixed.budget[0] > free.budget[0]


def test_the_check_back_runs_the_forward_model(tmp_path, capsys):
    """The specification table states whether every case meets the requirement with every source at its
    specification, through the forward model (the biases of crosstalk, imbalance and noise add linearly, not in
    quadrature, so an equal split of the variance can miss: it says so, exit status 1), and the YAML carries the
    allocation keys next to the specification values."""
    path = tmp_path / "alloc.yaml"
    path.write_text(json.dumps(chain()))
    code = main(["allocate", str(path), "-o", str(tmp_path / "out")])
    result = e2esim.allocate(chain())
    assert code == (0 if result.holds else 1)
    spec = yaml.safe_load((tmp_path / "out" / "specification.yaml").read_text())
    assert set(spec["specification"]) == {XT, CI, NESZ}
    assert set(spec["allocation_percent"]) == set(spec["allocation_share"]) == {"crosstalk", "channel_imbalance",
                                                                                  "noise"}
    assert spec["holds"] == result.holds
    check = e2esim.run(chain(), **{k: v for k, v in spec["specification"].items()})
    margins = check.to_dataframe()["requirement0.margin"].to_numpy()
    np.testing.assert_allclose(margins, result.margins, atol=1e-6)
    text = (tmp_path / "out" / "specification.md").read_text()
    assert "holds in every case" in text.splitlines()[2] or "does NOT hold" in text.splitlines()[2]


@pytest.mark.parametrize("argv, message", [
    (["--split", "weighted", "--weight", "nosuch=2"], "give a weight for sources among"),
    (["--fix", "instrument.nesz_db=-30"], "not the key of a source"),
    (["--requirement", "3"], "the scenario has 1 requirement(s)"),
    (["--source", "x=instrument.nope"], "unknown key"),
    (["--weight", "noise"], "expected NAME=VALUE"),
])
def test_bad_allocations_exit_2_with_a_message(tmp_path, capsys, argv, message):
    path = tmp_path / "alloc.yaml"
    path.write_text(json.dumps(chain()))
    code = main(["allocate", str(path), *argv])
    err = capsys.readouterr().err
    assert code == 2 and message in err


def test_a_requirement_the_floor_already_fails_is_refused(tmp_path, capsys):
    path = tmp_path / "alloc.yaml"
    path.write_text(json.dumps(chain(max_percent=10)))
    assert main(["allocate", str(path)]) == 2
    assert "fails with every source off" in capsys.readouterr().err
