"""Analytic moments of the sigma_hv error (Men et al. 2021, eqs. 6-14, A4-A6) against the full model.

The Monte Carlo here uses ``reference="population"`` (a new scene per realisation), for which the
analytic moments are exact to O(V^2) including speckle and noise over L looks, so the comparison can be
made at a precision far beyond the paper's (docs/errata.md, E3-E4).
"""

import numpy as np
import pytest

from e2esim.distortion.analytic import hv_error_moments
from e2esim.distortion.first_order import (
    SceneTerms,
    crosstalk_moments,
    imbalance_moments,
    simplified_moments,
    variance_terms,
)
from e2esim.distortion.montecarlo import simulate
from e2esim.faraday.distribution import ConstantFaraday, GaussianFaraday
from e2esim.instrument.system_errors import SystemErrorModel
from helpers import Z_ACCEPT, forest, mean_and_variance_z, system


def test_simplified_equals_general_form_for_equal_variances():
    fr = GaussianFaraday(1.0, 0.2)
    trig = fr.trig_moments()
    v, ve = 3e-4, 1e-4
    rho_d, rho_e = 0.8 * np.exp(0.7j), 0.6 * np.exp(-1.2j)
    xt = crosstalk_moments(np.full(4, v), rho_d * v, rho_d * v, trig)
    ci = imbalance_moments(np.full(2, ve), rho_e * ve, trig)
    xt_s, ci_s = simplified_moments(v, rho_d, ve, rho_e, trig)  # eqs. (13)-(14)
    for a, b in [(xt.vx, xt_s.vx), (xt.vy, xt_s.vy), (xt.cxy, xt_s.cxy), (ci.va, ci_s.va), (ci.vb, ci_s.vb),
                 (ci.cab, ci_s.cab)]:
        assert a == pytest.approx(b, rel=1e-12)


def test_parts_add_up_to_the_totals():
    m = hv_error_moments(forest("boreal_200"), system(gain_sd_db=0.3), GaussianFaraday(1.0, 0.4), "complete",
                         looks=500, reference="population")
    bias = m.bias_imbalance + m.bias_crosstalk + m.bias_noise + m.bias_higher_order + m.bias_gain
    var = (m.var_imbalance + m.var_crosstalk + m.var_interaction + m.var_higher_order + m.var_faraday_spread
           + m.var_finite_looks + m.var_gain)
    assert m.mean == pytest.approx(bias, rel=1e-12)
    assert m.variance == pytest.approx(var, rel=1e-12)
    assert m.bias_noise == pytest.approx(10 ** -2.7 / 2)  # sigma_n / 2, eq. (11)


def test_appendix_c_bias_decomposition_for_boreal_200():
    # Section V-A: "the crosstalk contribution to the bias is an order of magnitude greater than that from
    # channel imbalance"; Section VII: noise dominates the bias at NESZ -27 dB.
    m = hv_error_moments(forest("boreal_200"), system(), GaussianFaraday(np.pi / 3, np.pi / 36), "paper")
    assert 8 < m.bias_crosstalk / m.bias_imbalance < 30
    assert m.bias_noise > 5 * (m.bias_crosstalk + m.bias_imbalance)
    # Appendix C: channel imbalance (12a) dominates the variance; the interaction (12c) is negligible.
    assert m.var_imbalance > 0.9 * m.variance
    assert m.var_interaction < 1e-3 * m.variance


def test_eq12a_uses_2VA_not_2VB():
    # docs/errata.md E2: with channel imbalance only, Var(e) ~ 2 sigma_hv^2 V_A.
    scene = SceneTerms.from_covariance(forest("boreal_200"))
    trig = ConstantFaraday(np.pi / 3).trig_moments()
    ci = imbalance_moments(np.full(2, 1e-4), 0.9e-4, trig)
    xt = crosstalk_moments(np.zeros(4), 0.0, 0.0, trig)
    v = variance_terms(scene, xt, ci)["imbalance"]
    assert v == pytest.approx(2 * scene.sigma_hv**2 * ci.va, rel=0.01)
    assert v > 10 * 2 * scene.sigma_hv**2 * ci.vb


CASES = {
    "paper_structure": dict(scene="boreal_200", sys=system(), fr=GaussianFaraday(np.pi / 3, np.pi / 36), looks=1000),
    "complex_unequal": dict(
        scene="boreal_50",
        sys=SystemErrorModel(crosstalk_level=2.5e-3, crosstalk_relative=(1.0, 0.6, 1.6, 0.8),
                             crosstalk_rho13=0.7 * np.exp(1.0j), crosstalk_rho24=0.5 * np.exp(-2.0j),
                             imbalance_level=8e-4, imbalance_relative=(1.0, 0.5), imbalance_rho=0.6 * np.exp(0.7j),
                             noise_power=10 ** -2.7),
        fr=GaussianFaraday(0.4, 0.1), looks=100),
    "large_faraday_spread_and_gain": dict(
        scene="tropical_341", sys=system(-22.0, -25.0, rho=0.9 * np.exp(2.0j), gain_sd_db=0.3, gain_offset_db=0.1),
        fr=GaussianFaraday(1.1, np.radians(36.0)), looks=10),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_complete_moments_agree_with_the_full_model(name, rng):
    c = CASES[name]
    scene = forest(c["scene"])
    an = hv_error_moments(scene, c["sys"], c["fr"], "complete", looks=c["looks"], reference="population")
    mc = simulate(scene, c["sys"], c["fr"], rng, c["looks"], 300_000, reference="population")
    z_mean, z_var = mean_and_variance_z(mc.hv, an.mean, an.variance)
    assert abs(z_mean) < Z_ACCEPT
    assert abs(z_var) < Z_ACCEPT


def test_paper_variance_misses_second_order_crosstalk_terms(rng):
    # docs/errata.md E3: crosstalk only, fixed FR, no noise, infinite looks: the complete variance agrees with
    # the full model while eq. (12) is about 4 % low, far outside the sampling error.
    scene, fr = forest("boreal_200"), ConstantFaraday(np.pi / 3)
    sys_model = system(-24.0, -200.0, nesz_db=None)  # -200 dB: no channel imbalance
    mc = simulate(scene, sys_model, fr, rng, looks=10**7, realisations=800_000, reference="population")
    complete = hv_error_moments(scene, sys_model, fr, "complete", looks=10**7, reference="population")
    paper = hv_error_moments(scene, sys_model, fr, "paper")
    assert abs(mean_and_variance_z(mc.hv, complete.mean, complete.variance)[1]) < Z_ACCEPT
    z_paper = mean_and_variance_z(mc.hv, paper.mean, paper.variance)[1]
    assert z_paper > 8  # expected about 12 standard errors at this size
    assert 0.03 < complete.variance / paper.variance - 1 < 0.05


def test_paper_variance_misses_the_spread_over_faraday_rotation(rng):
    # docs/errata.md E4: SD(Omega) = 36 deg, crosstalk only: inserting the moments into a fixed-Omega formula
    # underestimates the variance by about a fifth (the full model agrees with the complete form, see
    # test_complete_moments_agree_with_the_full_model).
    scene, fr = forest("boreal_200"), GaussianFaraday(np.pi / 3, np.radians(36.0))
    sys_model = system(-24.0, -200.0, nesz_db=None)
    complete = hv_error_moments(scene, sys_model, fr, "complete")
    paper = hv_error_moments(scene, sys_model, fr, "paper")
    assert complete.mean == pytest.approx(paper.mean, rel=1e-3)  # the mean is linear in the FR moments
    assert complete.var_faraday_spread > 0
    assert complete.variance / paper.variance - 1 > 0.15


def test_vectorised_levels_match_scalar_calls():
    scene, fr = forest("boreal_350"), GaussianFaraday(0.9, 0.2)
    levels = np.array([1e-5, 1e-4, 1e-3])
    for form in ("paper", "complete"):
        vec = hv_error_moments(scene, system(), fr, form, crosstalk_level=levels[:, None], imbalance_level=levels)
        assert vec.mean.shape == (3, 3)
        for i, x in enumerate(levels):
            for j, e in enumerate(levels):
                one = hv_error_moments(scene, system().with_levels(x, e), fr, form)
                assert vec.mean[i, j] == pytest.approx(float(one.mean), rel=1e-12)
                assert vec.variance[i, j] == pytest.approx(float(one.variance), rel=1e-12)


def test_bad_form_and_reference_are_rejected():
    with pytest.raises(ValueError, match="form must be one of"):
        hv_error_moments(forest(), system(), ConstantFaraday(0.0), form="exact")
    with pytest.raises(ValueError, match="reference must be one of"):
        hv_error_moments(forest(), system(), ConstantFaraday(0.0), reference="truth")


def test_the_quadrature_average_is_numpys_sum_bit_for_bit(rng):
    """``_average`` writes out the sum over the short node axis (numpy's reduction over it is the slow part of the
    analytic moments): it must stay numpy's ``(values * weights).sum(-1)`` bit for bit, signed zeros included, for
    any node count, any layout and values of any size (the number lock and the case-alone identity rest on it)."""
    from e2esim.distortion import analytic

    for trial in range(300):
        shape = [(257, 5), (5,), (3, 7, 5), (1, 5), (4, 2), (6, 3), (6, 4), (6, 6), (6, 7), (6, 1), (6, 8), (2, 16)][
            trial % 12]
        values = rng.standard_normal(shape) * 10.0 ** rng.uniform(-30, 30, size=shape)
        u = rng.uniform(size=shape)
        values[u < 0.1], values[(u >= 0.1) & (u < 0.2)] = 0.0, -0.0
        values[u > 0.98] = np.inf if trial % 2 else -np.inf
        if trial % 3 == 0 and values.ndim > 1:
            values = np.asfortranarray(values)
        weights = rng.standard_normal(shape[-1:]) if trial % 4 else -np.zeros(shape[-1:])
        with np.errstate(invalid="ignore"):
            expected, got = (values * weights).sum(-1), analytic._average(values, weights)
        assert np.shape(got) == np.shape(expected)
        np.testing.assert_array_equal(got, expected)
        np.testing.assert_array_equal(np.signbit(got), np.signbit(expected))
