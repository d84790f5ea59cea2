"""Distributed-target calibration, Quegan (1994): first-order recovery, its bias when HV is not small, the
iterated refinement, noise, and the need for negligible Faraday rotation (seed 003, Sect. 5.2)."""

from __future__ import annotations

import numpy as np
import pytest

from cal_helpers import Z_ACCEPT, biomass_system, forest, z_mean
from e2esim.calibration.quegan1994 import block_covariances, quegan_calibrate, quegan_ratios
from e2esim.errors import PhysicsInputError
from e2esim.polarimetry.simulate import SystemState, measured_covariance, sample_measured_covariance, simulate_scene
from e2esim.polarimetry.system_model import faraday_matrix


def _errors(rng, n, crosstalk_db=-40.0, imbalance_db=-34.0):
    s = biomass_system(crosstalk_db=crosstalk_db, imbalance_db=imbalance_db, rho=0.5).sample(rng, n)
    return s.delta, s.f


def _predicted_bias(scene, delta, f, cov):
    """First-order terms the algorithm neglects: C10 and C13 carry f1 sigma_hv (d2 + d4)* and
    f1 sigma_hv (d1 f2 + f1 d3)*, C20 and C23 the same with f2; u and z inherit them through the 2x2 solve."""
    d1, d2, d3, d4 = delta.T
    f1, f2 = f.T
    hv = scene.sigma_hv
    e10, e13 = f1 * hv * np.conj(d2 + d4), f1 * hv * np.conj(d1 * f2 + f1 * d3)
    e20, e23 = f2 * hv * np.conj(d2 + d4), f2 * hv * np.conj(d1 * f2 + f1 * d3)
    c00, c33, c30 = cov[:, 0, 0].real, cov[:, 3, 3].real, cov[:, 3, 0]
    den = c00 * c33 - np.abs(cov[:, 0, 3]) ** 2
    return (c33 * e10 - c30 * e13) / den, (c33 * e20 - c30 * e23) / den


@pytest.mark.parametrize("name", ["boreal_200", "tropical_338"])
def test_first_order_recovery_and_the_hv_bias(name):
    """Zero Faraday rotation, infinite window: u = delta1 and z = delta3 up to the predicted bias of order
    (sigma_hv / sigma_hh) x crosstalk, with a remainder of second order in the crosstalk."""
    rng = np.random.default_rng(11)
    scene = forest(name)
    delta, f = _errors(rng, 300)
    cov = measured_covariance(scene, SystemState(delta, f, np.zeros(300), np.ones(300)))
    r = quegan_ratios(cov)
    bias_u, bias_z = _predicted_bias(scene, delta, f, cov)
    for est, true, bias in ((r["u"], delta[:, 0], bias_u), (r["z"], delta[:, 2], bias_z)):
        remainder = est - true - bias
        assert np.sqrt(np.mean(np.abs(remainder) ** 2)) < 0.05 * np.sqrt(np.mean(np.abs(bias) ** 2))
    relative = np.sqrt(np.mean(np.abs(bias_u) ** 2) / np.mean(np.abs(delta) ** 2))
    assert 0.3 * scene.sigma_hv / scene.sigma_hh < relative < 3 * scene.sigma_hv / scene.sigma_hh
    # v = delta4 / f2, w = delta2 / f1 and alpha = f1 / f2 to first order as well
    assert np.max(np.abs(r["alpha"] - f[:, 0] / f[:, 1])) < 1e-3


@pytest.mark.parametrize("name, passes, factor", [("boreal_200", 4, 0.2), ("tropical_338", 10, 0.3)])
def test_iterations_remove_the_bias_geometrically(name, passes, factor):
    """The truth is a fixed point; each pass shrinks the error by roughly sigma_hv (1/sigma_hh + 1/sigma_vv)
    (0.38 boreal 200 t/ha, 0.71 tropical 338 t/ha: the biases of u, w feed back through delta2 + delta4 and
    delta1 + delta3)."""
    rng = np.random.default_rng(5)
    scene = forest(name)
    delta, f = _errors(rng, 200, crosstalk_db=-30.0)
    cov = measured_covariance(scene, SystemState(delta, f, np.zeros(200), np.ones(200)))
    err = [np.sqrt(np.mean(np.abs(quegan_calibrate(cov, it).delta - delta) ** 2)) for it in (1, 2, passes)]
    assert err[1] < err[0]
    assert err[2] < factor * err[0]


def test_finite_window_scatters_about_the_large_window_estimate(rng):
    """Validity: reflection symmetry, Gaussian speckle, L = 2000 looks, NESZ -27 dB (noise subtracted)."""
    scene = forest("boreal_200")
    delta, f = _errors(np.random.default_rng(2), 1, crosstalk_db=-30.0)
    n = 4000
    state = SystemState(np.repeat(delta, n, 0), np.repeat(f, n, 0), np.zeros(n), np.ones(n))
    sigma_n = 10 ** (-27 / 10)
    limit = quegan_calibrate(measured_covariance(scene, state, sigma_n)[:1], noise_power=sigma_n).delta[0]
    est = quegan_calibrate(sample_measured_covariance(rng, scene, state, sigma_n, 2000), noise_power=sigma_n).delta
    for i in range(4):
        assert abs(z_mean(np.real(est[:, i]), limit[i].real)) < Z_ACCEPT
        assert abs(z_mean(np.imag(est[:, i]), limit[i].imag)) < Z_ACCEPT


def test_noise_subtraction():
    """Noise inflates the co-polarised powers in the denominators; subtracting it restores the estimate."""
    scene = forest("boreal_200")
    delta, f = _errors(np.random.default_rng(4), 50)
    state = SystemState(delta, f, np.zeros(50), np.ones(50))
    sigma_n = 0.05
    clean = quegan_ratios(measured_covariance(scene, state))["u"]
    noisy = measured_covariance(scene, state, sigma_n)
    np.testing.assert_allclose(quegan_ratios(noisy, sigma_n)["u"], clean, rtol=1e-10)
    assert np.mean(np.abs(quegan_ratios(noisy)["u"])) < 0.95 * np.mean(np.abs(clean))


def _residual_rms(scene, delta, f, omega_deg, iterations=1):
    """RMS off-diagonal term of the corrected distortion R_hat^-1 R F(Omega) and F(Omega) T T_hat^-1."""
    n = len(delta)
    state = SystemState(delta, f, np.full(n, np.radians(omega_deg)), np.ones(n))
    q = quegan_calibrate(measured_covariance(scene, state), iterations)
    rot = faraday_matrix(state.omega)
    xr = np.linalg.inv(q.receive) @ _receive(delta, f) @ rot
    xt = rot @ _transmit(delta, f) @ np.linalg.inv(q.transmit)
    off = [xr[:, 1, 0] / xr[:, 0, 0], xr[:, 0, 1] / xr[:, 0, 0], xt[:, 0, 1] / xt[:, 0, 0], xt[:, 1, 0] / xt[:, 0, 0]]
    return float(np.sqrt(np.mean(np.abs(np.stack(off)) ** 2))), q


@pytest.mark.parametrize("omega_deg", [0.5, 1.0, 2.0])
def test_faraday_rotation_is_taken_for_crosstalk(omega_deg):
    """Seed 003 Sect. 5.2: small Faraday rotation and crosstalk give the same data. The estimates are the
    crosstalk of R F(Omega): delta1 - Omega and delta3 + Omega, so the crosstalk itself (e.g. to verify
    |delta| < -30 dB, amplitude 0.03) cannot be measured unless |Omega| is far below it."""
    scene = forest("boreal_200")
    delta, f = _errors(np.random.default_rng(6), 100, crosstalk_db=-30.0)
    _, q = _residual_rms(scene, delta, f, omega_deg)
    omega = np.radians(omega_deg)
    assert np.mean(np.real(q.u - delta[:, 0])) == pytest.approx(-omega, rel=0.05)
    assert np.mean(np.real(q.z - delta[:, 2])) == pytest.approx(omega, rel=0.05)


def test_correction_breaks_down_at_large_faraday_rotation():
    """As a correction the algorithm absorbs the rotation (the crosstalk of R F(Omega)) while it is small:
    a single pass up to about 10 deg, five passes up to 30 deg; beyond, the first-order solution fails
    (near 45 deg the rotation swaps the channels). Hence Faraday-rotation correction first, elsewhere than
    at the magnetic equator."""
    scene = forest("boreal_200")
    delta, f = _errors(np.random.default_rng(6), 100, crosstalk_db=-30.0)
    raw = np.sqrt(np.mean(np.abs(delta) ** 2))
    base = _residual_rms(scene, delta, f, 0.0)[0]
    assert base < 0.5 * raw  # the HV bias only
    assert _residual_rms(scene, delta, f, 5.0)[0] < 1.1 * base
    assert _residual_rms(scene, delta, f, 30.0)[0] > 10 * raw
    assert _residual_rms(scene, delta, f, 30.0, iterations=5)[0] < 0.1 * raw
    assert _residual_rms(scene, delta, f, 45.0, iterations=5)[0] > 1.0


def _receive(delta, f):
    one = np.ones(len(delta))
    return np.stack([np.stack([one, delta[:, 1]], -1), np.stack([delta[:, 0], f[:, 0]], -1)], -2)


def _transmit(delta, f):
    one = np.ones(len(delta))
    return np.stack([np.stack([one, delta[:, 2]], -1), np.stack([delta[:, 3], f[:, 1]], -1)], -2)


def test_block_covariances(rng):
    img = simulate_scene(rng, forest(), (6, 8), SystemState.ideal(0.1), 0.01)
    cov = block_covariances(img, (3, 4))
    m = img.vector()[:3, :4].reshape(-1, 4)
    np.testing.assert_allclose(cov[0, 0], m.T @ m.conj() / 12, rtol=1e-12)
    assert cov.shape == (2, 2, 4, 4)


def test_bad_inputs_are_named():
    with pytest.raises(PhysicsInputError, match="iterations must be a positive integer"):
        quegan_calibrate(np.eye(4), iterations=0)
    with pytest.raises(PhysicsInputError, match="covariances must be 4x4"):
        quegan_calibrate(np.eye(3))
