"""Settings that change nothing (issue 21, item 6; e2esim.runner.no_effect): a swept or overridden key that changes
no result of its cases is reported with the stage that ignores it; a key that acts is not; Monte Carlo noise is
not mistaken for an effect."""

import copy
import json
import warnings

import numpy as np
import pytest

import e2esim
from e2esim.api import NoEffectWarning
from e2esim.cli import main
from e2esim.runner.no_effect import MONTE_CARLO_NOTE, no_effect
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario
from e2esim.runner.variation import Contexts, column_products, is_sampled
from stack_helpers import ground_cancelled_with_faraday_correction


def single_pass(sweep=None, mode="analytic", **sections):
    """A small single-pass HV chain (Men et al. 2021) as a scenario dict."""
    raw = {
        "name": "no_effect_case",
        "scene": {"type": "table1_forest", "forest": "boreal_200"},
        "instrument": {"type": "biomass"},
        "ionosphere": {"type": "gaussian_faraday", "mean_deg": 20.0, "sd_deg": 5.0},
        "propagation": {"type": "hv_backscatter_error"},
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_rmse", "max_percent": 20}],
        "simulation": {"mode": mode, "seed": 7, "looks": 2000, "realisations": 300},
    }
    raw.update(sections)
    if sweep:
        raw["sweep"] = {"mode": "grid", "parameters": sweep}
    return raw


def findings(raw, *overrides):
    scenario = Scenario(raw, "test.yaml")
    for item in overrides:
        scenario.override(item)
    return no_effect(run_scenario(scenario.resolve(), progress=False))


def test_the_ground_cancelled_hv_estimate_ignores_the_faraday_rotation_window():
    """The case of the issue: in a 3-pass ground-cancelled chain the window of the calibration's Faraday-rotation
    estimate changes no HV result (the symmetrised HV is rotation invariant, so the estimate's error cannot reach
    it), while the HH + HV + VV estimate sees it (tests/test_stack_faraday_residual.py). Reported for the HV cases
    only, naming the key, the stack stage and why; the calibration's own outputs do move."""
    raw = ground_cancelled_with_faraday_correction(looks=(20, 100_000))
    raw["sweep"]["parameters"]["propagation.0.channels, retrieval.type"] = [
        ["hv", "stack_power_law"], ["all", "stack_multichannel_power_law"]]
    (found,) = findings(raw)
    assert found.key == "calibration.0.looks" and found.source == "sweep"
    assert found.stage == "propagation type 'stack_backscatter_error' (propagation.0)"
    assert "propagation.0.channels=hv" in found.where and "(2 of 4 cases)" in found.where
    assert "(M_hv + M_vh)/2" in found.reason and "Section 3.3" in found.reason
    assert any(name.startswith("calibration.0.faraday_correction.omega_error") for name in found.changed)


def test_a_swept_key_its_module_ignores_is_reported_with_that_module():
    """The Monte Carlo method in an analytic run: nothing reads it (the module's own outputs do not move)."""
    (found,) = findings(single_pass({"propagation.mc_method": ["fast", "brute_force"]}))
    assert found.key == "propagation.mc_method" and found.where == "any case"
    assert found.stage == "propagation type 'hv_backscatter_error'" and found.changed == ()
    assert found.message().startswith("swept propagation.mc_method changes no result in any case: propagation type")


def test_an_effective_key_is_not_reported():
    """Crosstalk moves every result; the AGB level too; and an analytic key swept together with a dead one is one
    sweep group that acts."""
    assert findings(single_pass({"instrument.crosstalk.level_db": [-30.0, -25.0],
                                 "scene.forest": ["boreal_50", "boreal_200"]})) == []
    together = {"propagation.mc_method, instrument.crosstalk.level_db": [["fast", -30.0], ["brute_force", -25.0]]}
    assert findings(single_pass(together)) == []


def test_a_key_that_changes_only_the_random_stream_is_reported_but_sampling_settings_are_not():
    """Mode both: every case draws its own stream, so the Monte Carlo numbers of the two Monte Carlo methods
    differ; the analytic results decide, and they do not move. simulation.realisations changes the draws on
    purpose: compared on the samples, it acts (in mode both) and changes nothing (in mode analytic)."""
    (found,) = findings(single_pass({"propagation.mc_method": ["fast", "brute_force"]}, mode="both",
                                    simulation={"mode": "both", "seed": 7, "looks": 200, "realisations": 60}))
    assert found.key == "propagation.mc_method" and found.note == MONTE_CARLO_NOTE
    sweep = {"simulation.realisations": [50, 60]}
    assert findings(single_pass(sweep, mode="both")) == []
    (found,) = findings(single_pass(sweep))
    assert found.key == "simulation.realisations" and found.stage == "" and "no stage uses it" in found.reason


def test_monte_carlo_verdicts_cannot_tell():
    """Where a Monte Carlo result decides, differences between two cases' draws cannot be told from an effect:
    nothing is said."""
    raw = single_pass({"propagation.mc_method": ["fast", "brute_force"]}, mode="montecarlo")
    raw["simulation"].update(mode="montecarlo", looks=200, realisations=60)
    assert findings(raw) == []


def test_overrides_that_change_nothing(tmp_path, capsys):
    """An override the module never reads (the pass of a single-date estimate, with a ground-cancelled one), one
    that sets the value already in force, one that sets the default, a Monte Carlo size with no Monte Carlo; on the
    command line as warnings on standard error and in summary.json; through e2esim.run as NoEffectWarning. An
    override that acts says nothing."""
    raw = ground_cancelled_with_faraday_correction(channels="hv", looks=(1000,))
    raw.pop("sweep")
    scenario = tmp_path / "gc.yaml"
    scenario.write_text(json.dumps(raw))
    out = tmp_path / "run"
    assert main(["run", str(scenario), "-o", str(out), "--no-progress", "--set", "propagation.0.date=2",
                 "--set", "propagation.0.system_error_correlation=1.0", "--set", "propagation.0.reference=scene",
                 "--set", "simulation.realisations=100", "--set", "calibration.0.looks=500",
                 "--set", "instrument.nesz_db=-25"]) == 0
    err = capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())["settings_without_effect"]
    by_key = {f["key"]: f for f in summary}
    assert set(by_key) == {"propagation.0.date", "propagation.0.system_error_correlation", "propagation.0.reference",
                           "simulation.realisations", "calibration.0.looks"}
    assert by_key["propagation.0.date"]["stage"] == "propagation type 'stack_backscatter_error' (propagation.0)"
    assert by_key["propagation.0.date"]["reason"] == "it never reads date in this run"
    assert by_key["propagation.0.system_error_correlation"]["reason"] == "the scenario already sets 1.0"
    assert by_key["propagation.0.reference"]["reason"] == "scene is its default"
    assert "runs no Monte Carlo" in by_key["simulation.realisations"]["reason"]
    assert "(M_hv + M_vh)/2" in by_key["calibration.0.looks"]["reason"]
    for f in summary:
        assert f"e2esim: warning: {f['message']}" in err and f["source"] == "--set"
    assert "Settings that change nothing" in (out / "report.md").read_text()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        results = e2esim.run(raw, **{"propagation.0.date": 3})
    assert [str(w.message) for w in caught if w.category is NoEffectWarning] == results.settings_without_effect
    assert len(results.settings_without_effect) == 1 and "never reads date" in results.settings_without_effect[0]


def test_an_override_read_by_a_stage_that_depends_on_it_is_not_reported():
    """The Faraday-rotation window reaches HH and VV of the joint estimate: no stage says it ignores it."""
    raw = ground_cancelled_with_faraday_correction(looks=(1000,))
    raw.pop("sweep")
    assert findings(raw, "calibration.0.looks=500") == []


def test_contexts_compare_values_presence_and_non_finite_numbers():
    """Contexts of a 2 x 3 grid (group 0 varied, 3 contexts); a column varies where two present values differ
    beyond 1e-9 of its largest magnitude, where it is present in some cases only, or where NaN, +inf and -inf
    are not in the same cases; a sampled column by presence only."""
    codes = np.stack(np.unravel_index(np.arange(6), (2, 3)), -1)
    ctx = Contexts.of(codes, np.arange(6), 0)
    assert ctx.evidence.all() and list(ctx.sizes) == [2, 2, 2]
    values = np.array([1.0, 5.0, np.nan, 1.0 + 1e-10, 6.0, np.inf])
    present = np.array([True, True, True, True, True, False])
    assert list(ctx.varies(values, present, False)) == [False, True, True]
    assert list(ctx.varies(values, present, True)) == [False, False, True]
    both_nan = np.array([1.0, np.nan, -np.inf, 1.0, np.nan, -np.inf])
    assert not ctx.varies(both_nan, np.ones(6, bool), False).any()
    assert Contexts.of(codes, np.array([0, 1, 2]), 0).evidence.tolist() == [False, False, False]


def test_columns_belong_to_the_products_that_write_them():
    class Stage:
        def __init__(self, *products):
            self.provides = products

    from e2esim import products as P

    chain = [Stage(P.CALIBRATION, P.SYSTEM_RESIDUAL), Stage(P.BACKSCATTER_ERROR), Stage(P.AGB_ERROR), Stage(P.VERDICTS)]
    owners = column_products(["calibration.steps", "system.noise_power", "analytic.mean", "agb.exponent",
                              "requirement0.value", "requirement1.details.over.montecarlo.quantile_percent"], chain)
    assert owners == {"calibration.steps": "calibration", "system.noise_power": "system.residual",
                      "analytic.mean": "backscatter.error", "agb.exponent": "agb.error",
                      "requirement0.value": "verdicts", "requirement1.details.over.montecarlo.quantile_percent":
                      "verdicts"}
    assert is_sampled("hv.montecarlo.mean") and is_sampled("comparison.bias_rel") and not is_sampled("analytic.mean")


@pytest.mark.parametrize("engine", ["batched", "per_case"])
def test_the_engines_report_the_same(engine):
    raw = single_pass({"propagation.mc_method": ["fast", "brute_force"], "scene.forest": ["boreal_50", "boreal_200"]})
    result = run_scenario(Scenario(raw, "test.yaml").resolve(), progress=False, engine=engine)
    assert [f.message() for f in no_effect(result)] == [
        "swept propagation.mc_method changes no result in any case: propagation type 'hv_backscatter_error' ignores it"]


def test_the_findings_and_the_results_facade_are_made_once_and_equal_a_fresh_computation(monkeypatch):
    """Issue 27, Build 7: what is derived once from a run is kept with it (``ScenarioResult.no_effect``, a
    ``cached_property``), never stashed in its ``__dict__`` by another module: the summary, the report and
    ``Results`` all read one search, equal to a search made afresh; a copy (``dataclasses.replace``) starts
    without it; ``e2esim.run`` makes the ``Results`` facade once and it equals one made anew from its run."""
    import dataclasses

    import e2esim.runner.no_effect as module
    from e2esim.io.summary import summary_dict
    from e2esim.results import Results

    searches = []
    search = module.sweep_findings
    monkeypatch.setattr(module, "sweep_findings", lambda result: searches.append(1) or search(result))
    raw = single_pass({"propagation.mc_method": ["fast", "brute_force"]})
    result = run_scenario(Scenario(raw, "test.yaml").resolve(), progress=False)
    kept = no_effect(result)
    summary = summary_dict(result)
    facade = Results.from_run(result)
    assert no_effect(result) is kept is result.no_effect and len(searches) == 1
    assert kept == module.findings(result) and len(kept) == 1 and len(searches) == 2  # the fresh search
    assert summary["settings_without_effect"] == [f.as_dict() for f in kept]
    assert facade.settings_without_effect == [f.message() for f in kept]
    copy = dataclasses.replace(result)
    assert "no_effect" not in vars(copy) and copy.map_dataset is None and copy.no_effect == kept

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoEffectWarning)
        results = e2esim.run(raw)
    fresh = Results.from_run(results.run)
    assert results.run.no_effect is not None and fresh.settings_without_effect == results.settings_without_effect
    for name in ("labels", "inputs", "units", "requirements", "provenance"):
        assert getattr(fresh, name) == getattr(results, name), name
    assert fresh.scalars.keys() == results.scalars.keys()
    for name in fresh.scalars:
        np.testing.assert_array_equal(fresh.scalars[name], results.scalars[name])
    for name in ("passed", "value", "limit", "margin", "status", "reason", "dominant"):
        np.testing.assert_array_equal(getattr(fresh, name), getattr(results, name))


def test_worker_processes_report_what_their_modules_read(monkeypatch):
    """The settings a run never read are found from what every process read: worker processes send their modules'
    reads back (e2esim.runner.executors.note_worker_reads). Before, a run on workers (the default --workers auto
    moves long runs to workers) reported no such setting at all."""
    raw = ground_cancelled_with_faraday_correction(channels="hv", looks=(1000,))
    raw["sweep"] = {"mode": "grid", "parameters": {"instrument.nesz_db": [-30, -27, -24, -21]}}
    reports = []
    for workers in (1, 2):
        scenario = Scenario(copy.deepcopy(raw), "test.yaml")
        for item in ("propagation.0.date=2", "instrument.crosstalk.level_db=-29"):
            scenario.override(item)
        result = run_scenario(scenario.resolve(), progress=False, workers=workers)
        reports.append([f.message() for f in no_effect(result)])
    assert reports[1] == reports[0]
    assert len(reports[0]) == 1 and "never reads date" in reports[0][0]
