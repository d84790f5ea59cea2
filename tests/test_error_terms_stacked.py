"""A block's effects evaluated together (issue 24, Speed): ``BlockWrappedModel`` stacks the distinct effects of its
cases over the case axis (``e2esim.error_terms.effect_stack``) and every number is bit for bit what each case's
one-case ``WrappedErrorModel`` gives, at the model's own levels and at levels asked with further axes (a margin's
search), for every shipped effect class, for effects whose acquisitions differ in number, and for a plug-in's effect
that does not declare stacked fields (evaluated alone). A term that declares that its effects do not read the model
gets no one-case model in a block; one that reads it anyway hands the block back.
"""

from __future__ import annotations

import numpy as np
import pytest

from e2esim.block import NotBatched
from e2esim.distortion.modules import HVBackscatterErrorPropagation
from e2esim.error_terms.block_case import UNREAD_MODEL
from e2esim.error_terms.block_wrapped import block_wrapped
from e2esim.error_terms.effect_stack import stack_groups
from e2esim.error_terms.effects import AddedPower, ExtraVariance, FixedGain, GammaFactor, LogNormalGain
from e2esim.error_terms.modules import GainError
from e2esim.error_terms.wrapped import wrapped
from e2esim.errors import Location
from e2esim.scintillation.effects import CKL_LEVEL, CalibratorFactor, DistributedTargetFactor, FaradayLeakage
from e2esim.testing import reference_block

CASES = 12


@pytest.fixture(scope="module")
def base():
    """A batched single-channel model of CASES varied cases (the propagation's, four variants repeated)."""
    propagation = HVBackscatterErrorPropagation.from_config({}, Location("p"))
    block, _ = reference_block(propagation.needs, propagation.uses)
    model = propagation.forward(block)["backscatter.error"]
    return model.take(np.arange(CASES) % len(model))


def _tuple(rng, n, low, high):
    return tuple(float(x) for x in rng.uniform(low, high, n))


def _distributed(rng, n):
    w = rng.uniform(0.1, 1.0, n)
    return DistributedTargetFactor("s", CKL_LEVEL, weight=tuple(float(x) for x in w / w.sum()),
                                   shape=_tuple(rng, n, 0.5, 3.0), scale=_tuple(rng, n, 0.0, 0.2),
                                   shift_sd_cells=_tuple(rng, n, 0.0, 0.3), halo_share=_tuple(rng, n, 0.0, 1.0),
                                   cell_fraction=float(rng.uniform(0.02, 0.1)), contrast=float(rng.uniform(0, 1)))


def _faraday(rng, n):
    w = rng.uniform(0.1, 1.0, n)
    return FaradayLeakage("s", CKL_LEVEL, scale=(1.0,), looks=int(rng.integers(1, 50)),
                          weight=tuple(float(x) for x in w / w.sum()), window_variance=_tuple(rng, n, 0.0, 1e-3),
                          copol_power=float(rng.uniform(0.01, 0.2)))


MAKERS = {
    "gamma": lambda rng, k: GammaFactor("s", float(rng.uniform(0.0, 0.1))),
    "fixed_gain": lambda rng, k: FixedGain("s", float(rng.uniform(0.0, 0.2))),
    "log_normal": lambda rng, k: LogNormalGain("s", float(rng.uniform(0.0, 0.01)),
                                               offset_db=float(rng.uniform(-0.5, 0.5))),
    "added_power": lambda rng, k: AddedPower("s", float(rng.uniform(0.0, 1e-3)), looks=int(rng.integers(1, 50)),
                                             subtracted=bool(k % 3 == 0)),  # two groups: the flag differs
    "extra_variance": lambda rng, k: ExtraVariance("s", float(rng.uniform(0.0, 0.01))),
    "calibrator": lambda rng, k: CalibratorFactor("s", CKL_LEVEL, mean_log=float(rng.uniform(0.0, 0.1)),
                                                  var_log=float(rng.uniform(0.0, 0.01))),
    # acquisitions from 1 to 10 per case (rows of different lengths are evaluated apart)
    "distributed_target": lambda rng, k: _distributed(rng, 1 + k % 10),
    "distributed_target_equal": lambda rng, k: _distributed(rng, 8),
    "faraday_leakage": lambda rng, k: _faraday(rng, 1 + k % 4),
}


def _assert_each_case_alone(model, base, effects, **levels):
    """``model.moments(**levels)`` (levels with the case axis first) bit for bit each case's one-case moments."""
    got = model.moments(**levels)
    for i, effect in enumerate(effects):
        alone = wrapped(base.item(i), effect).moments(**{k: v[i] for k, v in levels.items()})
        np.testing.assert_array_equal(got.mean[i], alone.mean, err_msg=f"case {i} mean")
        np.testing.assert_array_equal(got.variance[i], alone.variance, err_msg=f"case {i} variance")


@pytest.mark.parametrize("kind", sorted(MAKERS))
def test_a_block_of_distinct_effects_gives_every_case_its_own_moments_bit_for_bit(base, kind, rng):
    effects = [MAKERS[kind](rng, k) for k in range(CASES)]
    model = block_wrapped(base, effects)
    assert len(stack_groups(model.effects.values)) < len(model.effects.values)  # evaluated together
    _assert_each_case_alone(model, base, effects)
    own = np.array([e.level for e in effects])
    # a margin's search: the own level scaled over a further axis, and a level of the base model with it
    _assert_each_case_alone(model, base, effects, s=own[:, None] * np.array([0.0, 0.5, 3.0, 40.0]))
    _assert_each_case_alone(model, base, effects, nesz=np.asarray(base.levels["nesz"])[:, None] * np.array([1, 2.0]))
    removed = model.without("s")  # the effect taken away, case by case
    for i, effect in enumerate(effects):
        alone = wrapped(base.item(i), effect).without("s").current()
        assert removed.current().mean[i] == alone.mean and removed.current().variance[i] == alone.variance


class PlugInGain(GammaFactor):
    """A plug-in's effect that does not list its stacked fields: its own ``factor_moments`` reads ``level`` as a
    Python number would not allow (``float``), so stacking it would fail, not just differ."""

    def factor_moments(self, level):
        return super().factor_moments([float(x) for x in np.ravel(level)] if np.ndim(level) else float(level))


def test_a_plug_in_effect_without_stacked_fields_is_evaluated_effect_by_effect(base, rng):
    effects = [PlugInGain("s", float(rng.uniform(0.0, 0.1))) for _ in range(CASES)]
    model = block_wrapped(base, effects)
    assert len(stack_groups(model.effects.values)) == CASES  # each alone
    _assert_each_case_alone(model, base, effects)


def test_a_sum_over_the_last_axis_is_each_row_s_own_sum(rng):
    """What the stacking relies on: numpy sums each row of an array (..., n) as it sums that row alone (the one-case
    equations sum the acquisitions of a mixture over an axis of length n), for the lengths an acquisition list has."""
    for n in range(1, 40):
        x = rng.standard_normal((7, 3, n)) * 10.0 ** rng.uniform(-8, 8, (7, 3, n))
        rows = np.sum(x, axis=-1)
        for i in range(7):
            for j in range(3):
                assert rows[i, j] == np.sum(np.array(x[i, j])), (n, i, j)


class ModelReadingGain(GainError):
    """A plug-in's term that declares block support for an ``effect`` that reads the model (its channel)."""

    type_name = "model_reading_gain"
    effects_take_blocks = True

    def effect(self, case, model):
        assert model.channel == "hv"
        return super().effect(case, model)


class WronglyDeclaredGain(ModelReadingGain):
    """The same, declaring that it does not read the model."""

    type_name = "wrongly_declared_gain"
    effects_take_blocks = True
    effects_ignore_model = True

    def effect(self, case, model):
        return super().effect(case, model)


def test_only_terms_that_declare_it_get_no_model_and_reading_it_hands_the_block_back(base):
    shipped, reading, wrong = (cls.from_config({"sd_db": 0.1}, Location("t"))
                               for cls in (GainError, ModelReadingGain, WronglyDeclaredGain))
    assert shipped.case_models(base) == [UNREAD_MODEL] * CASES
    assert reading.case_models(base)[0] is not UNREAD_MODEL  # it overrides effect: a subclass reads the model again
    assert reading.case_models(base)[0].channel == "hv"
    with pytest.raises(NotBatched, match="effects_ignore_model"):
        wrong.case_effects(None, wrong.case_models(base)[0])
