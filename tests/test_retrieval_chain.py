"""Chain integration: the ``backscatter_error_budget`` propagation module after ``hv_backscatter_error``,
the retrieval modules that combine systematic, random and regression errors into the reported AGB error
with named contributions, and the two scenarios of issue 6."""

from pathlib import Path

import numpy as np
import pytest

from e2esim.budget.presets import PRESETS
from e2esim.errors import ConfigError
from e2esim.retrieval.agb_error import AGBContribution
from e2esim.retrieval.combine import draw_random_errors
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario

ROOT = Path(__file__).resolve().parents[1]

BASE = {
    "scene": {"type": "table1_forest", "forest": "boreal_200"},
    "instrument": {"type": "biomass"},
    "ionosphere": {"type": "gaussian_faraday", "mean_deg": 60.0, "sd_deg": 5.0},
    "propagation": [{"type": "hv_backscatter_error"},
                    {"type": "backscatter_error_budget", "temporal": {"sd_percent": 5.0}}],
    "retrieval": {"type": "power_law"},
    "simulation": {"mode": "both", "seed": 3, "looks": 100_000, "realisations": 4000},
}


def _run(data, **changes):
    data = {**data, **changes}
    resolved = Scenario(data, source="<test>").resolve()
    return run_scenario(resolved, progress=False).cases


def test_budget_module_attaches_a_per_channel_budget():
    case = _run(BASE)[0]
    budget = case.get("backscatter.budget")
    assert budget.channels == ("hh", "hv", "vv")
    assert float(budget.channel("hv").sigma) == pytest.approx(0.0726)
    # 4 ha at c / 2B (B = 6 MHz, unweighted) x 8.3 m in ground range: Ahmed et al. 2014, eq. (22)
    looks = 40_000 * np.sin(PRESETS["biomass_200m"]["incidence_rad"]) / (299_792_458.0 / (2 * 6e6) * 8.3)
    assert case.scalars["budget.looks"] == pytest.approx(looks, rel=1e-9)
    assert case.scalars["budget.speckle.relative_sd_percent"] == pytest.approx(100 / np.sqrt(looks), rel=1e-9)
    assert case.scalars["budget.temporal.relative_sd_percent"] == pytest.approx(5.0)


def test_contributions_add_up_to_the_reported_error():
    case = _run(BASE)[0]
    agb, model = case.get("agb.error"), case.get("backscatter.error")
    names = [c.name for c in agb.contributions]
    assert names == ["system_distortions", "faraday_rotation", "noise_bias", "speckle_noise", "temporal",
                     "calibration", "area_projection"]
    s = model.value
    moments = model.current()
    systematic = [c for c in agb.contributions if c.group == "systematic"]
    # the three systematic parts add up to the propagation module's analytic moments exactly
    assert sum(c.relative_mean for c in systematic) * s == pytest.approx(float(moments.mean), rel=1e-10)
    assert sum(c.relative_variance for c in systematic) * s**2 == pytest.approx(float(moments.variance), rel=1e-10)
    # the total is systematic + budget (independent sources)
    budget_var = float(case.get("backscatter.budget").channel("hv").total_variance)
    assert agb.error_sd**2 == pytest.approx(float(moments.variance) + s**2 * budget_var, rel=1e-10)
    assert agb.error_mean == pytest.approx(float(moments.mean))
    shares = [case.scalars[f"agb.contribution.{n}.variance_share"] for n in names]
    assert sum(shares) == pytest.approx(1.0)
    assert agb.dominant_contribution() == "speckle_noise"  # about 92 looks at 4 ha


def test_monte_carlo_agrees_with_analytic_with_the_budget():
    """The Monte Carlo AGB error (systematic samples plus random draws from the case generator) has the
    mean of the analytic model: z test on the sample mean of q against the analytic E[q] (the gamma law of
    the speckle term and the Gaussian model differ in skewness, not in the first two moments of x)."""
    case = _run(BASE, simulation={**BASE["simulation"], "realisations": 20_000})[0]
    agb = case.get("agb.error")
    q = agb.samples
    x_analytic_sd = agb.error_sd / agb.sigma_hv
    # compare relative sigma errors: invert q = (1 + x)^p - 1
    x = (1 + q) ** (1 / agb.exponent) - 1
    z_mean = (x.mean() - agb.error_mean / agb.sigma_hv) / (x.std(ddof=1) / np.sqrt(x.size))
    assert abs(z_mean) < 5
    z_var = (x.var(ddof=1) - x_analytic_sd**2) / (x_analytic_sd**2 * np.sqrt(2 / (x.size - 1) + 0.2 / x.size))
    assert abs(z_var) < 5


def test_without_budget_results_are_unchanged():
    plain = dict(BASE, propagation={"type": "hv_backscatter_error"})
    a = _run(plain)[0]
    agb, model = a.get("agb.error"), a.get("backscatter.error")
    assert agb.contributions == ()
    assert not any(k.startswith(("agb.contribution", "budget.")) for k in a.scalars)
    # without a budget the AGB error is the power law of eq. (16) applied to the propagation's error alone,
    # checked here against the formula written out: q = (1 + e / sigma_hv)^p - 1, p = 2.2 (boreal); written
    # this way it loses digits for small x (absolute rounding error ~ p * 2^-52), hence atol
    x = model.relative_samples()  # errors relative to each simulated scene's own sigma_hv (eq. 17)
    np.testing.assert_allclose(agb.samples, np.ravel((1 + x) ** 2.2 - 1), rtol=1e-12, atol=2e-15)
    from scipy import integrate, stats

    m = model.current()
    mu, sd = float(m.mean) / model.value, float(m.sd) / model.value
    mean_square, _ = integrate.quad(lambda t: ((1 + t) ** 2.2 - 1) ** 2 * stats.norm.pdf(t, mu, sd),
                                    mu - 12 * sd, mu + 12 * sd, epsabs=0, epsrel=1e-12)
    assert agb.rmse() == pytest.approx(np.sqrt(mean_square), rel=1e-10)


def test_budget_reproducible_per_case():
    a, b = _run(BASE)[0], _run(BASE)[0]
    np.testing.assert_array_equal(a.get("agb.error").samples, b.get("agb.error").samples)


def test_regression_contribution_and_saturating_model():
    data = dict(BASE, retrieval={"type": "saturating", "agb_max_t_ha": 600.0,
                                 "regression": {"mode": "prediction", "plots": 40}})
    case = _run(data)[0]
    agb = case.get("agb.error")
    reg = agb.contribution("regression")
    assert reg.group == "regression" and reg.relative_variance > 0
    assert 0 <= case.scalars["agb.analytic.saturated_fraction"] <= 1
    assert case.scalars["agb.montecarlo.saturated_fraction"] > 0  # 200 t/ha is on the flat part
    assert np.nanmax(agb.samples) == pytest.approx(600 / 200 - 1)  # saturated estimates sit at the cap


def test_log_linear_retrieval_runs_and_uses_the_hv_weight():
    data = dict(BASE, retrieval={"type": "log_linear"})
    case = _run(data)[0]
    agb = case.get("agb.error")
    assert 0 < agb.exponent < 1  # c_hv of the Table I boreal fit: HH carries most of the weight
    assert {c.name for c in agb.contributions} >= {"speckle_noise", "calibration"}
    assert np.all(np.isfinite(agb.samples))


def test_a_retrieval_maps_threshold_is_bisected_once_per_map_and_level(monkeypatch):
    """Issue 27, Build 7: a requirement asks the relative sigma error at its bound of a retrieval model's map
    (``RelativeErrorMap.threshold``, a bisection) once per side: the verdict's exceedance, its standard error and
    the level margins share the bound's ``AGBBound.relative_threshold``, and the run's kernel memo keeps it for the
    cases whose maps have the same values (here two cases at one AGB). The numbers are a fresh bisection's."""
    from e2esim import case as case_module
    from e2esim.retrieval.relative_error_map import RelativeErrorMap

    monkeypatch.setattr(case_module, "_PROCESS_MEMO", [])  # a fresh process memo: nothing kept from other tests
    levels = []
    bisect = RelativeErrorMap._threshold_numeric
    monkeypatch.setattr(RelativeErrorMap, "_threshold_numeric",
                        lambda m, level: levels.append(level) or bisect(m, level))
    data = dict(BASE, retrieval={"type": "log_linear"},
                simulation={**BASE["simulation"], "mode": "analytic"},
                requirements=[{"type": "agb_error_bound", "side": "both", "bound_percent": 20,
                               "sources": "systematic", "level_margins": True}],
                sweep={"mode": "grid", "parameters": {"ionosphere.mean_deg": [60.0, 62.0]}})
    cases = _run(data)
    assert sorted(levels) == [-0.2, 0.2]  # not one per case, side and question
    for case in cases:
        agb, details = case.get("agb.error").systematic(), case.verdicts[0].details
        assert np.isfinite(details["nesz.margin_db"])  # the level margins asked the bounds too
        for side in ("over", "under"):
            assert details[f"{side}.analytic.exceedance_probability"] == agb.exceedance(0.2, side)  # bit for bit
    assert len(levels) == 2 + 4  # the checks above bisected anew, without a memo


def test_population_reference_with_speckle_is_refused():
    data = dict(BASE, propagation=[{"type": "hv_backscatter_error", "reference": "population"},
                                   {"type": "backscatter_error_budget"}])
    with pytest.raises(ConfigError, match="speckle would be counted twice"):
        _run(data)


def test_budget_module_bad_input_names_the_key():
    data = dict(BASE, propagation=[{"type": "hv_backscatter_error"},
                                   {"type": "backscatter_error_budget", "observation": {"area_m2": 1e4,
                                                                                        "product_resolution_m": 100}}])
    with pytest.raises(ConfigError, match=r"propagation\[1\]\.observation\.product_resolution_m: area_m2, "
                       "product_resolution_m are all given; give at most one of area_m2, product_resolution_m"):
        _run(data)
    data = dict(BASE, propagation=[{"type": "hv_backscatter_error"},
                                   {"type": "backscatter_error_budget",
                                    "observation": {"speckle_diverse_observations": 5}}])
    with pytest.raises(ConfigError, match="cannot exceed observations"):
        _run(data)
    data = dict(BASE, retrieval={"type": "saturating", "agb_max_t_ha": 100.0})
    with pytest.raises(ConfigError, match="is not below the cap"):
        _run(data)


def test_draw_random_errors_moments(rng):
    """Independent Gaussian and gamma draws: mean 0 and the summed variance (z tests)."""
    from e2esim.budget.presets import preset
    from e2esim.budget.result import backscatter_budget

    budget = backscatter_budget(preset("biomass_200m", temporal_relative_sd=0.05), np.array([0.5, 0.07, 0.3]))
    budget = budget.with_(channels=("hh", "hv", "vv"))
    hv = budget.channel("hv")
    contribs = tuple(AGBContribution(g, "random", 0.0, float(hv.group_sd(g) ** 2)) for g in budget.groups)
    x = draw_random_errors(rng, (200_000,), budget, contribs, regression_variance=1e-4)
    v = sum(c.relative_variance for c in contribs) + 1e-4
    assert abs(x.mean()) < 5 * np.sqrt(v / x.size)
    assert abs(x.var() - v) < 5 * v * np.sqrt(2.5 / x.size)


@pytest.mark.parametrize("name", ["biomass_error_budget", "uavsar_ahmed2014"])
def test_issue6_scenarios_run(name, quick_run):
    cases = quick_run(name)[0].cases
    assert len(cases) == 5
    for c in cases:
        agb = c.get("agb.error")
        names = [k.name for k in agb.contributions]
        assert names == ["system_distortions", "faraday_rotation", "noise_bias", "speckle_noise", "temporal",
                         "calibration", "area_projection", "regression"]
        # independent sources: the relative variance of the total is the sum of the parts (budget terms
        # combined independently in these scenarios), and the speckle part is at least 1 / looks
        total = (agb.error_sd / agb.sigma_hv) ** 2
        assert sum(k.relative_variance for k in agb.contributions) == pytest.approx(total, rel=1e-9)
        speckle = agb.contribution("speckle_noise").relative_variance
        assert 1 / c.scalars["budget.looks"] <= speckle < 2 / c.scalars["budget.looks"]
        assert agb.contribution("regression").relative_variance > 0
