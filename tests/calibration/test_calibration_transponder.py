"""System errors from polarimetric calibrators by non-linear least squares (seed 003, Sect. 5.1)."""

from __future__ import annotations

import numpy as np
import pytest

from cal_helpers import Z_ACCEPT, biomass_system, z_mean, z_variance
from e2esim.calibration.targets import Calibrators, calibrator_responses, mean_response, response_covariance
from e2esim.calibration.transponder import gauge_transform, solve_transponder
from e2esim.errors import PhysicsInputError
from e2esim.polarimetry.simulate import SystemState
from e2esim.polarimetry.system_model import faraday_matrix, receive_distortion, to_matrix, transmit_distortion

CLUTTER = np.array([[1.0, 0, 0.6], [0, 0.1, 0], [0.6, 0, 1.0]], dtype=complex)
TRANSPONDERS = ("transponder_hh", "transponder_hv", "transponder_vh", "transponder_vv")
PASSIVE = ("trihedral", "dihedral_0", "dihedral_22.5", "dihedral_45")


def _truth(rng, n, omega_deg, crosstalk_db=-25.0):
    s = biomass_system(crosstalk_db=crosstalk_db, imbalance_db=-25.0, rho=0.5).sample(rng, n)
    gain = s.gain * np.exp(1j * rng.uniform(-np.pi, np.pi, n))
    return SystemState(s.delta, s.f, np.full(n, np.radians(omega_deg)), gain)


def _noise_free(cal, truth):
    return to_matrix(mean_response(cal, truth))


@pytest.mark.parametrize("names", [TRANSPONDERS, PASSIVE])
@pytest.mark.parametrize("omega_deg", [0.0, 30.0, 60.0, -75.0])
def test_noise_free_recovery_at_any_faraday_rotation(names, omega_deg):
    """With Omega known (gauge faraday_prior, SD 0) the solution is exact at any latitude."""
    cal = Calibrators.named(names, 30.0, CLUTTER, -40.0)
    truth = _truth(np.random.default_rng(1), 20, omega_deg)
    sol = solve_transponder(_noise_free(cal, truth), cal, "faraday_prior", faraday_prior=(truth.omega, 0.0))
    np.testing.assert_allclose(sol.delta, truth.delta, atol=1e-9)
    np.testing.assert_allclose(sol.f, truth.f, atol=1e-9)
    np.testing.assert_allclose(sol.gain, truth.gain, rtol=1e-9)
    np.testing.assert_allclose(sol.chi2, 0.0, atol=1e-6)


def test_faraday_rotation_and_crosstalk_trade_exactly():
    """The gauge direction: R F(eps), Omega - eps, F(eps) T give identical responses for any eps."""
    cal = Calibrators.named(TRANSPONDERS, 30.0, CLUTTER)
    truth = _truth(np.random.default_rng(2), 5, 20.0)
    moved = SystemState(*gauge_transform(truth.delta, truth.f, truth.omega, truth.gain, 0.3))
    np.testing.assert_allclose(mean_response(cal, moved), mean_response(cal, truth), atol=1e-12)


def test_gauge_transform_equals_the_matrix_products(rng):
    """The closed form of gauge_transform against R F(eps) and F(eps) T formed by numpy, renormalised."""
    truth = _truth(rng, 300, 20.0, crosstalk_db=-15.0)
    eps = rng.uniform(-0.5, 0.5, 300)
    delta, f, omega, gain = gauge_transform(truth.delta, truth.f, truth.omega, truth.gain, eps)
    rot = faraday_matrix(eps)
    r = receive_distortion(truth.delta, truth.f) @ rot
    t = rot @ transmit_distortion(truth.delta, truth.f)
    gr, gt = r[:, 0, 0], t[:, 0, 0]
    r, t = r / gr[:, None, None], t / gt[:, None, None]
    np.testing.assert_allclose(delta, np.stack([r[:, 1, 0], r[:, 0, 1], t[:, 0, 1], t[:, 1, 0]], -1), rtol=1e-13,
                               atol=1e-15)
    np.testing.assert_allclose(f, np.stack([r[:, 1, 1], t[:, 1, 1]], -1), rtol=1e-13)
    np.testing.assert_allclose(gain, truth.gain * gr * gt, rtol=1e-13)
    np.testing.assert_allclose(omega, truth.omega - eps, rtol=1e-15)


def test_response_covariance_equals_the_per_calibrator_product(rng):
    """The clutter shape mapped once and scaled per calibrator equals K C_k K^H + noise for each calibrator."""
    cal = Calibrators.named(TRANSPONDERS, [25.0, 30.0, 35.0, 40.0], CLUTTER, -40.0)
    truth = _truth(rng, 50, 35.0, crosstalk_db=-20.0)
    kop = truth.operator()[:, None]
    expected = kop @ cal.clutter_covariances() @ np.conj(np.swapaxes(kop, -1, -2)) + cal.noise_to_signal * np.eye(4)
    np.testing.assert_allclose(response_covariance(cal, truth), expected, rtol=1e-12, atol=1e-18)


def test_min_crosstalk_gauge():
    """Noise-free: the minimum-norm member differs from the truth by eps ~ Re(d1 - d2 - d3 + d4)/4 along
    the gauge; the sums delta1 + delta3 and delta2 + delta4, which the sigma_hv error depends on, hold."""
    cal = Calibrators.named(TRANSPONDERS, 30.0, CLUTTER)
    truth = _truth(np.random.default_rng(3), 200, 40.0, crosstalk_db=-30.0)
    sol = solve_transponder(_noise_free(cal, truth), cal)
    d = truth.delta
    eps = np.real(d[:, 0] - d[:, 1] - d[:, 2] + d[:, 3]) / 4
    scale = np.sqrt(np.mean(np.abs(d) ** 2))
    assert np.max(np.abs(sol.omega - (truth.omega - eps))) < 0.05 * scale
    for i, j in ((0, 2), (1, 3)):
        assert np.max(np.abs((sol.delta[:, i] + sol.delta[:, j]) - (d[:, i] + d[:, j]))) < 0.05 * scale
    assert np.mean(np.sum(np.abs(sol.delta) ** 2, -1)) < np.mean(np.sum(np.abs(d) ** 2, -1))


def test_reciprocal_gauge_recovers_a_reciprocal_system():
    rng = np.random.default_rng(4)
    truth = _truth(rng, 50, 55.0)
    d = truth.delta.copy()
    d[:, 2], d[:, 3] = d[:, 0], d[:, 1]  # T = R^T
    f = np.stack([truth.f[:, 0], truth.f[:, 0]], -1)
    truth = SystemState(d, f, truth.omega, truth.gain)
    cal = Calibrators.named(PASSIVE, 30.0, CLUTTER)
    sol = solve_transponder(_noise_free(cal, truth), cal, "reciprocal")
    np.testing.assert_allclose(sol.omega, truth.omega, atol=1e-8)
    np.testing.assert_allclose(sol.delta, truth.delta, atol=1e-8)


@pytest.mark.parametrize("omega_deg", [0.0, 60.0])
def test_errors_match_the_cramer_rao_covariance(rng, omega_deg):
    """Validity: Gaussian clutter at SCR 30 dB, noise 40 dB below the calibrators, Omega known. The
    standardised errors of every parameter have mean 0 and variance 1, and chi2 has mean 8K - 14."""
    cal = Calibrators.named(TRANSPONDERS, 30.0, CLUTTER, -40.0)
    n = 3000
    truth = _truth(rng, n, omega_deg)
    sol = solve_transponder(
        calibrator_responses(rng, cal, truth), cal, "faraday_prior", faraday_prior=(truth.omega, 0.0)
    )
    est = np.concatenate([sol.delta, sol.f, sol.gain[:, None]], -1)
    true = np.concatenate([truth.delta, truth.f, truth.gain[:, None]], -1)
    sd = np.sqrt(np.real(np.diagonal(sol.covariance, axis1=-2, axis2=-1)) / 2)
    for part in (np.real, np.imag):
        z = part(est - true) / sd
        for i in range(7):
            assert abs(z_mean(z[:, i], 0.0)) < Z_ACCEPT
            assert abs(z_variance(z[:, i], 1.0)) < Z_ACCEPT
    assert abs(z_mean(sol.chi2, 8 * cal.count - 14)) < Z_ACCEPT


def test_min_crosstalk_faraday_error_follows_the_non_reciprocal_crosstalk(rng):
    """Calibrators at 60 dB SCR: the Omega error is the gauge offset, SD sqrt(V (1 - Re rho) / 8) for
    crosstalk of variance V with pair correlation rho (Men et al. 2021 statistics)."""
    model = biomass_system(crosstalk_db=-30.0, imbalance_db=-34.0, rho=0.9)
    n = 4000
    s = model.sample(rng, n)
    truth = SystemState(s.delta, s.f, np.full(n, np.radians(45.0)), s.gain.astype(complex))
    cal = Calibrators.named(TRANSPONDERS, 60.0, CLUTTER, -70.0)
    sol = solve_transponder(calibrator_responses(rng, cal, truth), cal)
    err = sol.omega - truth.omega
    assert abs(z_variance(err, model.crosstalk_level * (1 - 0.9) / 8)) < Z_ACCEPT


def test_bad_inputs_are_named():
    cal = Calibrators.named(TRANSPONDERS, 30.0, CLUTTER)
    y = np.zeros((4, 2, 2), complex)
    with pytest.raises(PhysicsInputError, match="gauge must be one of"):
        solve_transponder(y, cal, "smallest")
    with pytest.raises(PhysicsInputError, match="needs faraday_prior"):
        solve_transponder(y, cal, "faraday_prior")
    with pytest.raises(PhysicsInputError, match=r"responses must have shape \(\.\.\., 4, 2, 2\)"):
        solve_transponder(np.zeros((3, 2, 2)), cal)
    two = Calibrators.named(["trihedral", "dihedral_0"], 30.0, CLUTTER)
    with pytest.raises(PhysicsInputError, match="fewer than 3 independent scattering matrices"):
        solve_transponder(np.zeros((2, 2, 2)), two)


@pytest.mark.parametrize("names", [TRANSPONDERS, PASSIVE])
def test_start_angle_is_the_grid_angle_of_least_residual(rng, names):
    """The Gauss-Newton's start: the grid angle whose crosstalk-free model with the least-squares gain leaves the
    smallest residual, as a scan over the grid finds it (the solver scores every angle in one product)."""
    from e2esim.calibration.transponder import _START_ANGLES, _faraday_part, _start_angle
    from e2esim.polarimetry.system_model import to_vector

    cal = Calibrators.named(names, 30.0, CLUTTER, -40.0)
    truth = _truth(rng, 400, 0.0, crosstalk_db=-20.0)
    truth = SystemState(truth.delta, truth.f, rng.uniform(-np.pi, np.pi, 400), truth.gain)
    y = to_vector(calibrator_responses(rng, cal, truth))
    residuals = []
    for angle in _START_ANGLES:
        u = _faraday_part(angle, to_vector(cal.matrices))
        gain = np.sum(np.conj(u) * y, (-2, -1)) / np.sum(np.abs(u) ** 2)
        residuals.append(np.sum(np.abs(y - gain[:, None, None] * u) ** 2, (-2, -1)))
    best = np.argmin(residuals, 0)
    omega0, u0 = _start_angle(y, to_vector(cal.matrices), (400,))
    np.testing.assert_array_equal(omega0, _START_ANGLES[best])
    np.testing.assert_array_equal(u0, np.stack([_faraday_part(a, to_vector(cal.matrices)) for a in omega0]))


def test_covariance_is_the_inverse_of_the_information(rng):
    """The Cramer-Rao covariance (inverted when asked for) times the whitened normal matrix is the identity."""
    cal = Calibrators.named(TRANSPONDERS, 30.0, CLUTTER, -40.0)
    sol = solve_transponder(calibrator_responses(rng, cal, _truth(rng, 50, 10.0)), cal)
    np.testing.assert_allclose(sol.covariance @ sol.information, np.broadcast_to(np.eye(7), (50, 7, 7)), atol=1e-9)
