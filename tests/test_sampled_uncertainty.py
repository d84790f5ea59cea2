"""Every sampled number carries its uncertainty (issue 21, item 4): the standard errors of Monte Carlo means,
RMSEs, proportions and quantiles cover what they claim for any seed; verdicts say when their margin is inside
that uncertainty and when the analytic model and the Monte Carlo disagree beyond it."""

import numpy as np
import pytest
from scipy import stats
from test_retrieval_chain import BASE  # the chain of the retrieval tests: boreal 200 t/ha, 4 ha budget

from e2esim.retrieval.agb_error import AGBError
from e2esim.retrieval.sampling_error import (
    mean_standard_error,
    proportion_standard_error,
    quantile_interval,
    rmse_standard_error,
)
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario

REPLICATIONS = 400
COVERAGE_TOLERANCE = 4.5 * np.sqrt(0.95 * 0.05 / REPLICATIONS)  # binomial: a failure once in ~10^5 seeds


def _coverage_ok(covered) -> bool:
    return abs(np.mean(covered) - 0.95) < COVERAGE_TOLERANCE


def _z_sd_ok(z) -> bool:
    """The SD of z-scores is 1 within 4.5 of its standard errors (sqrt(1 / 2R) for Gaussian z)."""
    return abs(np.std(z) - 1.0) < 4.5 / np.sqrt(2 * len(z)) + 0.03  # + 3 %: the delta method's O(1/n)


def test_standard_errors_of_independent_samples_cover(rng):
    """Skewed independent samples (a gamma law, as the Monte Carlo's speckle): the 95 % intervals of the mean,
    RMSE, exceedance probability and the 0.135 %, 50 % and 99.865 % quantiles (order-statistic interval) cover the
    true values 95 % of the time."""
    k, n = 4.0, 4000
    law = stats.gamma(k, scale=1 / k, loc=-1.0)
    p = np.array([0.00135, 0.5, 0.99865])
    true_q, true_mean = law.ppf(p), law.mean()
    true_rms, true_exceed = np.sqrt(law.var() + law.mean() ** 2), law.sf(0.5)
    covered = {name: [] for name in ("mean", "rmse", "exceed", "q00135", "q50", "q99865")}
    for _ in range(REPLICATIONS):
        x = rng.gamma(k, 1 / k, n) - 1.0
        covered["mean"].append(abs(x.mean() - true_mean) <= 1.96 * mean_standard_error(x))
        rms = np.sqrt(np.mean(x**2))
        covered["rmse"].append(abs(rms - true_rms) <= 1.96 * rmse_standard_error(x))
        covered["exceed"].append(abs(np.mean(x > 0.5) - true_exceed) <= 1.96 * proportion_standard_error(x > 0.5))
        lo, hi, _ = quantile_interval(x, p)
        for name, c in zip(("q00135", "q50", "q99865"), (lo <= true_q) & (true_q <= hi)):
            covered[name].append(c)
    for name, c in covered.items():
        assert _coverage_ok(c), f"{name}: coverage {np.mean(c):.3f}"


def test_standard_errors_of_clustered_samples_cover(rng):
    """(M, N) samples whose N noise realisations share a system draw: the cluster-robust standard errors cover,
    where treating the M N samples as independent would not (the design effect here is 1 + 3 x 0.5 = 2.5)."""
    m, n = 1000, 4
    shared_sd = np.sqrt(0.5)
    law = stats.norm(0.0, np.sqrt(1.0 + shared_sd**2))
    p = np.array([0.02275, 0.5, 0.97725])
    true_q = law.ppf(p)
    covered, naive, z_rms = [], [], []
    for _ in range(REPLICATIONS):
        x = (shared_sd * rng.standard_normal((m, 1)) + rng.standard_normal((m, n))).ravel()
        covered.append(abs(x.mean()) <= 1.96 * mean_standard_error(x, m))
        naive.append(abs(x.mean()) <= 1.96 * mean_standard_error(x))
        lo, hi, _ = quantile_interval(x, p, m)
        covered.extend((lo <= true_q) & (true_q <= hi))
        z_rms.append((np.sqrt(np.mean(x**2)) - law.std()) / rmse_standard_error(x, m))
    assert _coverage_ok(covered[:: 4]) and _coverage_ok(covered)
    assert np.mean(naive) < 0.95 - COVERAGE_TOLERANCE  # independent-sample errors are too small here
    assert _z_sd_ok(z_rms)


def test_agb_error_monte_carlo_standard_errors_against_the_exact_answer(rng):
    """Monte Carlo samples of a Gaussian relative sigma error through the power law: the analytic answers are then
    exact, and (Monte Carlo - analytic) / standard error has mean 0 and SD 1 for the RMSE, the mean, the 97.725 %
    quantile and an exceedance probability. (A quantile further in the tail has a few samples beyond it and an
    asymmetric interval: its coverage is tested above, on the interval.)"""
    z = {name: [] for name in ("rmse", "mean", "q97725", "exceedance")}
    for _ in range(REPLICATIONS // 2):
        x = 0.02 + 0.1 * rng.standard_normal((2000, 2))
        agb = AGBError.from_sigma_errors(2.2, 1.0, 0.02, 0.1, x)
        assert agb.realisations == 2000
        for name, args in (("rmse", ()), ("mean", ()), ("q97725", (0.97725,)), ("exceedance", (0.2, "over"))):
            statistic = "quantile" if name.startswith("q") else name
            mc = getattr(agb, statistic)(*args, basis="montecarlo")
            exact = getattr(agb, statistic)(*args, basis="analytic")
            z[name].append((mc - exact) / agb.standard_error(statistic, "montecarlo", *args))
            assert agb.standard_error(statistic, "analytic", *args) == 0.0  # exact: nothing sampled
    for name, values in z.items():
        assert abs(np.mean(values)) < 4.5 / np.sqrt(len(values)) + 0.05, name
        assert _z_sd_ok(values), name


def _chain(seed, realisations=20_000, speckle="gamma", requirements=None, area_m2=10_000.0):
    """BASE at a smaller product than 4 ha (more speckle: its gamma tail shows), both simulation modes."""
    data = dict(BASE, propagation=[
        {"type": "hv_backscatter_error"},
        {"type": "backscatter_error_budget", "temporal": {"sd_percent": 5.0}, "observation": {"area_m2": area_m2},
         "speckle_distribution": speckle}],
        requirements=requirements or [{"type": "agb_error_bound", "confidence_percent": 99.865, "bound_percent": 20},
                                      {"type": "agb_rmse"}],
        simulation={"mode": "both", "seed": int(seed), "looks": 2000, "realisations": realisations})
    return run_scenario(Scenario(data, source="<test>").resolve(), progress=False)


def test_analytic_and_monte_carlo_disagreement_is_flagged_on_the_first_screen(seed):
    """biomass_default's all-sources 99.865 % AGB error read 115 % analytic and 136 % Monte Carlo with nothing said.
    Part of it is real: the Monte Carlo draws the speckle and noise from a gamma law (a heavier upper tail than
    the analytic Gaussian); part was the Monte Carlo's sampling error. With a 0.25 ha product the gamma tail is
    far beyond the sampling error (above five standard errors): the verdicts flag it (code 1: the moments agree,
    the shape differs), say which value they used, and the command line and the top of the report say so."""
    from e2esim.report.document import build_report, verdict_lines

    result = _chain(seed, area_m2=2500.0)
    for v in result.cases[0].verdicts:
        assert v.details["basis_disagreement"] == 1.0, v.name
        assert v.basis == "analytic" and v.details["value_standard_error"] == 0.0
        assert v.details["montecarlo.value"] > v.details["analytic.value"]  # the gamma tail is heavier
        assert any("disagree by more than 3 standard errors; the verdict uses the analytic value" in n
                   for n in v.notes)
    lines = verdict_lines(result)
    assert sum("! analytic and Monte Carlo values disagree" in line for line in lines) == 2
    top = build_report(result, [])[:8]
    assert sum("**How sure:**" in getattr(b, "text", "") and "the verdicts use the analytic value" in b.text
               for b in top) == 2


def test_agreeing_analytic_and_monte_carlo_are_not_flagged(seed):
    """The same chain with Gaussian speckle in the Monte Carlo: the two bases agree; a flag is a 3-sigma event
    (0.3 %), so at most one of four verdicts (two seeds) may carry one by chance."""
    flags = [v.details["basis_disagreement"] for k in range(2) for v in _chain(seed + k, speckle="gaussian")
             .cases[0].verdicts]
    assert len(flags) == 4 and sum(f > 0 for f in flags) <= 1


def test_a_margin_inside_the_uncertainty_is_said(seed):
    """A Monte Carlo verdict whose limit lies half a standard error beyond its value: the margin is inside its
    uncertainty and the verdict says so; five standard errors beyond, it is not."""
    rmse = [{"type": "agb_rmse", "basis": "montecarlo"}]
    first = _chain(seed, 4000, requirements=rmse).cases[0].verdicts[0]
    value, se = first.value, first.details["value_standard_error"]
    assert se > 0 and se == first.details["montecarlo.value_standard_error"]
    close = _chain(seed, 4000, requirements=[{**rmse[0], "max_percent": value + 0.5 * se}]).cases[0].verdicts[0]
    assert close.value == value and close.passed
    assert close.details["margin_within_uncertainty"] == 1.0
    assert any("inside the value's 95 % uncertainty" in n for n in close.notes)
    far = _chain(seed, 4000, requirements=[{**rmse[0], "max_percent": value + 5 * se}]).cases[0].verdicts[0]
    assert far.details["margin_within_uncertainty"] == 0.0 and not any("inside" in n for n in far.notes)


@pytest.mark.parametrize("name", ["uavsar_ahmed2014", "biomass_error_budget"])
def test_sampled_outputs_of_the_shipped_scenarios_carry_standard_errors(name, quick_run):
    for case in quick_run(name)[0].cases:
        s = case.scalars
        for key in ("rmse", "mean"):
            assert s[f"agb.montecarlo.{key}_standard_error_percent"] > 0
            assert s[f"agb.analytic.{key}_standard_error_percent"] > 0  # the regression term is sampled
        # a quantile at the saturated cap is exact (every interval end sits on it)
        assert s["agb.montecarlo.q99865_standard_error_percent"] >= 0
        assert s["agb.contribution.regression.sigma_sd_standard_error_percent"] > 0
        spread = [s[f"agb.contribution.regression.sigma_sd_{q}_percent"] for q in ("p16", "p50", "p84")]
        assert 0 < spread[0] <= spread[1] <= spread[2]
        for v in case.verdicts:
            rmse = "analytic.rmse_percent" in v.details  # a bound's quantile at the saturated cap is exact
            assert v.details["value_standard_error"] > 0 if rmse else v.details["value_standard_error"] >= 0
            assert {"analytic.value", "montecarlo.value", "margin_within_uncertainty", "basis_disagreement"} <= set(
                v.details)
