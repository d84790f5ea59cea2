"""The AGB error answers the requirements' questions itself (issue 27, Build 3): its error at changed levels of the
error model, without a source, its systematic part, and with added terms, all from the one split it holds
(the error model's systematic error and the variance the other sources add)."""

from __future__ import annotations

import numpy as np
import pytest

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
