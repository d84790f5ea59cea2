"""The Faraday-rotation estimation error in a multi-pass estimate (docs/theory/ground-cancellation.md, Section 3.3;
issue 21, item 6): every pass's co-polarised channels are corrected with its own estimate Omega_hat_n = Omega_n -
dW_n. The symmetrised HV of a pass is unchanged by any rotation F(a) M F(a), so no HV estimator (single date,
multi-date, ground cancelled) can see dW; HH and VV see it at second order,

    F(-dW) S F(-dW) has diagonal (cos^2 dW S_hh - sin^2 dW S_vv, cos^2 dW S_vv - sin^2 dW S_hh),

so E sigma_hat_hh = sigma_hh - 2 E[dW^2] (sigma_hh + Re C_hhvv) + O(dW^4). Checked against an exact average of that
identity, the Monte Carlo (any seed), and in the chain (where the calibration section's estimate reaches the stack
stage: before issue 21 it never did)."""

import dataclasses

import numpy as np
import pytest

from e2esim.distortion.validation import sample_covariance_moments
from e2esim.faraday.distribution import EmpiricalFaraday, GaussianFaraday
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.stack import combination as combos
from e2esim.stack.error_model import StackHVErrorModel
from e2esim.stack.faraday import StackFaraday, residual_moments
from e2esim.stack.joint_model import StackJointErrorModel
from e2esim.stack.montecarlo import pass_operators, simulate_stack
from e2esim.stack.system import StackSystemErrors
from helpers import Z_ACCEPT
from stack_helpers import BOREAL_FR, ground_cancelled_with_faraday_correction, rich_system, site_scene


def _model(residual, system=None, difference_deg=4.0, looks=300, reference="population", site="boreal"):
    scene = site_scene(site)
    errors = StackSystemErrors(system if system is not None else rich_system(1e-3, 2e-3), 0.5)
    faraday = StackFaraday(BOREAL_FR, np.radians(difference_deg), residual)
    return StackJointErrorModel(scene, errors, faraday, combos.interpolated(scene.acquisitions.kz_rad_m),
                                looks=looks, reference=reference)


def test_no_hv_estimate_sees_the_residual_rotation(rng):
    """The HV row of every pass's operator is the same for any correction angle, and the joint model's HV moments
    (hence every HV estimator's) are those without a residual, and those of the HV model, to rounding."""
    delta = (rng.standard_normal((50, 3, 4)) + 1j * rng.standard_normal((50, 3, 4))) * 0.05
    f = 1 + (rng.standard_normal((50, 3, 2)) + 1j * rng.standard_normal((50, 3, 2))) * 0.05
    omega, gain = rng.uniform(-1, 1, (50, 3)), 1 + 0.1 * rng.standard_normal((50, 3))
    exact = pass_operators(delta, f, omega, gain, True)
    estimated = pass_operators(delta, f, omega, gain, True, omega + rng.uniform(-0.5, 0.5, (50, 3)))
    np.testing.assert_allclose(estimated[..., 1, :], exact[..., 1, :], rtol=0, atol=1e-15)
    assert np.abs(estimated[..., 0, :] - exact[..., 0, :]).max() > 1e-3  # HH is not invariant
    with_residual = _model(GaussianFaraday(np.radians(1.0), np.radians(8.0))).current_joint()
    without = _model(None).current_joint()
    hv = StackHVErrorModel(**{f.name: getattr(_model(None), f.name)
                              for f in dataclasses.fields(StackHVErrorModel)}).current()
    for value in (with_residual.mean[1], without.mean[1]):
        assert value == pytest.approx(float(hv.mean), rel=1e-12)
    assert with_residual.covariance[1, 1] == pytest.approx(float(hv.variance), rel=1e-12)


def _second_order_shift(model, ms):
    """The exact expectation of the corrected co-polarised powers of every pass pair with no system errors, for
    dW_n independent N(0, s^2): E[cos^2 dW] etc. from E cos(k dW) = exp(-k^2 s^2 / 2); combined as the estimator
    combines the passes. Returns (E sigma_hat_hh, E sigma_hat_vv) - (sigma_hh, sigma_vv)."""
    e = lambda k: np.exp(-0.5 * k**2 * ms)
    c2, s2 = (1 + e(2)) / 2, (1 - e(2)) / 2
    c4, s4, cs = (3 + 4 * e(2) + e(4)) / 8, (3 - 4 * e(2) + e(4)) / 8, (1 - e(4)) / 8
    blocks = model.scene.blocks()  # C_nm (N, N, 3, 3)
    n = blocks.shape[0]
    same = np.eye(n, dtype=bool)[:, :, None, None]
    a_cc, a_ss, a_cs = np.where(same, c4, c2 * c2), np.where(same, s4, s2 * s2), np.where(same, cs, c2 * s2)
    hh = a_cc[..., 0, 0] * blocks[..., 0, 0] + a_ss[..., 0, 0] * blocks[..., 2, 2] \
        - a_cs[..., 0, 0] * (blocks[..., 0, 2] + blocks[..., 2, 0])
    vv = a_cc[..., 0, 0] * blocks[..., 2, 2] + a_ss[..., 0, 0] * blocks[..., 0, 0] \
        - a_cs[..., 0, 0] * (blocks[..., 0, 2] + blocks[..., 2, 0])
    q = model.combination.matrix
    values = model.values
    return (np.real(np.sum(q.T * hh)) - values[0], np.real(np.sum(q.T * vv)) - values[2])


@pytest.mark.parametrize("sd_deg", [2.0, 10.0])
def test_copolarised_bias_from_the_residual_rotation_is_exact(sd_deg):
    """No system errors, no noise, no rotation difference: the joint model's HH and VV biases are the exact average
    of the identity above over independent dW_n (the cubature of degree 5 over the 3 passes: O(s^6) left out)."""
    ms = np.radians(sd_deg) ** 2
    quiet = SystemErrorModel(crosstalk_level=0.0, imbalance_level=0.0, noise_power=0.0)
    model = _model(GaussianFaraday(0.0, np.radians(sd_deg)), quiet, difference_deg=0.0, looks=None, reference="scene")
    m = model.current_joint()
    hh, vv = _second_order_shift(model, ms)
    combined = model.combination.combined_covariance(model.scene.blocks())
    second_order = -2 * ms * (np.real(combined[0, 0]) + np.real(combined[0, 2]))
    assert hh == pytest.approx(second_order, rel=10 * ms)  # the identity's own expansion, O(dW^4) left out
    assert m.bias_distortion[0] == pytest.approx(hh, rel=30 * ms**2)  # the cubature of degree 5: O(dW^6) left out
    assert m.bias_distortion[2] == pytest.approx(vv, rel=30 * ms**2)
    assert m.bias_distortion[1] == pytest.approx(0.0, abs=1e-15)


def test_residual_moments_fold_the_ambiguity_errors():
    samples = np.radians([0.5, -0.5, 1.0, -1.0, 90.5])
    mu, sd, wrong = residual_moments(EmpiricalFaraday(samples))
    folded = np.radians([0.5, -0.5, 1.0, -1.0, 0.5])
    assert mu == pytest.approx(folded.mean()) and sd == pytest.approx(folded.std()) and wrong == pytest.approx(0.2)
    assert residual_moments(GaussianFaraday(0.1, 0.2)) == (0.1, 0.2, 0.0)


def test_the_monte_carlo_sees_the_residual_as_the_analytic_model_does(rng):
    """The arbiter: with a residual rotation of SD 4 deg (a small estimation window), the simulated HH, HV and VV
    errors agree with the analytic moments with the residual (any seed), and HH's mean is far from the one without
    it (the shift -2 E[dW^2] (sigma_hh + Re C_hhvv) is many standard errors). The cubature of degree 5 leaves out
    O(s^6) of that shift and O((4 s)^2) of the residual's own small spread (8 % of it here, 1e-3 of the covariance)."""
    residual = EmpiricalFaraday(np.radians(4.0) * rng.standard_normal(4000) + np.radians(0.5))
    system = rich_system(5e-4, 1e-3, gain_sd_db=0.1)
    model, perfect = _model(residual, system, looks=10**6, reference="scene"), _model(None, system, looks=10**6,
                                                                                      reference="scene")
    an = model.current_joint()
    mc = simulate_stack(model.scene, model.errors, model.faraday, model.combination, rng, 10**6, 6000, 1, "scene")
    s = sample_covariance_moments(np.stack([mc.errors[ch] for ch in ("hh", "hv", "vv")], -1))
    sd = np.sqrt(np.diag(an.covariance))
    mean_se = np.hypot(s["mean_se"], 2 * np.abs(an.bias_distortion) / 1e3)  # one scene of 10^6 looks
    cov_se = np.hypot(s["covariance_se"], 2 * np.outer(sd, sd) / 1e3)
    z_mean = (s["mean"] - an.mean) / mean_se
    z_cov = (s["covariance"] - an.covariance) / cov_se
    assert np.all(np.abs(z_mean) < Z_ACCEPT), z_mean
    assert np.all(np.abs(z_cov) < Z_ACCEPT), z_cov
    shift = (an.mean - perfect.current_joint().mean) / mean_se
    assert abs(shift[0]) > 3 * Z_ACCEPT and abs(shift[2]) > 3 * Z_ACCEPT and abs(shift[1]) < 1e-9, shift


def test_the_estimation_window_reaches_the_ground_cancelled_copolarised_channels():
    """Issue 21, item 6: in the 3-pass ground-cancelled scenario the window of the calibration's Faraday-rotation
    estimate moved its error, but not the stack's HH and VV (their correction used the true rotation). Now the
    co-polarised biases move by the second-order shift of the residual, -2 E[dW^2] (sigma_hh + Re C_hhvv) of the
    ground-cancelled covariance, and HV does not move at all."""
    import e2esim

    results = e2esim.run(ground_cancelled_with_faraday_correction())
    s = results.scalars
    ms = np.radians(s["calibration.0.faraday_correction.omega_error_rms_deg"]) ** 2  # E[dW^2] of each window
    assert ms[0] > 4 * ms[1]
    re_hhvv = s["combined.hhvv_magnitude"] * np.cos(np.radians(s["combined.hhvv_phase_deg"]))
    for ch, sigma in (("hh", s["combined.sigma_hh"]), ("vv", s["combined.sigma_vv"])):
        predicted = -2 * (ms[0] - ms[1]) * (sigma[0] + re_hhvv[0])
        moved = s[f"{ch}.analytic.mean"][0] - s[f"{ch}.analytic.mean"][1]
        assert moved == pytest.approx(predicted, rel=0.05), ch
    assert s["hv.analytic.mean"][0] == pytest.approx(s["hv.analytic.mean"][1], rel=1e-12)
    assert s["agb.analytic.rmse_percent"][0] != s["agb.analytic.rmse_percent"][1]
