"""The AGB error answers the requirements' questions itself (issue 27, Build 3): its error at changed levels of the
error model, without a source, its systematic part, and with added terms, all from the one split it holds
(the error model's systematic error and the variance the other sources add)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from e2esim.case import KernelMemo
from e2esim.distortion.error_model import HVErrorModel
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.requirements.tradeoff import (
    AGBBound,
    AGBRequirement,
    ModelBound,
    bound_tradeoff_curve,
    bound_tradeoff_curves,
    first_failing_level,
    first_failing_levels,
)
from e2esim.retrieval.agb_error import AGBContribution, AGBError
from e2esim.retrieval.loglinear import LogLinearModel
from e2esim.retrieval.power_law import PowerLaw
from e2esim.retrieval.relative_error_map import RelativeErrorMap
from helpers import forest, system

CONFIDENCE = 0.99865  # z = 3 (Men et al. 2021, Table III)


def _agb(speckle_variance=0.0):
    """The systematic AGB error of the boreal forest of Men et al. (2021) through p = 2.2, with a random term of
    relative variance ``speckle_variance`` added."""
    model = HVErrorModel(forest("boreal_200"), system(), GaussianFaraday(np.pi / 3, np.radians(5.0)))
    m = model.current()
    agb = AGBError.from_sigma_errors(2.2, model.value, float(m.mean), float(m.sd), error_model=model)
    if speckle_variance:
        agb = agb.with_terms((AGBContribution("speckle_noise", "random", 0.0, speckle_variance),))
    return model, agb


def test_added_terms_are_held_apart_from_the_error_model_and_taken_away_again():
    model, systematic = _agb()
    _, agb = _agb(0.01)
    assert systematic.added_variance == 0.0
    # sd^2 = model variance + sigma^2 * 0.01 (independent sources), up to the rounding of the square root
    assert agb.added_variance == pytest.approx(model.value**2 * 0.01, rel=1e-12)
    assert agb.sources() == (*model.sources, "speckle_noise")
    without, inactive = agb.without("speckle_noise")
    assert inactive is None and without.error_sd == pytest.approx(systematic.error_sd, rel=1e-12)
    # the systematic part alone is exactly the error model's own
    alone = agb.systematic()
    assert (alone.error_mean, alone.error_sd, alone.contributions) == (systematic.error_mean, systematic.error_sd, ())
    # a source of the error model: its moments without it, the added variance kept
    without_x, _ = agb.without("crosstalk")
    m = model.without("crosstalk").current()
    assert without_x.error_mean == float(m.mean)
    assert without_x.error_sd == pytest.approx(np.sqrt(float(m.sd) ** 2 + model.value**2 * 0.01), rel=1e-12)
    assert without_x.rmse() < agb.rmse()


@pytest.mark.parametrize("side", ["over", "under"])
def test_at_the_level_limit_the_agb_quantile_is_the_bound(side):
    """The crosstalk limit solved on the AGB error's violation (eq. 19, sigma space) is where the Gaussian quantile
    of the relative AGB error at the changed level, with the added random term, reaches the bound."""
    _, agb = _agb(0.0004)
    bound = AGBBound(agb, 0.2, CONFIDENCE, side)
    limit = float(first_failing_level(lambda v: bound.violation_at(crosstalk=v)))
    assert 1e-6 < limit < 1.0
    mean, sd = agb.moments_under(crosstalk=limit)
    at_limit = AGBError.from_sigma_errors(2.2, agb.sigma_hv, float(mean), float(sd))
    probability = CONFIDENCE if side == "over" else 1 - CONFIDENCE
    assert at_limit.quantile(probability) == pytest.approx(0.2 if side == "over" else -0.2, abs=1e-7)


def test_without_added_terms_the_agb_error_solves_as_the_error_model_alone():
    """With nothing added, the AGB error's violation is the stand-alone requirement's on the error model, bit for
    bit (the margins of a plain chain are unchanged)."""
    model, agb = _agb()
    levels = np.logspace(-8, -1, 15)
    for side in ("over", "under"):
        ours = AGBBound(agb, 0.2, CONFIDENCE, side).violation_at(crosstalk=levels)
        alone = ModelBound(AGBRequirement(0.2, CONFIDENCE, side, 2.2), model).violation_at(crosstalk=levels)
        assert np.array_equal(ours, alone)


def test_the_sides_of_a_bound_share_the_scan_and_find_their_own_limits_bit_for_bit(monkeypatch):
    """``first_failing_levels``: the sides of a requirement ask the scan's 25 levels in one evaluation of the moments
    (a curve's sides also refine together), and each side's limit is the one its own search finds, bit for bit."""
    _, agb = _agb(0.0004)
    bounds = [AGBBound(agb, 0.2, CONFIDENCE, side) for side in ("over", "under")]
    calls = []
    asked = AGBError.moments_under
    monkeypatch.setattr(AGBError, "moments_under", lambda self, **levels: calls.append(1) or asked(self, **levels))
    alone = [first_failing_level(lambda v, b=b: b.violation_at(crosstalk=v)) for b in bounds]
    searched_alone, calls[:] = len(calls), []
    together = first_failing_levels(bounds, lambda v: {"crosstalk": v})
    assert np.isfinite(alone[0]) and np.array_equal(alone, together, equal_nan=True)
    assert len(calls) == searched_alone - 1  # the scan once for both sides
    x = np.logspace(-6, -2, 7)
    calls[:] = []
    alone = [bound_tradeoff_curve(b, x) for b in bounds]
    searched_alone, calls[:] = len(calls), []
    curves = bound_tradeoff_curves(bounds, x)
    assert np.any(np.isfinite(alone[0])) and np.array_equal(alone, curves, equal_nan=True)
    assert len(calls) < 0.6 * searched_alone  # one scan, and the sides' steps asked together


def _counted_bisections(monkeypatch) -> list:
    """The levels ``RelativeErrorMap``'s bisection is run at, from now on."""
    levels = []
    bisect = RelativeErrorMap._threshold_numeric
    monkeypatch.setattr(RelativeErrorMap, "_threshold_numeric",
                        lambda m, level: levels.append(level) or bisect(m, level))
    return levels


def _same_bits(a, b) -> bool:
    return np.float64(a).tobytes() == np.float64(b).tobytes()


def test_the_kernel_memo_keeps_a_maps_threshold_by_the_maps_values_and_the_level(monkeypatch):
    """Issue 27, Build 7: ``RelativeErrorMap.threshold`` handed the run's kernel memo bisects once per map value and
    level (equal maps made apart share it; an array of the model is keyed by its bytes), the bits of a fresh
    bisection; without a memo it bisects anew (nothing is kept in the frozen map)."""
    power_law = RelativeErrorMap(PowerLaw(0.1, 0.5), 150.0)
    fresh = {level: power_law._threshold_numeric(level) for level in (0.2, -0.2)}
    bisected = _counted_bisections(monkeypatch)
    memo = KernelMemo()
    first = power_law.threshold(0.2, memo)
    again = RelativeErrorMap(PowerLaw(0.1, 0.5), 150.0).threshold(0.2, memo)
    assert bisected == [0.2] and _same_bits(first, fresh[0.2]) and _same_bits(again, fresh[0.2])
    assert _same_bits(power_law.threshold(-0.2, memo), fresh[-0.2]) and bisected == [0.2, -0.2]
    RelativeErrorMap(PowerLaw(0.1, 0.5), 151.0).threshold(0.2, memo)
    assert len(bisected) == 3  # another AGB: another map
    assert _same_bits(power_law.threshold(0.2), fresh[0.2]) and len(bisected) == 4  # no memo: bisected anew
    log_linear = [LogLinearModel((-4.7, -4.9, -1.6), (0.8039, 0.4224, 0.0612), (0.0, 0.0, 0.0), c * np.eye(3))
                  for c in (1.0, 1.0, 2.0)]
    for model in log_linear:
        RelativeErrorMap(model, 100.0, None, (("incidence_rad", 0.5),)).threshold(0.2, memo)
    assert len(bisected) == 6  # the residual covariance, an array, is keyed by its bytes: equal ones share


def test_a_bound_derives_its_threshold_once_for_its_margins_curves_and_exceedance(monkeypatch):
    """Issue 27, Build 7: a requirement's ``AGBBound`` derives the relative sigma error at its side's level once
    (``relative_threshold``) for every level its margins and trade-off curves ask and for the verdict's exceedance
    probability; the violations and probabilities are those of a threshold derived in place, bit for bit."""
    _, agb = _agb(0.0004)
    agb = replace(agb, mapping=RelativeErrorMap(PowerLaw(0.1, 1 / 2.2), 150.0))
    bisected = _counted_bisections(monkeypatch)
    bounds = [AGBBound(agb, 0.2, CONFIDENCE, side, KernelMemo()) for side in ("over", "under")]
    limits = first_failing_levels(bounds, lambda v: {"crosstalk": v})
    curves = bound_tradeoff_curves(bounds, np.logspace(-6, -2, 7))
    exceedance = [agb.exceedance(0.2, b.side, relative_threshold=b.relative_threshold) for b in bounds]
    assert sorted(bisected) == [-0.2, 0.2]  # one per side, not one per level asked
    assert np.all(np.isfinite(limits)) and np.any(np.isfinite(curves[0]))
    levels = np.logspace(-8, -1, 15)
    for b, p in zip(bounds, exceedance):
        moments = agb.moments_under(crosstalk=levels)
        assert np.array_equal(b.violation_of(moments), agb.bound_violation_of(moments, 0.2, CONFIDENCE, b.side))
        assert _same_bits(p, agb.exceedance(0.2, b.side))
