"""Error terms on the batched engine (issue 27, Done when 2; issue 24, Speed): a chain with an ``error_terms`` list
runs its analytic cases in blocks (``ErrorTermStack.forward`` takes blocks, each term wraps the block's error model),
and every number is bit for bit the per-case engine's (the reference path). Cases the block cannot take (a Monte
Carlo, a multi-channel model, a term that draws, a plug-in term that does not declare block support) run one by one,
and a term run so is named in the model's notes.
"""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np
import pytest
import yaml

from e2esim import api
from e2esim.distortion.modules import HVBackscatterErrorPropagation
from e2esim.error_terms.block_wrapped import BlockEffects, BlockWrappedModel
from e2esim.error_terms.modules import AddedNoise, ExtraRelativeVariance, GainError
from e2esim.error_terms.rfi_modules import RFITerm
from e2esim.error_terms.stage import ErrorTermStack
from e2esim.errors import Location
from e2esim.module import batched_run
from e2esim.runner.run import run_block, run_scenario
from e2esim.runner.scenario import Scenario
from e2esim.scintillation.modules import ScintillationSigma0
from e2esim.testing import check_block_invariance

SCENARIO = {
    "name": "terms_in_blocks",
    "scene": {"type": "table1_forest", "forest": "tropical_338"},
    "instrument": {"type": "biomass"},
    "ionosphere": {"type": "gaussian_faraday", "mean_deg": 5.0, "sd_deg": 5.0},
    "propagation": [{"type": "hv_backscatter_error"},
                    {"type": "backscatter_error_budget", "preset": "biomass_200m"}],
    "retrieval": {"type": "power_law"},
    "error_terms": [{"type": "added_noise", "power_db": -40.0},
                    {"type": "gain_error", "sd_db": 0.05, "offset_db": 0.02},
                    {"type": "extra_variance", "relative_sd_percent": 0.5},
                    {"type": "rfi", "band_fraction_percent": 2, "time_fraction_percent": 1,
                     "residual_power_db": -38.0},
                    {"type": "scintillation_sigma0", "lat_deg": 65.0, "lon_deg": 20.0, "month": 3}],
    "requirements": [{"type": "agb_error_bound", "sources": "systematic", "bound_percent": 40,
                      "confidence_percent": 99.865, "level_margins": True},
                     {"type": "agb_rmse", "sources": "computed", "max_percent": 40}],
    "simulation": {"mode": "analytic", "seed": 3, "looks": 2000},
    # the terms' effects differ between the cases of a block (the gain error's spread, off in half of them: its
    # source is then not active; the screen's latitude), and so does the propagation's model
    "sweep": {"mode": "grid", "parameters": {"ionosphere.sd_deg": [2.0, 8.0],
                                             "error_terms.1.sd_db, error_terms.1.offset_db": [[0.0, 0.0], [0.05, 0.02]],
                                             "error_terms.4.lat_deg": [10.0, 65.0]}},
}


MARGIN_KEYS = (".limit_db", ".margin_db", ".spec_margin_db")
"""Level margins: the vectorised root search stops on the block's cases together, so its last digits may differ
from a case alone's (to 1e-12, as tests/test_batched_engine.py allows; the chain without error terms does the same)."""


def _bitwise_same(got, expected) -> None:
    """Two ``CaseResult``s with the same numbers bit for bit (level margins to 1e-12, ``MARGIN_KEYS``)."""
    assert list(got.scalars) == list(expected.scalars)
    for name, value in expected.scalars.items():
        assert got.scalars[name] == value or (math.isnan(value) and math.isnan(got.scalars[name])), name
    assert got.notes == expected.notes
    for v, w in zip(got.verdicts, expected.verdicts, strict=True):
        assert (v.name, v.passed, v.value, v.margin, v.dominant, v.notes, v.coverage) == (
            w.name, w.passed, w.value, w.margin, w.dominant, w.notes, w.coverage)
        assert list(v.details) == list(w.details)
        for key, x in w.details.items():
            y = v.details[key]
            if key.endswith(MARGIN_KEYS):  # the level margins' root search, over a block as over a case alone
                assert y == x or abs(y - x) <= 1e-12 * abs(x), key
                continue
            assert y == x or (math.isnan(x) and math.isnan(y)), key
        assert list(v.curves) == list(w.curves)
        for key, x in w.curves.items():
            np.testing.assert_array_equal(v.curves[key], x, err_msg=key)


def _products(resolved, indices):
    from e2esim.runner.blocks import BlockRun
    from e2esim.runner.run import default_services

    return BlockRun(resolved.plan, indices, default_services()).run()


def test_a_chain_with_every_shipped_term_runs_in_blocks_with_the_per_case_numbers():
    resolved = Scenario(copy.deepcopy(SCENARIO), "terms.yaml").resolve()
    n = len(resolved.cases)
    assert n == 8
    products = _products(resolved, np.arange(n))
    model = products["backscatter.error"]
    assert isinstance(model, BlockWrappedModel)  # the block's model, wrapped by each term in turn
    assert type(products["agb.error"]).__name__ == "AGBError" and type(products["verdicts"]).__name__ == (
        "RequirementVerdicts")
    assert model.sources[-7:] == ("added_noise", "gain_error", "extra_variance", "rfi_notch", "rfi_looks",
                                  "rfi_residual", "scintillation_sigma0")
    per_case = run_scenario(resolved, progress=False, engine="per_case")
    for indices in (np.arange(n), np.array([5, 0, 3])):  # one block; a few cases, in any order and company
        block = run_block(resolved, indices)
        for k, index in enumerate(block.indices):
            _bitwise_same(block.case(k, {}, ""), per_case.cases[int(index)])
    # every term is attributed and has a level margin, in every case
    details = per_case.cases[-1].verdicts[0].details
    for source in ("added_noise", "gain_error", "extra_variance", "rfi_notch", "rfi_looks", "scintillation_sigma0"):
        assert details[f"contribution.{source}_percent"] != 0.0, source
        assert math.isfinite(details[f"{source}.limit_db"]), source


def test_a_block_whose_gain_error_is_off_in_some_cases_says_where_it_was_not_active():
    resolved = Scenario(copy.deepcopy(SCENARIO), "terms.yaml").resolve()
    model = _products(resolved, np.arange(8))["backscatter.error"]
    gain_off = np.array([case["error_terms.1.sd_db"] == 0.0 and case["error_terms.1.offset_db"] == 0.0
                         for case in (resolved.cases[i].inputs for i in range(8))])
    assert 0 < gain_off.sum() < 8
    variant = model.without("gain_error")
    while not (isinstance(variant, BlockWrappedModel) and variant.source == "gain_error"):
        variant = variant.base  # down to the gain error's own wrapper
    np.testing.assert_array_equal(variant.inactive, gain_off)


def _wrapper(model, source: str) -> BlockWrappedModel:
    while not (isinstance(model, BlockWrappedModel) and model.source == source):
        model = model.base
    return model


def _unshared(model):
    """``model`` rebuilt with nothing evaluated or shared between its wrappers (each stacks its own effects)."""
    if not isinstance(model, BlockWrappedModel):
        return model
    return dataclasses.replace(model, base=_unshared(model.base), effects=BlockEffects(model.effects.cases))


def test_the_variants_of_a_block_model_share_their_removed_effects_and_keep_their_own_numbers():
    # a Shapley split asks the model with every subset of its sources removed: the variants that hold the same
    # effects stack them and remove a source from them once (the removed effects are one object, whatever the order
    # of the removals), and every variant's moments are, bit for bit, those of the variant rebuilt with nothing shared
    resolved = Scenario(copy.deepcopy(SCENARIO), "terms.yaml").resolve()
    model = _products(resolved, np.arange(8))["backscatter.error"]
    model.current()
    one = model.without("scintillation_sigma0").without("rfi_notch").without("gain_error")
    other = model.without("gain_error").without("scintillation_sigma0").without("rfi_notch")
    for source in ("scintillation_sigma0", "gain_error"):
        assert _wrapper(one, source).effects is _wrapper(other, source).effects
    for variant in (one, other, model.without("rfi_looks")):
        got, alone = variant.current(), _unshared(variant).current()
        np.testing.assert_array_equal(got.mean, alone.mean)
        np.testing.assert_array_equal(got.variance, alone.variance)


def test_the_stack_with_every_shipped_term_passes_the_block_invariance_check():
    terms = [AddedNoise(power_db=-40.0), GainError(sd_db=0.1, offset_db=0.05),
             ExtraRelativeVariance(relative_sd_percent=1.0),
             RFITerm(band_fraction_percent=10.0, residual_power_db=-35.0, notch_position="edge"),
             ScintillationSigma0(lat_deg=70.0, lon_deg=25.0, month=12, solar="max", contrast=0.5)]
    stack = ErrorTermStack(HVBackscatterErrorPropagation.from_config({}, Location("p")), terms)
    assert check_block_invariance(stack)


class UndeclaredGain(GainError):
    """A plug-in's term that overrides ``effect`` and does not say that its effects take blocks."""

    type_name = "undeclared_gain"

    def effect(self, case, model):
        return super().effect(case, model)


def test_a_term_that_does_not_declare_block_support_runs_case_by_case_and_says_so():
    propagation = HVBackscatterErrorPropagation.from_config({}, Location("p"))
    declared = ErrorTermStack(propagation, [GainError(sd_db=0.1)])
    undeclared = ErrorTermStack(propagation, [UndeclaredGain(sd_db=0.1)])
    assert batched_run(declared) is not None and declared.case_by_case == ()
    assert undeclared.case_by_case == undeclared.terms  # never its parent's block path
    from e2esim.testing import reference_block

    block, cases = reference_block(undeclared.needs, undeclared.uses)
    assert batched_run(undeclared)(block) is None  # the block is handed back: its cases run one by one
    alone = undeclared.forward(cases[0])["backscatter.error"]
    assert any("undeclared_gain" in note and "case by case" in note for note in alone.notes)
    reference = declared.forward(cases[0])["backscatter.error"]
    assert not any("case by case" in note for note in reference.notes)
    assert float(alone.current().variance) == float(reference.current().variance)


def test_an_analytic_case_alone_is_wrapped_as_a_block_of_one(monkeypatch):
    from e2esim.error_terms.modules import ErrorTerm
    from e2esim.error_terms.wrapped import WrappedErrorModel
    from e2esim.testing import reference_block

    propagation = HVBackscatterErrorPropagation.from_config({}, Location("p"))
    stack = ErrorTermStack(propagation, [AddedNoise(power_db=-40.0), GainError(sd_db=0.1, offset_db=0.05)])
    block, cases = reference_block(stack.needs, stack.uses)
    one_case = cases[0].adding(propagation.forward(cases[0]))["backscatter.error"]
    expected = one_case
    for term in stack.terms:  # the one-case path, before the case alone was a block of one
        expected = term.wrap(expected, cases[0])
    assert stack.one_case_only(one_case) is None

    def no_one_case_path(self, model, case):
        raise AssertionError("a case alone took the one-case path")

    monkeypatch.setattr(ErrorTerm, "wrap", no_one_case_path)
    alone = stack.forward(cases[0])["backscatter.error"]
    assert type(alone) is WrappedErrorModel and alone.sources == expected.sources  # the case's own product
    assert float(alone.current().variance) == float(expected.current().variance)
    assert float(alone.current().mean) == float(expected.current().mean)
    in_block = batched_run(stack)(block)["backscatter.error"]
    assert float(in_block.current().variance[0]) == float(expected.current().variance)
    undeclared = ErrorTermStack(propagation, [UndeclaredGain(sd_db=0.1)])
    assert "undeclared_gain" in undeclared.one_case_only(one_case)


@pytest.mark.parametrize("mode", ["montecarlo", "both"])
def test_monte_carlo_cases_with_error_terms_keep_the_per_case_numbers(mode):
    data = copy.deepcopy(SCENARIO)
    data["simulation"] = {"mode": mode, "seed": 3, "looks": 500, "realisations": 60}
    data["sweep"] = {"parameters": {"ionosphere.sd_deg": [2.0, 8.0]}}
    data["requirements"] = [{"type": "agb_error_bound", "sources": "systematic"}]
    runs = [api.run(data, engine=engine) for engine in ("batched", "per_case")]
    assert runs[0].scalars.keys() == runs[1].scalars.keys()
    for k in runs[0].scalars:
        np.testing.assert_array_equal(runs[0].scalars[k], runs[1].scalars[k], err_msg=k)


def test_the_scenario_yaml_of_the_test_is_plain_data():
    assert yaml.safe_load(yaml.safe_dump(SCENARIO)) == SCENARIO


def _error_term_sentences_case_by_case(result) -> list:
    """The report's error-term sentences as 772ca19 made them, case by case (the reference of the columns' version)."""
    from e2esim.io.error_budget import unit_key
    from e2esim.report.blocks import fmt
    from e2esim.report.conclusions import NEGLIGIBLE_SHARE
    from e2esim.requirements.source_names import source_name

    modules = result.scenario.cases[0].modules
    sources = [m.source for m in modules if getattr(m, "kind", None) == "error_terms" and hasattr(m, "source")]
    out = []
    for j, name in enumerate(result.requirement_names):
        for source in dict.fromkeys(sources):
            rows = []
            for case in result.cases:
                v = case.verdicts[j]
                share = v.details.get(f"contribution.{source}_{unit_key(v.unit)}")
                if share is not None and v.limit is not None:
                    rows.append((abs(float(share)), case, v))
            if not rows:
                continue
            worst, case, v = max(rows, key=lambda r: r[0])
            unit = "percentage points" if v.unit == "%" else v.unit
            small = [r for r in rows if r[0] < NEGLIGIBLE_SHARE * abs(float(r[2].limit))]
            large = [r[1].label for r in rows if r[0] >= NEGLIGIBLE_SHARE * abs(float(r[2].limit))]
            sentence = (f"{source_name(source)} changes the checked value of {name} by at most {fmt(worst, 3)} "
                        f"{unit} (case {case.index}: {case.label}); it is negligible (below a tenth of the limit, "
                        f"{fmt(NEGLIGIBLE_SHARE * abs(float(v.limit)), 3)} {unit}) in {len(small)} of {len(rows)} "
                        "cases")
            if large:
                sentence += f"; not in {', '.join(large[:4])}" + (f" and {len(large) - 4} more" if len(large) > 4
                                                                    else "")
            out.append(sentence + ".")
    return out


def test_the_reports_error_term_sentences_read_from_the_columns_are_those_made_case_by_case():
    # the report reads each term's largest change and its negligible cases from the result's columns (a 1 deg map
    # has 150 000 cases); the sentences are word for word those made case by case, in blocks and case by case
    from e2esim.report.conclusions import error_term_sentences

    data = copy.deepcopy(SCENARIO)
    data["requirements"][0]["bound_percent"] = data["requirements"][1]["max_percent"] = 2.0  # some not negligible
    resolved = Scenario(data, "terms.yaml").resolve()
    for engine in ("batched", "per_case"):
        result = run_scenario(resolved, progress=False, engine=engine)
        sentences = error_term_sentences(result)
        assert sentences == _error_term_sentences_case_by_case(result)
        assert len(sentences) >= 8 and any("; not in " in s for s in sentences), sentences
