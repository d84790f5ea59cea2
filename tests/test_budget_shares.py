"""Budgets that add up (issue 23, item 1): each source's share of a requirement's checked value, by the Euler
principle on the moments of the sigma error (docs/theory/error-budget.md), sums to the value; what no source accounts
for is where the error model couples its sources, and nothing where they add."""

from __future__ import annotations

import numpy as np
import pytest

from e2esim.distortion.error_model import HVErrorModel
from e2esim.faraday.distribution import ConstantFaraday, GaussianFaraday
from e2esim.requirements.shares import bound_shares, quantile_parts, rms_parts, shares
from e2esim.retrieval.agb_error import AGBContribution, AGBError
from e2esim.retrieval.gauss_hermite import standard_normal_quantile
from helpers import forest, system
from quick_runs import scenario_names

COUPLERS = ("faraday_rotation", "system_instability", "temporal_decorrelation")
"""Sources of the built-in error models that act through the others (``e2esim.requirements.source_names.COUPLINGS``):
where none is active, the sources add and the remainder must be small."""


def _agb(faraday, random_variances=(0.01, 0.004)):
    model = HVErrorModel(forest("boreal_200"), system(), faraday)
    m = model.current()
    agb = AGBError.from_sigma_errors(2.2, model.value, float(m.mean), float(m.sd), error_model=model)
    terms = tuple(AGBContribution(f"term{k}", "random", 0.0, v) for k, v in enumerate(random_variances))
    return agb.with_terms(terms) if terms else agb


def _rest(details, unit="percent"):
    return details[f"share.interactions_{unit}"]


def test_independent_zero_mean_terms_share_the_value_as_their_variances_do():
    agb = _agb(ConstantFaraday(0.0))
    sigma2 = agb.sigma_hv**2
    b, s = agb.error_mean, agb.error_sd
    rmse = 100 * agb.rmse()
    out = shares(rmse, *rms_parts(agb), "percent")
    for k, v in enumerate((0.01, 0.004)):  # Euler on the mean square: v_i / (b^2 + v), the bias shared by the rest
        assert out[f"share.term{k}_percent"] == pytest.approx(rmse * sigma2 * v / (b * b + s * s), rel=1e-9)
    assert sum(out.values()) == pytest.approx(rmse, rel=1e-12)
    z = float(standard_normal_quantile(0.99865))
    q = 100 * float(agb.quantile(0.99865))
    total, parts = quantile_parts(agb, 0.99865, "over")
    assert total == pytest.approx(b + z * s, rel=1e-12)
    out = shares(q, total, parts, "percent")
    for k, v in enumerate((0.01, 0.004)):  # Euler on the Gaussian quantile: z v_i / s of b + z s
        assert out[f"share.term{k}_percent"] == pytest.approx(q * z * sigma2 * v / s / (b + z * s), rel=1e-9)
    assert sum(out.values()) == pytest.approx(q, rel=1e-12)
    # without Faraday rotation the system errors add too: the rest is far below 1 % of the value
    assert abs(_rest(out)) < 1e-3 * q


def test_faraday_rotation_couples_with_the_system_errors_and_the_rest_says_so():
    """Faraday rotation acts on sigma_hv only through crosstalk and imbalance (Men et al. 2021, eqs. 11-12): its
    share and theirs leave a remainder that vanishes without the rotation."""
    rotated = _agb(GaussianFaraday(np.pi / 3, np.radians(5.0)), ())
    plain = _agb(ConstantFaraday(0.0), ())
    for agb in (rotated, plain):
        q_over, q_under = 100 * float(agb.quantile(0.99865)), -100 * float(agb.quantile(1 - 0.99865))
        value = max(q_over, q_under)
        out = bound_shares(value, agb, 0.99865, ("over", "under"), {"over": q_over, "under": q_under}, "percent")
        assert sum(out.values()) == pytest.approx(value, rel=1e-12)
        if agb is rotated:
            assert abs(_rest(out)) > 0.01 * value and out["share.faraday_rotation_percent"] != 0.0
        else:
            assert abs(_rest(out)) < 0.01 * value and out["share.faraday_rotation_percent"] == 0.0


def test_a_block_of_cases_gets_the_shares_of_each_case_alone():
    faradays = (ConstantFaraday(0.0), GaussianFaraday(0.2, 0.05))
    ones = [_agb(f) for f in faradays]
    for one in ones:
        value = 100 * one.rmse()
        alone = shares(value, *rms_parts(one), "percent")
        assert sum(alone.values()) == pytest.approx(value, rel=1e-12)
    # the side that sets an agb_error_bound value decides whose parts are shared, case by case
    values = {"over": np.array([5.0, 1.0]), "under": np.array([1.0, 4.0])}
    block = bound_shares(np.array([5.0, 4.0]), ones[0], 0.99865, ("over", "under"), values, "percent")
    over = bound_shares(5.0, ones[0], 0.99865, ("over",), {"over": 5.0}, "percent")
    under = bound_shares(4.0, ones[0], 0.99865, ("under",), {"under": 4.0}, "percent")
    for key in over:
        assert block[key][0] == pytest.approx(over[key], rel=1e-12, abs=1e-15)
        assert block[key][1] == pytest.approx(under[key], rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("scenario", scenario_names())
def test_every_shipped_budget_sums_to_its_value(scenario, quick_run):
    """The Done-when of issue 23: every verdict's shares (Euler and Shapley) sum to its checked value, and where no
    coupling source is active the part the Euler split does not attribute is below 1 % of it."""
    result, _ = quick_run(scenario)
    checked = 0
    for case in result.cases:
        for v in case.verdicts:
            unit = "t_ha" if v.unit == "t/ha" else "percent"
            removal = [k for k in v.details if k.startswith("contribution.") and k.endswith("_" + unit)]
            parts = {k: x for k, x in v.details.items() if k.startswith("share.") and k.endswith("_" + unit)}
            if not removal:
                assert not parts
                continue
            assert set(parts) == {"share." + k[len("contribution."):] for k in removal} | {f"share.interactions_{unit}"}
            assert sum(parts.values()) == pytest.approx(v.value, rel=1e-12, abs=1e-12)
            # the Shapley split (e2esim.requirements.shapley): every source, no remainder, summing to the value
            exact = {k: x for k, x in v.details.items() if k.startswith("shapley.") and k.endswith("_" + unit)}
            names = {"shapley." + k[len("contribution."):] for k in removal}
            assert set(exact) == names | {f"shapley.no_source_{unit}"}
            assert sum(exact.values()) == pytest.approx(v.value, rel=1e-9, abs=1e-9), (case.label, v.name)
            if not any(v.details[f"contribution.{s}_{unit}"] != 0.0 for s in COUPLERS if f"contribution.{s}_{unit}"
                       in v.details):
                assert abs(_rest(v.details, unit)) < 0.01 * abs(v.value), (case.label, v.name)
            checked += 1
    if result.requirement_names:
        assert checked > 0


def test_the_report_explains_a_remainder_by_what_couples(quick_run):
    _, folder = quick_run("biomass_calibration")  # cases without Faraday-rotation correction: FR couples
    report = (folder / "report.md").read_text()
    assert "not attributed" in report and "Faraday rotation acts on the backscatter only through crosstalk" in report
    # there the line takes the Shapley split (no remainder) and says why; where the sources add, the Euler split
    assert "Shapley (sources couple: Euler leaves" in report and "| Euler |" in report
    _, folder = quick_run("biomass_default")
    budget = (folder / "report.md").read_text().split("## Error budget")[1]
    assert "Faraday rotation (residual after correction)" in budget
