"""The fast path is the reference path (issue 21, item 1): a batched method is used only where it describes the
one-case method in force, and ``check_module`` proves block invariance for any module it is given."""

from __future__ import annotations

import numpy as np
import pytest

from e2esim.block import Batched, Block
from e2esim.budget.modules import BackscatterErrorBudget
from e2esim.distortion.modules import HVBackscatterErrorPropagation
from e2esim.error_terms.effects import ExtraVariance
from e2esim.error_terms.modules import ErrorTerm, source_param
from e2esim.errors import Location
from e2esim.module import batched_run, fast_path
from e2esim.requirements.modules import AGBErrorBound
from e2esim.requirements.stage import RequirementSet
from e2esim.retrieval.modules import PowerLawRetrieval
from e2esim.testing import check_block_invariance, check_error_term_blocks, check_module


class OwnForward(HVBackscatterErrorPropagation):
    """A plug-in that follows docs/writing-a-module.md §3: its own forward, the parent's forward_takes_blocks."""

    type_name = "own_forward"

    def forward(self, case):
        return super().forward(case)


class OwnForwardAndBlock(OwnForward):
    type_name = "own_forward_and_block"
    forward_takes_blocks = True  # it says its forward takes blocks


class WrongBlock(HVBackscatterErrorPropagation):
    """A forward whose answer for a block does not describe its cases (it gives them in reverse order):
    check_module must say so."""

    type_name = "wrong_block"
    forward_takes_blocks = True

    def forward(self, case):
        out = super().forward(case)
        if not isinstance(case, Block):
            return out
        reverse = np.arange(len(case))[::-1]
        return {name: value.take(reverse) for name, value in out.items()}


class OwnExponent(PowerLawRetrieval):
    type_name = "own_exponent"

    def case_exponent(self, case):
        return 1.5


class OwnEvaluate(AGBErrorBound):
    type_name = "own_evaluate"

    def evaluate(self, case):
        return super().evaluate(case)


def test_a_subclass_that_overrides_forward_does_not_inherit_the_fast_path():
    assert batched_run(HVBackscatterErrorPropagation()) is not None
    assert batched_run(OwnForward()) is None
    assert batched_run(OwnForwardAndBlock()) is not None  # it says its forward takes blocks


def test_overriding_a_hook_of_the_fast_path_turns_it_off():
    assert batched_run(PowerLawRetrieval()) is not None
    assert batched_run(OwnExponent()) is None


def test_a_requirement_that_overrides_evaluate_is_evaluated_case_by_case():
    assert fast_path(AGBErrorBound(), "batched", "evaluate")
    assert fast_path(OwnEvaluate(), "batched", "evaluate") is None
    assert check_block_invariance(RequirementSet([AGBErrorBound(level_margins=True)], Location("t")))
    assert not check_block_invariance(RequirementSet([OwnEvaluate()], Location("t")))


@pytest.mark.parametrize("cls, config", [
    (HVBackscatterErrorPropagation, {}), (PowerLawRetrieval, {}), (OwnForwardAndBlock, {}),
    (BackscatterErrorBudget, {"temporal": {"sd_percent": 5.0}}),
    (AGBErrorBound, {"level_margins": True, "tradeoff_curve": True, "curve_points": 5}),
])
def test_built_in_fast_paths_are_block_invariant(cls, config):
    module = check_module(cls, config)
    stage = RequirementSet([module], Location("t")) if isinstance(module, AGBErrorBound) else module
    assert check_block_invariance(stage)  # checked, not skipped


def test_check_module_finds_a_fast_path_that_differs_from_forward():
    with pytest.raises(AssertionError, match="differs from the case run alone"):
        check_module(WrongBlock)


def test_the_block_of_the_check_is_batched_where_the_engine_batches():
    from e2esim.testing import reference_block

    block, cases = reference_block(("agb.error",))
    assert isinstance(block["backscatter.error"], Batched) and isinstance(block["agb.error"], Batched)
    assert len(cases) == len(block) == 4
    assert len({float(c["agb.error"].rmse()) for c in cases}) == 4  # the cases differ


def test_the_power_law_with_an_error_budget_is_block_invariant():
    from e2esim.testing import reference_case

    case = reference_case(("scene.covariance", "backscatter.error", "instrument"))
    case = case.adding(BackscatterErrorBudget(temporal={"sd_percent": 5.0}).forward(case))
    assert check_block_invariance(PowerLawRetrieval(), case)


class HandsBack(HVBackscatterErrorPropagation):
    """A forward that takes blocks but needs every case alone."""

    type_name = "hands_back"
    forward_takes_blocks = True

    def forward(self, case):
        case.per_case("every case alone")
        return super().forward(case)


def test_one_forward_answers_for_a_block_as_for_each_case_alone():
    """Issue 27, Build 1: hv_backscatter_error has one forward; on a block it gives one HVErrorModel with the case
    axis, whose every answer (moments, sources removed, contributions) is bit for bit the case's alone."""
    from e2esim.distortion.error_model import HVErrorModel
    from e2esim.testing import reference_block

    block, cases = reference_block(HVBackscatterErrorPropagation.needs)
    assert batched_run(HandsBack())(block) is None  # handed back: the engine runs the cases one by one
    model = batched_run(HVBackscatterErrorPropagation())(block)["backscatter.error"]
    assert type(model) is HVErrorModel and len(model) == len(cases) == 4
    columns = model.scalar_columns()
    for k, case in enumerate(cases):
        alone = HVBackscatterErrorPropagation().forward(case)["backscatter.error"]
        assert type(alone) is HVErrorModel and len(alone) == 1
        assert {name: columns[name][k] for name in columns} == alone.scalars()
        for source in alone.sources:
            variant, in_block = alone.without(source), model.without(source)
            if variant is alone:  # not active in this case: the block marks it, or is its own variant
                assert in_block is model or in_block.inactive[k], source
            else:
                assert in_block.current().variance[k] == variant.current().variance, source
        for name, part in alone.contributions().items():
            assert model.contributions()[name].variance[k] == part.variance, name


class OwnBudgetForward(BackscatterErrorBudget):
    type_name = "own_budget_forward"

    def forward(self, case):
        return super().forward(case)


class OwnVerdictsForward(RequirementSet):
    def forward(self, case):
        return super().forward(case)


@pytest.mark.parametrize("cls", [PowerLawRetrieval, BackscatterErrorBudget, RequirementSet])
def test_the_folded_stages_have_one_forward_that_takes_blocks(cls):
    """Issue 27, Build 1: no stage keeps a second, batched method beside its forward."""
    assert not hasattr(cls, "forward_block") and cls.forward_takes_blocks


def test_a_subclass_of_a_folded_stage_that_overrides_forward_runs_case_by_case():
    assert batched_run(BackscatterErrorBudget()) is not None and batched_run(OwnBudgetForward()) is None
    assert batched_run(RequirementSet([AGBErrorBound()], Location("t"))) is not None
    assert batched_run(OwnVerdictsForward([AGBErrorBound()], Location("t"))) is None


def test_the_error_model_answers_a_block_where_no_case_has_a_source_as_a_case_alone():
    """Issue 27, item 2: ``HVErrorModel.without`` of a source no case has is the model itself, for a block as for a
    case alone (a block of one); the contributions are floats for a case alone, arrays over a block's cases."""
    from e2esim.testing import BLOCK_VARIANTS, reference_block

    still = tuple({**v, "ionosphere": {"mean_deg": 0.0, "sd_deg": 0.0}} for v in BLOCK_VARIANTS)
    block, cases = reference_block(HVBackscatterErrorPropagation.needs, variants=still)
    model = batched_run(HVBackscatterErrorPropagation())(block)["backscatter.error"]
    assert model.without("faraday_rotation") is model
    assert model.without("crosstalk") is not model
    in_block = model.contributions()
    for k, case in enumerate(cases):
        alone = HVBackscatterErrorPropagation().forward(case)["backscatter.error"]
        assert alone.without("faraday_rotation") is alone
        for name, part in alone.contributions().items():
            assert type(part.variance) is float and in_block[name].variance[k] == part.variance, name


def test_a_case_alone_and_a_block_of_one_make_the_same_variants():
    """Issue 27, item 2: the HV error model makes a variant (a source removed) one way for a case alone and a
    block, with no branch on a case alone: the model's own products, no Monte Carlo samples, and no ``inactive``
    marks where every case has the source (a block of one marks nothing, as a case alone does); the variants'
    moments are the same bits."""
    from e2esim.testing import BLOCK_VARIANTS, reference_block

    block, cases = reference_block(HVBackscatterErrorPropagation.needs, variants=BLOCK_VARIANTS[1:2])
    one = batched_run(HVBackscatterErrorPropagation())(block)["backscatter.error"]
    alone = HVBackscatterErrorPropagation().forward(cases[0])["backscatter.error"]
    assert len(one) == len(alone) == 1
    for source in ("crosstalk", "channel_imbalance", "noise", "faraday_rotation"):
        a, b = alone.without(source), one.without(source)
        assert a is not alone and b is not one, source
        assert a.inactive is None and b.inactive is None, source
        assert a.system is alone.system and a.faraday is alone.faraday and a.montecarlo is None, source
        assert b.current().variance[0] == a.current().variance and b.current().mean[0] == a.current().mean, source


class OwnBudgetInputs(BackscatterErrorBudget):
    """A budget that reads more of the instrument than ``_instrument_reads`` says (its NESZ doubled)."""

    type_name = "own_budget_inputs"

    def _inputs_with(self, inst):
        base = super()._inputs_with(inst)
        return base.replace(nesz=2 * base.nesz)


def test_the_budget_has_one_path_for_a_case_alone_and_a_block():
    """Issue 27, item 2: the budget's forward makes a case alone's budget as a block's (no case.alone branch), from
    the inputs ``_inputs_with`` gives; a subclass that overrides that hook runs case by case (it may read what the
    block's sharing of budgets between instruments does not look at) and its case alone gets its own inputs."""
    from e2esim.testing import reference_case

    case = reference_case(("scene.covariance", "backscatter.error", "instrument"))
    own = OwnBudgetInputs(temporal={"sd_percent": 5.0})
    assert batched_run(own) is None
    got = own.forward(case)["backscatter.budget"]
    plain = BackscatterErrorBudget(temporal={"sd_percent": 5.0})
    expected = plain.forward(case)["backscatter.budget"]
    assert np.all(np.isfinite(expected.snr)) and np.array_equal(2 * got.snr, expected.snr)  # sigma / (2 sigma_n)
    assert check_block_invariance(plain, case)


def test_a_block_reads_its_products_by_declared_form():
    """Block.common, factor and batched (the typed reads that replaced FactorView and BlockView): a text every case
    shares, the distinct values, a product with its case axis; NotBatched where the block does not have that form."""
    from e2esim.block import Factor, NotBatched
    from e2esim.testing import reference_block, reference_case

    block, cases = reference_block(("agb.error",))
    assert block.batched("agb.error") is block["agb.error"]
    scenes = block.factor("scene.covariance")
    assert isinstance(scenes, Factor) and [scenes.item(k) for k in range(len(block))] == [
        c["scene.covariance"] for c in cases]
    with pytest.raises(NotBatched, match="carries a case axis"):
        block.factor("agb.error")
    with pytest.raises(NotBatched, match="made case by case"):
        block.batched("scene.covariance")
    assert block.common("scene.covariance", "kind", lambda v: type(v).__name__) == "ScatteringCovariance"
    with pytest.raises(NotBatched, match="AGB differs"):
        block.common("scene.covariance", "AGB", lambda v: v.agb_t_ha)
    alone = reference_case(("scene.covariance",))
    assert alone.factor("scene.covariance").item(0) is alone["scene.covariance"]
    assert alone.common("scene.covariance", "AGB", lambda v: v.agb_t_ha) == alone["scene.covariance"].agb_t_ha


class ForestVariance(ErrorTerm):
    """A plug-in error term whose level depends on the case: an extra relative variance growing with the forest's
    AGB (its effects may be made from a block's cases: effects_take_blocks)."""

    type_name = "forest_variance"
    summary = "extra variance growing with AGB (a test's plug-in)"
    params = (source_param("forest_variance"),)
    needs = ("scene.covariance",)
    effects_take_blocks = True

    def effect(self, case, model):
        return ExtraVariance(self.source, 1e-4 * case["scene.covariance"].agb_t_ha, "extra variance ~ AGB")


class FirstCaseForAll(ForestVariance):
    """A wrong plug-in: it makes a block's effects together (block_case_effects) but gives every case the first
    case's effects; it says again that its effects take blocks, so the fast path stays on."""

    type_name = "first_case_for_all"
    effects_take_blocks = True

    def block_case_effects(self, block, model):
        from e2esim.error_terms.block_case import case_of

        first = self.case_effects(case_of(block, 0), model.item(0))
        return [first] * len(block)


def test_check_module_proves_an_error_term_block_invariant():
    """Issue 27: an error term's effects in a block equal its per-case effects (checked, not skipped)."""
    assert check_error_term_blocks(ForestVariance())
    check_module(ForestVariance)


def test_check_module_finds_an_error_term_whose_block_effects_differ():
    with pytest.raises(AssertionError, match="differs from the case run alone"):
        check_module(FirstCaseForAll)
