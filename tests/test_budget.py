"""Backscatter error budget, Ahmed, Siqueira & Hensley (2014), eqs. (20)-(38): each equation against hand
values, the window fits (eqs. 25, 29) against exact integrals, eq. (21) against a speckle simulation, the
vectorised kernels against the scalar reference, and bad input."""

import math

import numpy as np
import pytest
from scipy import integrate, stats

from e2esim.budget.area import area_projection_error, dem_averaging_factor, slope_error
from e2esim.budget.calibration import (
    BEAM_SHAPING_UNIFORM,
    azimuth_gain_error,
    dem_calibration_error,
    elevation_gain_error,
    pointing_calibration_error,
    random_calibration_error,
    sinc_squared_integral,
)
from e2esim.budget.geometry import (
    azimuth_resolution,
    broadening_factor,
    number_of_looks,
    range_resolution,
    slant_range_spherical,
)
from e2esim.budget.noise import inverse_mnr, islr_db, quantisation_noise_ratio_db, speckle_noise_terms
from e2esim.budget.presets import BIOMASS_200M, UAVSAR_AHMED2014, preset
from e2esim.budget.reference import budget_scalar, random_cases
from e2esim.budget.result import GROUPS, TERMS, BudgetInputs, backscatter_budget
from e2esim.budget.window import window_broadening, window_islr_db
from e2esim.errors import PhysicsInputError

C = 299_792_458.0


# eqs. (22)-(25) -----------------------------------------------------------------------------------------
def test_resolutions_eqs_23_24():
    assert range_resolution(80e6) == pytest.approx(C / 160e6, rel=1e-15)  # 1.87370 m
    assert range_resolution(80e6, 3.0e8) == pytest.approx(1.875, rel=1e-15)  # Table III with c = 3e8
    assert azimuth_resolution(1.5) == 0.75  # Table III
    np.testing.assert_allclose(range_resolution([6e6, 80e6]), [C / 12e6, C / 160e6])


def test_broadening_eq_25_hand_values():
    assert broadening_factor(1.0) == pytest.approx(1.0, abs=1e-12)  # uniform
    assert broadening_factor(0.0) == pytest.approx(1.6363, abs=1e-12)  # Hann
    assert broadening_factor(0.7) == pytest.approx(1.6363 - 0.6363 * math.sqrt(0.7), abs=1e-12)  # 1.10393
    assert broadening_factor(0.08) == pytest.approx(1.45633, abs=5e-6)  # Hamming: Section III-A's "1.45"


@pytest.mark.parametrize("eta", [0.0, 0.08, 0.3, 0.49, 0.7, 1.0])
def test_eq_25_against_exact_window_width(eta):
    # Eq. (25) is a fit: within 5.1 % of the exact -3 dB width of w = eta + (1 - eta) cos^2 for all eta
    # (largest near eta = 0.47); 5.5 % leaves room for the root finder, not for a different formula.
    assert broadening_factor(eta) == pytest.approx(window_broadening(eta), rel=0.055)


def test_table3_kappa_1_1909_is_not_eq_25():
    # 1.1909 = 1.6363 - 0.6363 * 0.7 (eta, not sqrt(eta)); the exact width is closer to eq. (25).
    assert 1.6363 - 0.6363 * 0.7 == pytest.approx(1.1909, abs=5e-5)
    exact = window_broadening(0.7)
    assert abs(broadening_factor(0.7) - exact) < abs(1.1909 - exact) / 2


def test_looks_eq_22_hand_value():
    n = number_of_looks(10_000.0, math.radians(40), 1.875, 0.75, 1.1909, 1.1909)
    assert n == pytest.approx(10_000 * math.sin(math.radians(40)) / (1.1909**2 * 1.40625), rel=1e-14)
    assert round(float(n)) == 3223  # Table IV reproduced with Table III's kappa and c = 3e8


def test_slant_range_spherical_limits():
    # Airborne: altitude / cos(theta); nadir: altitude.
    assert slant_range_spherical(12_500.0, math.radians(40)) == pytest.approx(12_500 / math.cos(math.radians(40)),
                                                                              rel=2e-3)
    assert slant_range_spherical(666e3, 1e-9) == pytest.approx(666e3, rel=1e-9)
    assert 700e3 < slant_range_spherical(666e3, math.radians(28.4)) < 800e3


# eqs. (21), (26)-(29) ---------------------------------------------------------------------------------------
def test_islr_and_qnr_hand_values():
    assert islr_db(1.0) == pytest.approx(-46.965 + 104.11 - 112.59 + 43.124, abs=1e-12)  # -12.321 dB
    assert islr_db(0.0) == pytest.approx(-46.965)
    assert quantisation_noise_ratio_db(8) == pytest.approx(2.0 + 6.02 * 8)  # 50.16 dB


@pytest.mark.parametrize("eta", [0.5, 0.7, 0.85, 1.0])
def test_eq_29_matches_exact_islr_for_weak_weighting(eta):
    # Main lobe = +-2 resolution widths; eq. (29) agrees within 0.6 dB for eta in [0.5, 1].
    assert islr_db(eta) == pytest.approx(window_islr_db(eta, 2.0), abs=0.6)


def test_mnr_eq_27_and_speckle_terms_eq_21():
    inv = inverse_mnr(10 ** -1.4, 10 ** -1.4, 100.0, 10 ** 5.016)
    assert inv == pytest.approx(2 * 10 ** -1.4 + 0.01 + 10 ** -5.016)
    s, t, m = speckle_noise_terms(400.0, 4.0, 1.0, 50.0, 0.1)
    assert s == pytest.approx(1 / 20)  # 1/sqrt(N N_os)
    assert t == pytest.approx(1 / 40 / 50)  # 1/(sqrt(N N_ot) SNR)
    assert m == pytest.approx(1 / 40 * 0.1)  # 1/(sqrt(N N_ot) MNR)
    # eq. (21) as printed: (1/sqrt N)(1/sqrt(N_os) + 1/sqrt(N_ot) (1 + SNR/MNR)/SNR)
    printed = (1 / 20) * (1 + 0.5 * (1 + 50 * 0.1) / 50)
    assert s + t + m == pytest.approx(printed, rel=1e-14)


def test_eq_21_against_speckle_simulation(rng):
    """Average N looks of speckled signal plus noise, subtract the noise level: the relative SD is
    (1 + 1/SNR)/sqrt(N) (eq. 21 with N_os = N_ot = 1). Chi-square test of the sample variance."""
    looks, snr_lin, trials = 50, 4.0, 20_000
    sigma, noise = 1.0, 0.25
    intensity = (sigma + noise) * rng.gamma(looks, 1.0 / looks, trials)  # speckle and noise are one exponential
    estimate = intensity - noise
    s, t, _ = speckle_noise_terms(looks, 1, 1, snr_lin, 0.0)
    expected_var = (s + t) ** 2 * sigma**2
    chi2 = (trials - 1) * estimate.var(ddof=1) / expected_var
    # The sample variance of a gamma law is not chi-square; use its exact variance instead (z test).
    k = looks
    var_of_var = expected_var**2 * (2 / (trials - 1) + 6 / (k * trials))
    z = (estimate.var(ddof=1) - expected_var) / math.sqrt(var_of_var)
    assert abs(z) < 5, (chi2, z)
    assert abs(estimate.mean() - sigma) < 5 * math.sqrt(expected_var / trials)


# eqs. (30)-(35) ---------------------------------------------------------------------------------------------
def test_random_calibration_eq_31():
    assert random_calibration_error(0.05) == pytest.approx(10 ** 0.005 - 1)  # 1.158 %
    assert random_calibration_error(0.0) == 0.0


def test_sinc_squared_integral_closed_form():
    for a in (0.3, 1.0, math.pi / (2 * BEAM_SHAPING_UNIFORM), 2.5):
        numeric, _ = integrate.quad(lambda x: (math.sin(x) / x) ** 2, 0, a)
        assert sinc_squared_integral(a) == pytest.approx(numeric, rel=1e-12)


def test_gain_errors_eqs_33_34_hand_values():
    k = 1 / 0.88
    x = math.pi / (2 * k)
    ln_sinc = math.log(math.sin(x) / x)
    dtheta, el_bw, az_bw = 0.8e-3, math.radians(39), math.radians(8)
    assert elevation_gain_error(dtheta, el_bw, k) == pytest.approx(4 * dtheta / el_bw * ln_sinc, rel=1e-14)
    integral, _ = integrate.quad(lambda t: (math.sin(t) / t) ** 2, 0, x)
    assert azimuth_gain_error(dtheta, az_bw, k) == pytest.approx(2 * k / math.pi * dtheta / az_bw * ln_sinc / integral,
                                                                 rel=1e-10)
    total = pointing_calibration_error(dtheta, el_bw, az_bw, k)
    assert total == pytest.approx(-2 * (elevation_gain_error(dtheta, el_bw, k) + azimuth_gain_error(dtheta, az_bw, k)))
    assert total > 0  # ln sinc < 0


def test_eq_33_is_swath_average_of_log_gain_derivative():
    """Derivation check: the mean of |d ln G / d theta| over the half-power beam times dtheta equals eq. (33)
    for the one-way power pattern G = sinc^2(pi theta / (k theta_1/2))."""
    k, bw, dtheta = 1 / 0.88, math.radians(20), 1e-3

    def dlng(theta):
        x = math.pi * theta / (k * bw)
        return 2 * (1 / math.tan(x) - 1 / x) * math.pi / (k * bw) if x else 0.0

    mean_abs, _ = integrate.quad(lambda t: abs(dlng(t)), -bw / 2, bw / 2)
    assert dtheta * mean_abs / bw == pytest.approx(abs(elevation_gain_error(dtheta, bw, k)), rel=1e-8)


def test_dem_pointing_eq_35_and_geo_term():
    from e2esim.budget.calibration import dem_pointing_error

    assert dem_pointing_error(3.0, 16_322.0) == pytest.approx(3 / 16_322)  # 0.18380 mrad
    assert dem_calibration_error(3.0, 16_322.0, math.radians(39)) == pytest.approx(
        abs(elevation_gain_error(3 / 16_322, math.radians(39))))


# eqs. (36)-(38) ---------------------------------------------------------------------------------------------
def test_slope_error_eq_38():
    assert slope_error(3.0, 30.0, math.radians(3)) == pytest.approx(0.1 / (1 + math.tan(math.radians(3)) ** 2))
    assert round(float(slope_error(3.0, 30.0, math.radians(3))), 4) == 0.0997  # Table IV


def test_area_projection_eq_37_flat_ground_and_derivative():
    theta = math.radians(40)
    assert area_projection_error(theta, 0.0, 0.0, 0.01) == pytest.approx(0.01 / math.tan(theta))
    # With an azimuth slope 0 the range term is d ln(1/sin(theta - tau_r)) / d tau_r.
    tr = math.radians(5)
    h = 1e-7
    numeric = (math.log(1 / math.sin(theta - tr - h)) - math.log(1 / math.sin(theta - tr + h))) / (2 * h)
    assert area_projection_error(theta, tr, 0.0, 1.0) == pytest.approx(numeric, rel=1e-6)


def test_dem_averaging_factor_and_cap():
    assert dem_averaging_factor(900.0, 1.4, 3000.0) == pytest.approx(math.sqrt(900 / (1.4 * 3000)))
    assert dem_averaging_factor(900.0, 1.4, 100.0) > 1
    assert dem_averaging_factor(900.0, 1.4, 100.0, cap=True) == 1.0


# the budget ----------------------------------------------------------------------------------------------
def test_uavsar_budget_area_projection_dominates_as_the_paper_says():
    """Section III-D: "The largest contribution ... in either cases is from uncertainties in area projection"
    (hectares and 25 m subplots)."""
    for area in (10_000.0, 625.0):
        b = backscatter_budget(preset("uavsar_ahmed2014", area_m2=area), 0.05)
        groups = {g: float(b.group_sd(g)) for g in GROUPS}
        assert max(groups, key=groups.get) == "area_projection", groups
    hectare = backscatter_budget(preset("uavsar_ahmed2014"), 0.05)
    subplot = backscatter_budget(preset("uavsar_ahmed2014", area_m2=625.0), 0.05)
    # N-dependent terms scale with sqrt(16) = 4 between hectares and subplots.
    assert float(subplot.relative_sd["speckle"] / hectare.relative_sd["speckle"]) == pytest.approx(4.0)
    assert float(subplot.relative_sd["area_projection"] / hectare.relative_sd["area_projection"]) == pytest.approx(4.0)


def test_budget_total_and_combinations():
    inputs = preset("uavsar_ahmed2014")
    b = backscatter_budget(inputs, 0.05)
    sd = b.relative_sd
    sn = sd["speckle"] + sd["thermal_noise"] + sd["multiplicative_noise"]  # eq. (21) linear
    cal = math.sqrt(sd["calibration_random"] ** 2 + sd["calibration_pointing"] ** 2 + sd["calibration_dem"] ** 2)
    total = math.sqrt(sn**2 + sd["temporal"] ** 2 + cal**2 + sd["area_projection"] ** 2)
    assert float(b.total_sd) == pytest.approx(total, rel=1e-14)
    assert set(b.contributions) == set(TERMS)
    lin = backscatter_budget(inputs.replace(combination="linear"), 0.05)
    assert float(lin.total_sd) == pytest.approx(sn + sd["temporal"] + sd["calibration_random"]
                                                + sd["calibration_pointing"] + sd["calibration_dem"]
                                                + sd["area_projection"], rel=1e-14)
    assert float(lin.total_sd) > float(b.total_sd)
    assert float(b.absolute_sd("temporal")) == pytest.approx(0.002)  # eq. (44), absolute
    only = b.with_(groups=("speckle_noise",))
    assert float(only.total_variance) == pytest.approx(sn**2)


def test_budget_vectorised_equals_scalar_reference():
    rng = np.random.default_rng(7)
    n = 200
    case, arrays, sigma = random_cases(n, rng, UAVSAR_AHMED2014)
    b = backscatter_budget(BudgetInputs(**{**case, **arrays}), sigma)
    for i in range(0, n, 17):
        one = {**case, **{k: float(v[i]) for k, v in arrays.items()}}
        ref = budget_scalar(one, float(sigma[i]))
        for name in TERMS:
            assert float(b.relative_sd[name][i]) == pytest.approx(ref[name], rel=1e-9, abs=1e-15), name
        assert float(b.total_sd[i]) == pytest.approx(ref["total"], rel=1e-9)
        assert float(b.looks[i]) == pytest.approx(ref["looks"], rel=1e-12)


def test_biomass_preset_product_looks():
    """4 ha at 25 m x 8.3 m (seed 003) and mid-swath incidence: about 90 looks, speckle ~ 10 %."""
    b = backscatter_budget(preset("biomass_200m"), 0.0726)
    expected = 40_000 * math.sin(BIOMASS_200M["incidence_rad"]) / (C / 12e6 * 8.3)
    assert float(b.looks) == pytest.approx(expected, rel=1e-12)
    assert float(b.relative_sd["speckle"]) == pytest.approx(1 / math.sqrt(expected), rel=1e-12)


def test_budget_channel_axis():
    b = backscatter_budget(preset("biomass_200m"), np.array([0.649, 0.0726, 0.274])).with_(channels=("hh", "hv", "vv"))
    hv = b.channel("hv")
    assert float(hv.sigma) == pytest.approx(0.0726)
    assert float(hv.relative_sd["thermal_noise"]) > float(b.channel("hh").relative_sd["thermal_noise"])
    with pytest.raises(KeyError, match="no channel 'xx'"):
        b.channel("xx")


@pytest.mark.parametrize("change, message", [
    ({"bandwidth_hz": None}, "needs bandwidth_hz"),
    ({"eta_range": 1.5}, r"eta_range \(window pedestal\) must be in \[0, 1\]"),
    ({"area_m2": -1.0}, "area_m2 must be > 0"),
    ({"diverse_observations": 20}, "cannot exceed observations"),
    ({"combination": "rss"}, "combination must be one of"),
    ({"slope_range_rad": math.radians(45)}, "range slope must be smaller than the incidence"),
])
def test_budget_bad_input_messages(change, message):
    with pytest.raises(PhysicsInputError, match=message):
        backscatter_budget(preset("uavsar_ahmed2014", **change), 0.05)


def test_budget_needs_positive_sigma():
    with pytest.raises(PhysicsInputError, match="sigma > 0"):
        backscatter_budget(preset("uavsar_ahmed2014"), 0.0)


def test_unknown_preset():
    with pytest.raises(KeyError, match="unknown budget preset 'nisar'"):
        preset("nisar")


def test_speckle_gamma_law_matches_budget_variance(rng):
    """The Monte Carlo law of the speckle term: Gamma(k, 1/k) - 1 with k = 1/v has variance v (KS against
    the gamma law and a z test on the variance)."""
    from e2esim.retrieval.agb_error import AGBContribution
    from e2esim.retrieval.combine import draw_random_errors

    b = backscatter_budget(preset("biomass_200m"), np.array([0.5, 0.07, 0.3])).with_(
        channels=("hh", "hv", "vv"), groups=("speckle_noise",))
    v = float(b.channel("hv").group_sd("speckle_noise") ** 2)
    contrib = (AGBContribution("speckle_noise", "random", 0.0, v),)
    x = draw_random_errors(rng, (40_000,), b, contrib)
    k = 1 / v
    assert stats.kstest(x + 1, stats.gamma(k, scale=1 / k).cdf).pvalue > 1e-4
    assert abs(x.mean()) < 5 * math.sqrt(v / x.size)
