"""What a verdict covers is computed from its chain, never written (issue 21, item 2): every shipped scenario's
summary.json against the products of its chain, the labels, and ``sources: all`` refused at validation where the
chain cannot back it (unless the missing terms are stated as assumed values)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import e2esim
from e2esim.cli import main
from e2esim.errors import ConfigError
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario
from quick_runs import SCENARIOS, scenario_names

SYSTEM_ONLY = """
name: coverage
scene: {type: table1_forest, forest: boreal_200}
instrument: {type: biomass}
ionosphere: {type: gaussian_faraday, mean_deg: 60, sd_deg: 5}
propagation: {type: hv_backscatter_error}
requirements:
  - {type: agb_error_bound, sources: systematic}
  - {type: agb_rmse, max_percent: 20}
simulation: {mode: analytic}
"""
SPECKLE = ("speckle", "speckle_noise")


def _chain_sources(case) -> tuple:
    """(systematic sources, [(source, group)] of the other contributions) of a case, read from its products: the
    error model its AGB error maps, and the named contributions of its AGB error."""
    agb = case.get("agb.error")
    model = getattr(agb, "error_model", None) or case.get("backscatter.error")
    systematic = tuple(model.sources) + (("speckle",) if getattr(model, "includes_speckle", False)
                                         and "speckle" not in model.sources else ())
    others = [(c.name, c.group) for c in getattr(agb, "contributions", ()) if c.group != "systematic"]
    return systematic, others


def _resolved(name: str):
    return yaml.safe_load((SCENARIOS / f"{name}.yaml").read_text())


@pytest.mark.parametrize("name", scenario_names())
def test_no_shipped_report_claims_a_source_its_chain_did_not_compute(quick_run, name):
    """Done when (issue 21): every verdict of summary.json covers exactly what its case's chain computed."""
    result, folder = quick_run(name)
    summary = json.loads((folder / "summary.json").read_text())
    settings = [r.get("sources", "computed") for r in _resolved(name).get("requirements", [])]
    if not settings:
        assert summary["requirements"] == []
        return
    assert summary["cases"] and result.keeps_products, "the quick run must keep its products to be checked"
    for entry, case in zip(summary["cases"], result.cases):
        systematic, others = _chain_sources(case)
        for setting, verdict in zip(settings, entry["requirements"]):
            expected = list(systematic) + ([s for s, _ in others] if setting != "systematic" else [])
            assert verdict["coverage"] == expected, (case.index, verdict["name"])
            text = verdict["coverage_text"]
            computed = set(systematic) | {s for s, _ in others}
            assert ("no speckle" in text) == (not computed & set(SPECKLE)), text
            has_retrieval = any(g in ("regression", "model") for _, g in others)
            assert ("regression/retrieval-model term in this chain" in text) == (not has_retrieval), text
            assert ("random (" in text) == any(g == "random" for _, g in others), text
            if setting == "systematic":
                assert not text.split(";")[0].count("+"), text  # the systematic group only
    for setting, overview in zip(settings, summary["requirements"]):
        claims_all = "(all sources" in overview["name"]
        assert claims_all == (setting == "all")
        assert overview["sources"] == setting
        for part in overview["coverage"]:
            if setting == "all":
                assert "no speckle" not in part["text"] and "regression/retrieval-model term" not in part["text"]
        assert sum(p["cases"] for p in overview["coverage"]) == summary["n_cases"]


def test_a_systematic_only_chain_does_not_claim_every_source():
    """biomass_calibration and biomass_fr_climatology printed "AGB RMSE <= 20 % (all sources) PASS" at 5 % with no
    random-error budget: the label and coverage now say what the chain computed."""
    results = e2esim.run(yaml.safe_load(SYSTEM_ONLY))
    names = results.requirements
    assert names == ["AGB error within +-20 % at 99.865 % (system errors)", "AGB RMSE <= 20 % (computed sources)"]
    text = results.coverage_text[0, 1]
    assert text == ("systematic (crosstalk, channel imbalance, noise, Faraday rotation, gain error); "
                    "no speckle, temporal or regression/retrieval-model term in this chain")
    assert results.coverage[0, 1] == "crosstalk, channel_imbalance, noise, faraday_rotation, gain"
    for name in ("biomass_calibration", "biomass_fr_climatology"):
        for requirement in _resolved(name)["requirements"]:
            assert requirement["sources"] == "systematic"


def test_validate_refuses_all_sources_on_a_chain_that_cannot_supply_them(tmp_path, capsys):
    data = yaml.safe_load(SYSTEM_ONLY)
    data["requirements"][1]["sources"] = "all"
    path = tmp_path / "all.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:" in err and "requirements[1].sources" in err
    assert "no speckle and no regression/retrieval-model term" in err
    assert "backscatter_error_budget" in err and "regression.mode confidence" in err
    assert "assumed.random_percent" in err and "assumed.retrieval_agb_percent" in err
    assert "sources: computed" in err and "systematic" in err


def test_all_sources_is_valid_where_the_chain_computes_them():
    data = yaml.safe_load(SYSTEM_ONLY)
    data["propagation"] = [{"type": "hv_backscatter_error"}, {"type": "backscatter_error_budget"}]
    data["retrieval"] = {"type": "power_law", "regression": {"mode": "confidence"}}
    data["requirements"][1]["sources"] = "all"
    Scenario(data, "all.yaml").resolve()
    data["propagation"][1]["include"] = ["temporal", "calibration"]  # a budget without speckle
    with pytest.raises(ConfigError, match=r"requirements\[1\]\.sources.*no speckle term"):
        Scenario(data, "all.yaml").resolve()
    data["propagation"][1]["include"] = ["speckle_noise"]
    data["retrieval"]["regression"]["mode"] = "none"  # swept to none in one case: that case is refused
    data["sweep"] = {"parameters": {"retrieval.regression.mode": ["confidence", "none"]}}
    with pytest.raises(ConfigError, match=r"no regression/retrieval-model term \(case 1 of the sweep\)"):
        Scenario(data, "all.yaml").resolve()


def test_assumed_terms_complete_all_sources_and_enter_the_checked_value():
    data = yaml.safe_load(SYSTEM_ONLY)
    plain = run_scenario(Scenario(data, "a.yaml").resolve(), progress=False).cases[0].verdicts[1]
    data["requirements"][1].update(sources="all", assumed={"random_percent": 8.0, "retrieval_agb_percent": 10.0})
    result = run_scenario(Scenario(data, "a.yaml").resolve(), progress=False)
    case = result.cases[0]
    v = case.verdicts[1]
    assert v.name == "AGB RMSE <= 20 % (all sources, random and retrieval model assumed)"
    assert v.coverage[-2:] == ("assumed_random", "assumed_retrieval")
    assert "random terms (speckle, temporal, calibration), assumed 8 % of σ" in v.coverage_text
    assert "regression and retrieval model, assumed 10 % of AGB" in v.coverage_text
    assert "no speckle" not in v.coverage_text and "term in this chain" not in v.coverage_text
    # the checked sigma error gains the assumed variances: 8 % of sigma, and 10 % of AGB through 1/p (eq. 16)
    agb = case.get("agb.error")
    sd = np.sqrt(agb.error_sd**2 + agb.sigma_hv**2 * (0.08**2 + (0.10 / agb.exponent) ** 2))
    from dataclasses import replace

    assert v.value == pytest.approx(100 * replace(agb, error_sd=sd).rmse(), rel=1e-12)
    assert v.value > plain.value
    assert v.details["contribution.assumed_retrieval_percent"] > 0
    assert v.details["contribution.assumed_random_percent"] > 0


@pytest.mark.parametrize("change, where, message", [
    ({"sources": "computed", "assumed": {"random_percent": 5.0}}, r"requirements\[1\]\.assumed",
     "assumed terms complete sources: all, but sources is 'computed'"),
    ({"sources": "all", "assumed": {"random_percent": 5.0}}, r"requirements\[1\]\.sources", "no regression"),
    ({"sources": "all", "assumed": {"random_percent": 5.0, "retrieval_agb_percent": 5.0}, "basis": "montecarlo"},
     r"requirements\[1\]\.basis", "cannot hold the assumed terms"),
])
def test_assumed_terms_are_checked_at_validation(change, where, message):
    data = yaml.safe_load(SYSTEM_ONLY)
    data["requirements"][1].update(change)
    with pytest.raises(ConfigError, match=f"{where}.*{message}"):
        Scenario(data, "a.yaml").resolve()


def test_an_assumed_term_the_chain_computes_would_count_twice():
    data = yaml.safe_load(SYSTEM_ONLY)
    data["propagation"] = [{"type": "hv_backscatter_error"}, {"type": "backscatter_error_budget"}]
    data["requirements"][1].update(sources="all", assumed={"random_percent": 5.0, "retrieval_agb_percent": 5.0})
    with pytest.raises(ConfigError, match=r"assumed\.random_percent.*computes a speckle term.*twice"):
        Scenario(data, "a.yaml").resolve()


def test_assumed_terms_give_the_same_verdicts_batched_and_per_case():
    data = yaml.safe_load(SYSTEM_ONLY)
    data["requirements"][1].update(sources="all", assumed={"random_percent": 8.0, "retrieval_agb_percent": 10.0})
    data["sweep"] = {"parameters": {"scene.forest": ["boreal_50", "boreal_200", "tropical_338"],
                                    "instrument.crosstalk.level_db": [-30, -25]}}
    resolved = Scenario(data, "a.yaml").resolve()
    batched = run_scenario(resolved, progress=False)
    per_case = run_scenario(resolved, progress=False, engine="per_case")
    from e2esim.runner.blocks import BlockRun
    from e2esim.runner.run import default_services

    products = BlockRun(resolved.plan, np.arange(6), default_services()).run()
    assert type(products["verdicts"]).__name__ == "RequirementVerdicts"  # the fast path (not a Factor) holds the terms
    for a, b in zip(batched.cases, per_case.cases):
        for v, w in zip(a.verdicts, b.verdicts):
            assert (v.name, v.status, v.value, v.margin, v.coverage, v.coverage_text, v.details) == (
                w.name, w.status, w.value, w.margin, w.coverage, w.coverage_text, w.details)


def test_the_coverage_overview_counts_each_coverage_in_the_order_first_met():
    """summary.json's coverage list: one entry per distinct (sources, text), counted over the cases, in the order
    the cases first meet it; two codes of equal values count as one entry."""
    from types import SimpleNamespace

    from e2esim.block import Values
    from e2esim.io.summary import coverage_overview

    coverage = Values([("a",), ("a", "b"), ("c",), ("a",)], np.array([1, 0, 2, 1, 3, 0, 1, 0]))
    text = Values(["x", "y", "x"], np.array([0, 1, 1, 0, 2, 1, 0, 0]))  # the last case: the values of case 4
    got = coverage_overview(SimpleNamespace(coverage=coverage, coverage_text=text))
    assert got == [{"sources": ["a", "b"], "text": "x", "cases": 3}, {"sources": ["a"], "text": "y", "cases": 2},
                   {"sources": ["c"], "text": "y", "cases": 1}, {"sources": ["a"], "text": "x", "cases": 2}]
