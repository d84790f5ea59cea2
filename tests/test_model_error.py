"""Model uncertainty of the retrievals (docs/theory/retrieval.md, Section 7): the propagation of uncertain exponents
and coefficients into the log-AGB error (eqs. 7.1-7.2) against a Monte Carlo over the parameters, the model term in
the retrieval chain (analytic and Monte Carlo), and the joint estimate's sensitivity to its exponents."""

import dataclasses
import html
import json

import numpy as np
import pytest
from test_stack_joint import _stack_retrieval_case

from e2esim.retrieval import model_error
from e2esim.retrieval.exponent_sensitivity import joint_rmse
from e2esim.stack.multichannel_retrieval import StackMultiChannelRetrieval, ground_cancelled_alphas
from e2esim.stack.retrieval import StackPowerLawRetrieval
from e2esim.stack.sites import SITES
from helpers import Z_ACCEPT, mean_and_variance_z


def _simulate_retrieval(rng, alpha_r, exponent_sd, level_sd, agb, reference, correlation, n):
    """Brute force: draw nature's exponents alpha_r + eps and the processor's level error delta at W_ref, simulate
    nature's backscatter at ``agb`` with a relative measurement error, calibrate the processor's law at W_ref and
    invert it (ATBD eq. 4.26 / Men et al. eq. 15). Returns (y, the measurement part sum c_p ln(1 + x_p))."""
    alpha_r = np.asarray(alpha_r, dtype=float)
    k = alpha_r.size
    corr = np.full((k, k), correlation)
    np.fill_diagonal(corr, 1.0)
    eps = rng.multivariate_normal(np.zeros(k), corr * np.outer(exponent_sd, exponent_sd), n)
    delta = rng.standard_normal((n, k)) * level_sd
    alpha_t = alpha_r + eps
    ln_l = np.log([0.05, 0.01, 0.1][:k])  # nature's coefficients (their values cancel)
    x = 0.1 * rng.standard_normal((n, k))  # relative measurement errors of sigma
    ln_sigma_hat = ln_l + alpha_t * np.log(agb) + np.log1p(x)
    # the processor's law agrees with nature's at W_ref up to delta: ln L_r + alpha_r ln W_ref = ln sigma(W_ref) + delta
    ln_l_r = ln_l + alpha_t * np.log(reference) + delta - alpha_r * np.log(reference)
    c = alpha_r / (alpha_r @ alpha_r)
    y = (ln_sigma_hat - ln_l_r) @ c - np.log(agb)
    return y, np.log1p(x) @ c


@pytest.mark.parametrize("alpha, sd_rel, level_sd, agb, correlation", [
    ((1 / 1.9,), 0.2, 0.0, 338.0, 1.0),  # one power law (c = p), exponent only
    ((1 / 2.2,), 0.1, 0.05, 50.0, 1.0),  # with a level error
    ((0.58, 0.58, 0.077), 0.15, 0.03, 120.0, 0.5),  # the joint estimate, partly correlated exponents
    ((0.80, 0.45, 0.06), 0.3, 0.0, 500.0, 0.0),
])
def test_model_term_against_a_monte_carlo_over_the_parameters(rng, alpha, sd_rel, level_sd, agb, correlation):
    """eq. (7.1): the model error m = y - sum c_p ln(1 + x_p) has mean 0, the variance of eq. (7.2) (growing with
    ln(W / W_ref)^2 from the calibration centre), and is uncorrelated with the measurement part."""
    alpha = np.asarray(alpha)
    reference = 151.8
    exponent_sd = sd_rel * alpha
    level = np.full(alpha.size, level_sd)
    y, measured = _simulate_retrieval(rng, alpha, exponent_sd, level, agb, reference, correlation, 200_000)
    m = y - measured
    c = alpha / (alpha @ alpha)
    variance = model_error.model_log_variance(c, exponent_sd, level, model_error.log_distance(agb, reference),
                                              correlation)
    z_mean, z_var = mean_and_variance_z(m, 0.0, variance)
    assert abs(z_mean) < Z_ACCEPT and abs(z_var) < Z_ACCEPT
    assert abs(np.corrcoef(m, measured)[0, 1]) < 5 / np.sqrt(m.size)
    # the variance grows as the squared log distance from the calibration centre
    at_centre = model_error.model_log_variance(c, exponent_sd, level, 0.0, correlation)
    assert at_centre == pytest.approx(float(c**2 @ level**2), rel=1e-12)


def test_equal_relative_sds_moving_together_give_the_relative_sd_times_the_distance():
    """sum_p c_p alpha_p = 1: with every exponent off by the same fraction s, m = s D exactly."""
    alpha = np.array([0.58, 0.58, 0.077])
    c = alpha / (alpha @ alpha)
    variance = model_error.model_log_variance(c, 0.0733 * alpha, np.zeros(3), np.log(2.0), 1.0)
    assert np.sqrt(variance) == pytest.approx(0.0733 * np.log(2.0), rel=1e-12)


def test_stated_uncertainties_and_their_sources():
    assert model_error.HV_EXPONENT_RELATIVE_SD == pytest.approx(0.5 * np.log(2.2 / 1.9), rel=1e-15)
    assert model_error.REFERENCE_AGB_T_HA["boreal"] == pytest.approx(151.83, abs=0.01)
    tropical = ground_cancelled_alphas((0.8039, 1 / 1.9, 0.0612), SITES["tropical"].ground_to_volume_db)
    spread = abs(0.8039 - tropical[1])
    sd = model_error.stated_exponent_sd(tropical, cancelled_hh_spread=spread)
    assert sd[0] == pytest.approx(0.8039 - 1.1 / 1.9, rel=1e-12)  # between the volume and same rules
    np.testing.assert_allclose(sd[1:], model_error.HV_EXPONENT_RELATIVE_SD * tropical[1:], rtol=1e-15)
    assert "Schlund" in model_error.source_of() and "assumed" in model_error.source_of(cancelled=True)


def _joint(case, **params):
    return StackMultiChannelRetrieval(**params).forward(_fresh(case))["agb.error"]


def _fresh(case, seed=7):
    """The case with a generator in the same state for every retrieval compared (the same budget draws)."""
    return dataclasses.replace(case, rng=np.random.default_rng(seed))


def test_the_joint_estimate_carries_the_model_term_analytic_and_monte_carlo(seed):
    """Off the calibration centre (W_ref = 100 t/ha for the 200 t/ha forest) the model term adds its variance (eq. 7.2)
    to the analytic log-AGB error, and the Monte Carlo applies it exactly: with the same draws before it, the log
    estimate moves by m ~ N(0, Var m)."""
    case = _stack_retrieval_case(seed, realisations=4000)
    stated = {"mode": "stated", "reference_agb_t_ha": 100.0, "exponent_sd_percent": [20.0, 20.0, 20.0]}
    off, on = _joint(case, model_uncertainty={"mode": "none"}), _joint(case, model_uncertainty=stated)
    stage = StackMultiChannelRetrieval(model_uncertainty=stated)
    alpha = stage.case_alpha(case)
    c = alpha / (alpha @ alpha)
    assert case["scene.covariance"].agb_t_ha == 200.0
    variance = model_error.model_log_variance(c, 0.2 * alpha, np.zeros(3), np.log(200.0 / 100.0), 1.0)
    assert variance == pytest.approx((0.2 * np.log(2.0)) ** 2, rel=1e-12)
    assert on.error_sd**2 - off.error_sd**2 == pytest.approx(variance, rel=1e-9)
    assert on.contribution("model").relative_variance == pytest.approx(variance, rel=1e-12)
    assert [c.name for c in off.contributions].count("model") == 0
    moved = np.log1p(on.samples) - np.log1p(off.samples)  # the cap (600 t/ha) is not reached here
    z_mean, z_var = mean_and_variance_z(moved, 0.0, variance)
    assert abs(z_mean) < Z_ACCEPT and abs(z_var) < Z_ACCEPT
    assert abs(on.rmse("montecarlo") - on.rmse()) < 0.1 * on.rmse()


def test_the_single_power_law_carries_the_model_term(seed):
    """stack_power_law: the model term as an equivalent relative sigma error Var m / p^2 (analytic) and exactly as
    the factor e^m on the AGB estimate (Monte Carlo)."""
    case = _stack_retrieval_case(seed, realisations=2000)  # the joint model is also the HV error model
    stated = {"mode": "stated", "reference_agb_t_ha": 100.0}
    on = StackPowerLawRetrieval(model_uncertainty=stated).forward(_fresh(case))["agb.error"]
    off = StackPowerLawRetrieval(model_uncertainty={"mode": "none"}).forward(_fresh(case))["agb.error"]
    p = on.exponent
    variance = (model_error.HV_EXPONENT_RELATIVE_SD * np.log(200.0 / 100.0)) ** 2
    term = on.contribution("model")
    assert term.group == "model" and term.relative_variance * p**2 == pytest.approx(variance, rel=1e-12)
    assert (on.error_sd / on.sigma_hv) ** 2 - (off.error_sd / off.sigma_hv) ** 2 == pytest.approx(
        term.relative_variance, rel=1e-9)
    moved = np.log1p(on.samples) - np.log1p(off.samples)
    z_mean, z_var = mean_and_variance_z(moved, 0.0, variance)
    assert abs(z_mean) < Z_ACCEPT and abs(z_var) < Z_ACCEPT


def test_the_sensitivity_is_the_rmse_of_the_estimate_with_the_other_exponent(seed):
    """agb.exponent_sensitivity: each end of an exponent's range is the analytic RMSE the chain gives when that
    exponent is the retrieval's (given as alpha), from the same joint moments; the nominal weights give the
    headline."""
    case = _stack_retrieval_case(seed, realisations=100)
    agb = _joint(case)
    alpha = StackMultiChannelRetrieval().case_alpha(case)
    np.testing.assert_allclose(alpha[0], alpha[1], rtol=1e-15)  # ground-cancelled HH: the volume's exponent
    found = dict(agb.sensitivity)
    assert set(found) >= {"hh.low_exponent", "hh.low_rmse_percent", "hh.high_exponent", "hh.high_rmse_percent"}
    assert found["hh.high_exponent"] == pytest.approx(0.8039, rel=1e-12)  # the biome's (same) exponent
    for side in ("low", "high"):
        given = alpha.copy()
        given[0] = found[f"hh.{side}_exponent"]
        other = _joint(case, alpha=list(given))  # the same stated SDs at these exponents
        assert found[f"hh.{side}_rmse_percent"] == pytest.approx(100 * other.rmse(), rel=1e-9)
    assert found["hh.low_rmse_percent"] > 100 * agb.rmse() > found["hh.high_rmse_percent"]
    assert "exponent_sensitivity.hh.low_rmse_percent" in agb.scalars()  # agb.exponent_sensitivity.* outputs
    # the nominal exponents reproduce the headline from the same moments
    model = case["backscatter.error"]
    joint = model.current_joint()
    sigma = np.asarray(model.values)
    assert joint_rmse(np.asarray(joint.mean) / sigma, _relative_cov(case, model), alpha / (alpha @ alpha),
                      agb.contribution("model").relative_variance) == pytest.approx(agb.rmse(), rel=1e-12)


def _relative_cov(case, model):
    from e2esim.retrieval.combine import channel_covariance

    sigma = np.asarray(model.values)
    budget = case["backscatter.budget"]
    gamma = model.speckle_correlation()
    return (np.asarray(model.current_joint().covariance) / np.outer(sigma, sigma)
            + sum(channel_covariance(budget, g, gamma) for g in budget.groups))


def test_all_sources_verdicts_include_the_model_term_and_systematic_ones_do_not(quick_run):
    """The ground-cancelled scenario: every case's AGB error has the model contribution; the verdict on every source
    attributes to it, the one on the systematic error (Men et al. 2021) does not; the joint estimate reports its
    sensitivity to the HH exponent, which the report shows."""
    _, folder = quick_run("biomass_ground_cancelled")
    summary = json.loads((folder / "summary.json").read_text())
    for case in summary["cases"]:
        systematic, every = case["requirements"]
        assert "contribution.model_percent" in every["details"], case["label"]
        assert "contribution.model_percent" not in systematic["details"], case["label"]
        assert "model" in {row["source"] for row in case["agb_budget"]}
        if case["inputs"]["propagation.0.channels"] == "all":
            r = case["results"]
            assert r["agb.exponent_sensitivity.hh.high_exponent"] == pytest.approx(0.8039, rel=1e-12)  # same rule
            assert (r["agb.exponent_sensitivity.hh.low_rmse_percent"] > r["agb.analytic.rmse_percent"]
                    > r["agb.exponent_sensitivity.hh.high_rmse_percent"])
    report = html.unescape((folder / "report.html").read_text())
    assert "Sensitivity of the AGB error to the retrieval's exponents" in report


def test_a_biome_without_a_reference_agb_is_named():
    """A scene of another biome with given exponents: the model term needs its calibration centre, and says so."""
    from e2esim.case import Case, Products
    from e2esim.distortion.faraday_correction import FaradayCorrection
    from e2esim.distortion.polarimetric_model import PolarimetricErrorModel
    from e2esim.errors import ConfigError
    from e2esim.faraday.distribution import GaussianFaraday
    from e2esim.retrieval.multichannel_modules import MultiChannelRetrieval
    from e2esim.scene.covariance import ScatteringCovariance
    from e2esim.settings import SimulationSettings
    from helpers import system

    scene = ScatteringCovariance.from_powers(0.3, 0.05, 0.2, 0.1, 0.0, agb_t_ha=150.0, biome="temperate")
    model = PolarimetricErrorModel(scene, system(), GaussianFaraday(0.0, 0.05), FaradayCorrection(),
                                   looks=100_000)
    case = Case(0, {}, SimulationSettings(), np.random.default_rng(0),
                products=Products({"scene.covariance": scene, "backscatter.error": model}))
    stage = MultiChannelRetrieval(alpha=(0.8, 0.5, 0.1))
    with pytest.raises(ConfigError, match=r"model_uncertainty: case 0: no reference AGB for the scene's "
                       r"biome 'temperate'.*give model_uncertainty\.reference_agb_t_ha"):
        stage.forward(case)
    given = MultiChannelRetrieval(alpha=(0.8, 0.5, 0.1), model_uncertainty={"reference_agb_t_ha": 100.0})
    term = given.forward(case)["agb.error"].contribution("model")
    variance = model_error.model_log_variance([0.8, 0.5, 0.1] / np.dot([0.8, 0.5, 0.1], [0.8, 0.5, 0.1]),
                                              model_error.HV_EXPONENT_RELATIVE_SD * np.array([0.8, 0.5, 0.1]),
                                              np.zeros(3), np.log(1.5))
    assert term.relative_variance == pytest.approx(variance, rel=1e-12)
