"""The batched engine gives the per-case runner's numbers (issue 14): analytic results to 1e-12, Monte Carlo
results identical, for every shipped scenario; blocks, catalogs and the sweep plan behave as documented.

The default suite checks the first and the last case of each shipped scenario at the quick sizes against the
per-case runner (the batched run is the session's quick run); the slow suite checks every case at the scenarios'
own sizes.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
import yaml

from e2esim.block import Catalog, Factor
from e2esim.faraday.distribution import EmpiricalFaraday, GaussianFaraday
from e2esim.results import Results
from e2esim.runner.run import run_block, run_scenario
from e2esim.runner.scenario import Scenario
from quick_runs import SCENARIOS, scenario_names

RTOL = 1e-12  # issue 14: batched and per-case numbers agree to 1e-12


def _close(a: float, b: float, scale: float = 0.0) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b or abs(a - b) <= RTOL * max(abs(a), abs(b), scale)


def assert_same_case(got, expected) -> None:
    """Scalars and verdicts of two ``CaseResult``s: Monte Carlo numbers identical, analytic ones to 1e-12 (a
    contribution, a difference of two checked values, and a Shapley part, relative to the checked value)."""
    assert list(got.scalars) == list(expected.scalars), set(got.scalars) ^ set(expected.scalars)
    for name, value in expected.scalars.items():
        if "montecarlo" in name:
            assert got.scalars[name] == value or (math.isnan(value) and math.isnan(got.scalars[name])), name
        else:
            assert _close(got.scalars[name], value), (name, got.scalars[name], value)
    assert got.notes == expected.notes
    assert len(got.verdicts) == len(expected.verdicts)
    for v, w in zip(got.verdicts, expected.verdicts):
        assert (v.name, v.passed, v.unit, v.basis, v.dominant, v.notes) == (w.name, w.passed, w.unit, w.basis,
                                                                              w.dominant, w.notes)
        assert (v.status, v.reason, v.coverage, v.coverage_text) == (w.status, w.reason, w.coverage, w.coverage_text)
        assert _close(v.value, w.value) and _close(v.limit, w.limit) and _close(v.margin, w.margin, abs(w.limit))
        assert list(v.details) == list(w.details)
        for key, x in w.details.items():
            # a contribution or a Shapley part (sums of differences of checked values): relative to the checked value
            differences = key.startswith(("contribution.", "shapley."))
            assert _close(v.details[key], x, abs(w.value) if differences else 0.0), (key, x)
        assert list(v.curves) == list(w.curves)
        for key, x in w.curves.items():
            assert np.allclose(v.curves[key], x, rtol=RTOL, atol=0.0, equal_nan=True), key


@pytest.mark.parametrize("name", scenario_names())
def test_batched_runs_give_the_per_case_numbers(quick_run, name):
    result, _ = quick_run(name)  # the batched engine
    resolved = result.scenario
    n = len(resolved.cases)
    picks = sorted({0, n - 1})  # the first case and one in the last block
    for index in picks:
        assert_same_case(result.cases[index], run_block(resolved, [index], engine="per_case").case(0, {}, ""))


@pytest.mark.slow
@pytest.mark.parametrize("name", scenario_names())
def test_batched_runs_give_the_per_case_numbers_in_every_case(name):
    resolved = Scenario.load(SCENARIOS / f"{name}.yaml").resolve()
    batched = run_scenario(resolved, progress=False)
    per_case = run_scenario(resolved, progress=False, engine="per_case")
    for got, expected in zip(batched.cases, per_case.cases):
        assert_same_case(got, expected)


SWEEP = """
name: blocks
scene: {type: forest_agb_model, biome: boreal}
instrument: {type: biomass}
ionosphere: {type: gaussian_faraday, mean_deg: 40, sd_deg: 5}
requirements:
  - {type: agb_error_bound, sources: systematic, level_margins: true, tradeoff_curve: true, curve_points: 7}
  - {type: agb_rmse}
  - {type: agb_rmse_absolute, applies_below_t_ha: 150}
simulation: {mode: analytic}
sweep:
  parameters:
    scene.agb_t_ha: [60, 200, 330]
    instrument.crosstalk.level_db: [-34, -26]
    instrument.channel_imbalance.level_db: [-36, -28]
    ionosphere.sd_deg: [0, 5]
"""


def test_every_case_of_an_analytic_sweep_agrees_in_blocks_of_any_size():
    resolved = Scenario(yaml.safe_load(SWEEP), "blocks.yaml").resolve()
    per_case = run_scenario(resolved, progress=False, engine="per_case")
    for size in (1, 5, 24):  # blocks of one case, ragged blocks, one block
        blocks = [run_block(resolved, np.arange(i, min(i + size, 24))) for i in range(0, 24, size)]
        for block in blocks:
            for k, index in enumerate(block.indices):
                assert_same_case(block.case(k, {}, ""), per_case.cases[int(index)])


def test_batched_stages_are_used_for_the_analytic_chain():
    from e2esim.runner.blocks import BlockRun
    from e2esim.runner.run import default_services

    resolved = Scenario(yaml.safe_load(SWEEP), "blocks.yaml").resolve()
    products = BlockRun(resolved.plan, np.arange(24), default_services()).run()
    kinds = {name: type(value).__name__ for name, value in products.items()}
    assert kinds["backscatter.error"] == "HVErrorModel" and kinds["agb.error"] == "AGBError"
    assert kinds["verdicts"] == "RequirementVerdicts" and kinds["calibration"] == "CalibrationRecord"
    assert kinds["instrument"] == "Factor" and len(products["instrument"].values) == 4  # once per distinct one


def test_monte_carlo_cases_keep_their_own_generator_in_blocks():
    data = yaml.safe_load(SWEEP)
    data["simulation"] = {"mode": "both", "looks": 500, "realisations": 60, "seed": 5}
    data["requirements"] = [{"type": "agb_error_bound"}]
    resolved = Scenario(data, "mc.yaml").resolve()
    per_case = run_scenario(resolved, progress=False, engine="per_case", keep_products=True)
    shuffled = run_block(resolved, np.array([7, 3, 19, 0]), keep_products=True)  # any order, any company
    for k, index in enumerate(shuffled.indices):
        got, expected = shuffled.case(k, {}, ""), per_case.cases[int(index)]
        assert np.array_equal(got.get("backscatter.error").samples(), expected.get("backscatter.error").samples())
        assert_same_case(got, expected)


def test_a_grid_plan_builds_each_distinct_module_once():
    resolved = Scenario(yaml.safe_load(SWEEP), "blocks.yaml").resolve()
    slots = {s.path: s for s in resolved.plan.slots}
    assert len(slots[("scene",)].objects) == 3 and len(slots[("instrument",)].objects) == 4
    assert len(slots[("ionosphere",)].objects) == 2 and len(slots[("retrieval",)].objects) == 1
    case = resolved.cases[13]  # C order: agb 1, crosstalk 1, imbalance 0, sd 1
    assert case.inputs == {"scene.agb_t_ha": 200, "instrument.crosstalk.level_db": -26,
                           "instrument.channel_imbalance.level_db": -36, "ionosphere.sd_deg": 5}
    assert [m.config.get("agb_t_ha") for m in case.modules if m.kind == "scene"] == [200]


def test_a_catalog_keeps_each_value_once_and_extends_its_tables():
    catalog = Catalog()
    a, b = GaussianFaraday(0.1, 0.0), GaussianFaraday(0.2, 0.0)
    assert [catalog.add(a), catalog.add(b), catalog.add(a)] == [0, 1, 0]
    calls = []

    def mean(v):
        calls.append(v)
        return v.mean_rad

    factor = Factor(catalog, np.array([1, 0, 1]))
    assert np.array_equal(factor.gather(mean, name="mean"), [0.2, 0.1, 0.2]) and len(calls) == 2
    catalog.add(GaussianFaraday(0.3, 0.0))
    assert np.array_equal(catalog.table("mean", mean), [0.1, 0.2, 0.3]) and len(calls) == 3  # the new one only


def test_a_catalog_keys_its_values_by_keys_that_hold_them():
    """Issue 27, Build 7: no id()-keyed memo: a key names its object by identity and keeps it, so it cannot come to
    name another object; an equal but different object is another value."""
    from e2esim.block import IdentityKey

    a = GaussianFaraday(0.1, 0.0)
    twin = GaussianFaraday(0.1, 0.0)
    assert IdentityKey(a) == IdentityKey(a) and IdentityKey(a) != IdentityKey(twin) and IdentityKey(a) != id(a)
    catalog = Catalog()
    assert [catalog.add(a), catalog.add(twin), catalog.add(a)] == [0, 1, 0]
    assert all(isinstance(key, IdentityKey) for key in catalog._codes)
    first, second = (key.value for key in catalog._codes)
    assert first is a and second is twin
    copy = pickle.loads(pickle.dumps(catalog))
    assert len(copy) == 2 and copy.add(copy[1]) == 1


def test_the_five_node_average_is_exact_for_polynomials_of_degree_4_in_cos_2_omega(rng):
    samples = rng.normal(0.7, 0.4, 50)
    dist = EmpiricalFaraday(samples, rng.uniform(0.1, 1.0, 50))
    nodes, weights = dist.even_quadrature()
    coefficients = rng.normal(size=5)
    exact = np.dot(dist.probabilities, np.polynomial.polynomial.polyval(np.cos(2 * dist.samples), coefficients))
    assert np.dot(weights, np.polynomial.polynomial.polyval(np.cos(2 * nodes), coefficients)) == pytest.approx(
        exact, rel=1e-13, abs=1e-14)
    # and the HV error moments averaged with it agree with the 17-node average of any trigonometric polynomial
    # of degree 8 (FaradayDistribution.quadrature)
    nodes17, weights17 = dist.quadrature()
    h = lambda w: np.cos(w) ** 4 * np.sin(w) ** 4 + 0.3 * np.cos(w) ** 2
    assert np.dot(weights, h(nodes)) == pytest.approx(np.dot(weights17, h(nodes17)), rel=1e-13)


@pytest.mark.parametrize("name", ["biomass_calibration", "biomass_latitude_sweep"])
def test_the_run_columns_are_the_cases(quick_run, name):
    """``Results.from_run`` reads the joined block columns: they must be what the one-case view gives."""
    result, _ = quick_run(name)
    columns = Results.from_run(result)
    cases = list(result.cases)
    assert columns.labels == [c.label for c in cases]
    for key in result.scenario.sweep_keys:
        assert columns.inputs[key] == [c.inputs.get(key) for c in cases]
    assert sorted(columns.scalars) == sorted({k for c in cases for k in c.scalars})
    for name_, values in columns.scalars.items():
        np.testing.assert_array_equal(values, [c.scalars.get(name_, np.nan) for c in cases])
    for j in range(len(result.requirement_names)):
        assert columns.passed[:, j].tolist() == [c.verdicts[j].passed for c in cases]
        assert columns.status[:, j].tolist() == [c.verdicts[j].status for c in cases]
        assert columns.coverage_text[:, j].tolist() == [c.verdicts[j].coverage_text for c in cases]
        np.testing.assert_array_equal(columns.margin[:, j], [c.verdicts[j].margin for c in cases])
        assert columns.dominant[:, j].tolist() == [c.verdicts[j].dominant for c in cases]
        for key, values in columns.details[j].items():
            np.testing.assert_array_equal(values, [c.verdicts[j].details.get(key, np.nan) for c in cases])


def test_grid_labels_made_group_by_group_are_those_made_one_by_one():
    data = yaml.safe_load(SWEEP)
    data["sweep"]["parameters"]["ionosphere.sd_deg"] = [5, 5]  # a repeated value: labels get the case number
    labels = Scenario(data, "blocks.yaml").resolve().cases.labels
    assert labels.tolist() == [labels[i] for i in range(len(labels))]
    assert labels[1].endswith("(#1)")


LARGE = """
name: large
scene: {type: forest_agb_model, biome: boreal}
instrument: {type: biomass}
ionosphere: {type: gaussian_faraday, mean_deg: 60, sd_deg: 5}
requirements: [{type: agb_error_bound, sources: systematic}, {type: agb_rmse}]
simulation: {mode: analytic}
sweep:
  parameters:
    scene.agb_t_ha: {linspace: [20, 400, 25]}
    instrument.crosstalk.level_db: {linspace: [-40, -20, 21]}
    instrument.channel_imbalance.level_db: {linspace: [-40, -25, 21]}
output: {plots: [auto, verdicts]}
"""


def test_a_large_run_writes_every_case_to_results_h5_and_leaves_the_per_case_report_out(tmp_path):
    import json

    from e2esim import open_results
    from e2esim.io.summary import LARGE_RUN_CASES
    from e2esim.runner.outputs import write_outputs

    resolved = Scenario(yaml.safe_load(LARGE), "large.yaml").resolve()
    n = len(resolved.cases)
    assert n == 25 * 21 * 21 > LARGE_RUN_CASES
    result = run_scenario(resolved, progress=False)
    warnings = write_outputs(result, tmp_path)["warnings"]
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["n_cases"] == n and summary["cases"] == [] and "results.h5" in summary["cases_omitted"]
    overview = summary["requirements"][1]
    passed = result.table.requirements[1].passed
    assert overview["passed_cases"] == int(passed.sum()) and overview["failed_cases"] == n - int(passed.sum())
    worst = int(np.argmin(result.table.requirements[1].margin))
    assert overview["worst_case"] == worst and overview["worst_case_label"] == result.cases[worst].label
    assert any(w.startswith("verdicts: not drawn") and "more than 10000" in w for w in warnings)
    report = (tmp_path / "report.md").read_text()
    assert "per-case tables and plots are left out" in report and "error_budget.png" in report
    back = open_results(tmp_path)
    for index in (0, n // 3, n - 1):  # the columns hold the one-case numbers
        case = result.cases[index]
        for name, value in case.scalars.items():
            assert back.scalars[name][index] == value, name
        assert back.margin[index, 0] == case.verdicts[0].margin
        assert back.labels[index] == case.label


def test_scalars_only_some_cases_have_keep_their_place_among_the_others():
    from e2esim.runner.columns import dict_columns, merged_order

    # the contribution "nonlinearity" of biomass_multichannel: the first case of a block lacks it
    first = {"agb.contribution.noise.mean": 1.0, "requirement0.passed": 1.0}
    second = {"agb.contribution.noise.mean": 2.0, "agb.contribution.nonlinearity.mean": 0.1, "requirement0.passed": 0.0}
    assert list(dict_columns([first, second])) == list(second)
    assert merged_order([["b", "c"], ["a", "b", "x", "c", "y"], ["z"]]) == ["z", "a", "b", "x", "c", "y"]
    assert merged_order([[], ["a", "b"], ["b", "a"]]) == ["a", "b"]  # the first order met stands


BUDGET_SWEEP = """
name: budget_blocks
scene: {type: forest_agb_model, biome: boreal}
instrument: {type: biomass}
ionosphere: {type: gaussian_faraday, mean_deg: 40, sd_deg: 5}
propagation:
  - {type: hv_backscatter_error}
  - {type: backscatter_error_budget, preset: biomass_200m, temporal: {sd_percent: 5}}
retrieval: {type: power_law}
requirements:
  - {type: agb_rmse, sources: computed, max_percent: 30}
  - {type: agb_error_bound, sources: computed, level_margins: true}
  - {type: agb_error_bound, sources: systematic}
simulation: {mode: analytic, seed: 3}
sweep:
  parameters:
    scene.agb_t_ha: [60, 200, 330]
    instrument.nesz_db: [-30, -24]
    ionosphere.sd_deg: [0, 20]
"""


def _bitwise_same(got, expected) -> None:
    """Two ``CaseResult``s with the same numbers bit for bit (the fast path is the reference path)."""
    assert list(got.scalars) == list(expected.scalars)
    for name, value in expected.scalars.items():
        assert got.scalars[name] == value or (math.isnan(value) and math.isnan(got.scalars[name])), name
    for v, w in zip(got.verdicts, expected.verdicts, strict=True):
        assert (v.name, v.passed, v.value, v.margin, v.dominant, v.notes) == (w.name, w.passed, w.value, w.margin,
                                                                              w.dominant, w.notes)
        assert list(v.details) == list(w.details)
        for key, x in w.details.items():
            assert v.details[key] == x or (math.isnan(x) and math.isnan(v.details[key])), key


def _budget_products(resolved):
    from e2esim.runner.blocks import BlockRun
    from e2esim.runner.run import default_services

    return BlockRun(resolved.plan, np.arange(len(resolved.cases)), default_services()).run()


def test_the_error_budget_and_the_agb_error_it_enters_run_batched_with_the_per_case_numbers():
    resolved = Scenario(yaml.safe_load(BUDGET_SWEEP), "budget.yaml").resolve()
    products = _budget_products(resolved)
    kinds = {name: type(value).__name__ for name, value in products.items()}
    assert kinds["backscatter.error"] == "HVErrorModel" and kinds["agb.error"] == "AGBError"
    assert kinds["verdicts"] == "RequirementVerdicts" and kinds["calibration"] == "CalibrationRecord"
    assert len(set(products["backscatter.budget"].index.tolist())) == 6  # one per scene and instrument, not per case
    groups = products["agb.error"].source_groups()
    assert [g for g in groups.values()] == ["systematic"] * 3 + ["random"] * 4
    per_case = run_scenario(resolved, progress=False, engine="per_case")
    for size in (1, 5, 12):  # blocks of one case, ragged blocks, one block
        for start in range(0, 12, size):
            block = run_block(resolved, np.arange(start, min(start + size, 12)))
            for k, index in enumerate(block.indices):
                _bitwise_same(block.case(k, {}, ""), per_case.cases[int(index)])


def _with_regression(monkeypatch, draws: bool):
    """The power law with a regression term that draws from the case's generator, or one the same for every case
    of a scene (a term that draws nothing: the expectation over campaigns, issue 21 item 5)."""
    from e2esim.retrieval import modules
    from e2esim.retrieval.regression_campaign import regression_contribution

    def regression(self, case, model, agb, covariates=None):
        seed = int(case.rng.integers(2**31)) if draws else case.settings.seed  # a seed of the case's own, or the run's
        return regression_contribution(model, agb, self.campaign, seed, covariates, case.services.memo)

    monkeypatch.setattr(modules._Retrieval, "regression", regression)
    data = yaml.safe_load(BUDGET_SWEEP)
    data["retrieval"]["regression"] = {"mode": "confidence"}
    return Scenario(data, "regression.yaml").resolve()


@pytest.mark.parametrize("draws", [False, True])
def test_a_regression_term_runs_batched_unless_it_draws_from_the_cases_generator(monkeypatch, draws):
    resolved = _with_regression(monkeypatch, draws)
    products = _budget_products(resolved)
    assert type(products["agb.error"]).__name__ == ("Factor" if draws else "AGBError")
    regression = [c.relative_variance for c in (products["agb.error"].item(k).contributions for k in range(12))
                  for c in c if c.name == "regression"]
    assert len(set(regression)) == (12 if draws else 3)  # a draw per case, or one per scene
    batched = run_scenario(resolved, progress=False)
    per_case = run_scenario(resolved, progress=False, engine="per_case")
    for got, expected in zip(batched.cases, per_case.cases, strict=True):
        _bitwise_same(got, expected)
