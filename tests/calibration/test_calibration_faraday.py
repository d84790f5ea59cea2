"""Faraday-rotation estimators: convention, ambiguity, variance against seed 003 eqs. (5)-(6), crosstalk bias."""

from __future__ import annotations

import numpy as np
import pytest

from cal_helpers import Z_ACCEPT, biomass_system, forest, z_mean, z_variance
from e2esim.calibration.quegan1994 import block_covariances
from e2esim.errors import PhysicsInputError
from e2esim.faraday.estimators import (
    BickelBates,
    FreemanSecondMoment,
    resolve_ambiguity,
    wrap_error,
)
from e2esim.faraday.theory import (
    ambiguity_error_probability,
    bickel_bates_bias,
    bickel_bates_bias_first_order,
    bickel_bates_limit,
    bickel_bates_snr,
    bickel_bates_variance,
    freeman_variance,
    phase_pdf,
    phase_variance,
)
from e2esim.polarimetry.simulate import SystemState, measured_covariance, sample_measured_covariance, simulate_scene

SCENE = forest("boreal_200")


def _noise_for_snr(scene, snr_db):
    """Per-channel noise power giving the eq. (6) SNR: <|S_hh + S_vv|^2> / (4 sigma_n)."""
    return bickel_bates_snr(scene, 1.0) / 10 ** (snr_db / 10)


@pytest.mark.parametrize("omega_deg", [-40.0, -7.0, 0.0, 3.0, 30.0, 44.0])
@pytest.mark.parametrize("estimator", [BickelBates(), FreemanSecondMoment()])
def test_noise_free_estimate_recovers_omega(estimator, omega_deg):
    """Convention pin (docs/conventions.md): M = F S F with F = [[c, s], [-s, c]] gives back +Omega."""
    omega = np.radians(omega_deg)
    cov = measured_covariance(SCENE, SystemState.ideal(omega))
    assert estimator.from_covariance(cov, 1).omega == pytest.approx(omega, abs=1e-12)


def test_pi_over_2_ambiguity_and_its_resolution():
    """Beyond +-45 deg the estimate folds back by pi/2; a prior within 45 deg picks the right branch."""
    omega = np.radians(60.0)
    raw = BickelBates().from_covariance(measured_covariance(SCENE, SystemState.ideal(omega)), 1).omega
    assert raw == pytest.approx(omega - np.pi / 2, abs=1e-12)
    assert resolve_ambiguity(raw, np.radians(20.0)) == pytest.approx(omega, abs=1e-12)
    assert resolve_ambiguity(raw, np.radians(100.0)) == pytest.approx(omega, abs=1e-12)
    assert resolve_ambiguity(raw, np.radians(10.0)) == pytest.approx(omega - np.pi / 2, abs=1e-12)


def test_ambiguity_error_probability_matches_simulation(rng):
    """Validity: Gaussian prior error; a wrong branch whenever |prior - Omega| > pi/4."""
    sd = np.radians(30.0)
    n = 200_000
    truth = rng.uniform(-1, 1, n)
    raw = wrap_error(truth)
    wrong = np.abs(resolve_ambiguity(raw, truth + sd * rng.standard_normal(n)) - truth) > 1e-9
    p = float(ambiguity_error_probability(sd))
    assert abs(z_mean(wrong.astype(float), p)) < Z_ACCEPT


def test_image_and_covariance_paths_agree(rng):
    state = SystemState(np.array([0.02, -0.01j, 0.015, 0.01]), np.array([1.02, 0.99j]), np.radians(12.0), 1.0)
    img = simulate_scene(rng, SCENE, (40, 60), state, noise_power=0.01)
    for est in (BickelBates(), FreemanSecondMoment(0.01)):
        by_image = est.estimate(img, window=(20, 30)).omega
        by_cov = est.from_covariance(block_covariances(img, (20, 30)), 600).omega
        np.testing.assert_allclose(by_image, by_cov, atol=1e-12)
        assert by_image.shape == (2, 2)


GRID = [(-3.0, 4), (-3.0, 100), (0.0, 16), (10.0, 4), (10.0, 100), (20.0, 16)]


@pytest.mark.parametrize("snr_db, looks", GRID)
def test_bickel_bates_variance_over_looks_and_snr(rng, snr_db, looks):
    """The simulated variance equals the exact multilook-phase variance / 16 at every SNR and L.

    Validity: reciprocal target, equal noise in the four channels, no system errors (eq. 6).
    """
    n = 30_000
    sigma_n = _noise_for_snr(SCENE, snr_db)
    omega = np.radians(17.0)
    cov = sample_measured_covariance(rng, SCENE, SystemState.ideal(np.full(n, omega)), sigma_n, looks)
    err = wrap_error(BickelBates().from_covariance(cov, looks).omega - omega)
    snr = bickel_bates_snr(SCENE, sigma_n)
    assert abs(z_variance(err, bickel_bates_variance(snr, looks, "exact"))) < Z_ACCEPT
    assert abs(z_mean(err, 0.0)) < Z_ACCEPT  # unbiased without system errors


def test_printed_eq5_understates_the_variance_by_gamma(rng):
    """Seed 003 eq. (5) has gamma where the Cramer-Rao bound has gamma^2 (docs/errata.md): at SNR = 0 dB
    (gamma = 1/2) and L = 100, where the asymptotic form is accurate, simulation rejects the printed
    variance by far more than sampling error and accepts the corrected one."""
    n, looks, snr_db = 30_000, 100, 0.0
    sigma_n = _noise_for_snr(SCENE, snr_db)
    cov = sample_measured_covariance(rng, SCENE, SystemState.ideal(np.zeros(n)), sigma_n, looks)
    err = wrap_error(BickelBates().from_covariance(cov, looks).omega)
    snr = bickel_bates_snr(SCENE, sigma_n)
    assert abs(z_variance(err, bickel_bates_variance(snr, looks, "asymptotic"))) < Z_ACCEPT + 2  # 3 % finite-L excess
    assert z_variance(err, bickel_bates_variance(snr, looks, "printed")) > 20
    ratio = bickel_bates_variance(snr, looks, "printed") / bickel_bates_variance(snr, looks, "asymptotic")
    assert ratio == pytest.approx(0.5)  # = gamma


def test_phase_density_reduces_to_the_single_look_form():
    """L = 1: p = (1 - r^2) / (2 pi (1 - b^2)) [1 + b (pi/2 + asin b) / sqrt(1 - b^2)], b = r cos psi."""
    psi = np.linspace(-np.pi, np.pi, 101)
    r = 0.8
    b = r * np.cos(psi)
    single = (1 - r**2) / (2 * np.pi * (1 - b**2)) * (1 + b * (np.pi / 2 + np.arcsin(b)) / np.sqrt(1 - b**2))
    np.testing.assert_allclose(phase_pdf(psi, 1, r), single, rtol=1e-12)
    for looks in (1, 5, 300):
        x = np.linspace(-np.pi, np.pi, 20001)
        assert np.trapezoid(phase_pdf(x, looks, 0.9), x) == pytest.approx(1.0, abs=1e-6)


def test_exact_variance_tends_to_the_asymptotic_form():
    for g in (0.3, 0.9, 0.999):  # excess ~ (1 + 0.6 (1 - g^2) / g^2) / L
        assert phase_variance(400, g) / phase_variance(400, g, "asymptotic") == pytest.approx(1, abs=0.02)
    assert phase_variance(4, 0.9) > 1.4 * phase_variance(4, 0.9, "asymptotic")  # small L: far above the bound


def test_crosstalk_bias_first_order_formula():
    """The first-order bias agrees with the exact large-window limit up to a remainder quadratic in the
    crosstalk: ten times less crosstalk, a hundred times less remainder."""
    rng = np.random.default_rng(1)
    s = biomass_system(crosstalk_db=-30.0, imbalance_db=-34.0).sample(rng, 200)
    omega = np.radians(25.0)
    remainders = []
    for scale in (1.0, 0.1):
        delta, f = s.delta * scale, 1 + (s.f - 1) * scale
        exact = bickel_bates_bias(SCENE, SystemState(delta, f, np.full(200, omega), np.ones(200)))
        first = bickel_bates_bias_first_order(SCENE, delta, f, omega)
        remainders.append(np.sqrt(np.mean((exact - first) ** 2)))
        assert np.sqrt(np.mean(first**2)) > 10 * remainders[-1]
    assert remainders[0] / remainders[1] > 50


def test_crosstalk_bias_is_a_sinusoid_in_the_crosstalk_phase():
    """Linear in (delta, delta*): b(phi) = A cos phi + B sin phi for delta = a e^{j phi} d, amplitude ~ a."""
    d = np.array([0.6, -0.3 + 0.5j, 0.2j, 0.4])
    f = np.ones(2, complex)
    phis = np.array([0.0, np.pi / 2, 1.1, 2.7, 4.0])

    def bias(phi, a):
        return bickel_bates_bias_first_order(SCENE, a * np.exp(1j * phi) * d, f, np.radians(10.0))

    b0, b90 = bias(0.0, 0.01), bias(np.pi / 2, 0.01)
    assert np.hypot(b0, b90) > 1e-4  # a bias that vanished would pass the checks below
    # the first-order bias is the exact bias (the estimator's limit) to first order in the crosstalk
    state = SystemState(0.01 * d[None], f[None], np.array([np.radians(10.0)]), np.ones(1, complex))
    exact = bickel_bates_bias(SCENE, state)
    assert float(exact[0]) == pytest.approx(b0, rel=0.05)
    for phi in phis:
        assert bias(phi, 0.01) == pytest.approx(b0 * np.cos(phi) + b90 * np.sin(phi), abs=1e-15)
    assert bias(1.1, 0.02) == pytest.approx(2 * bias(1.1, 0.01), rel=1e-12)


def test_finite_window_estimate_is_centred_on_the_large_window_limit(rng):
    """With system errors the estimator converges to arg(a^T C_M b*)/4, and at finite L it scatters
    symmetrically about it (z_a, z_b stay jointly circular Gaussian). Crosstalk -25 dB, L = 50."""
    n = 20_000
    s = biomass_system(crosstalk_db=-25.0, imbalance_db=-30.0).sample(rng, n)
    state = SystemState(s.delta, s.f, np.full(n, np.radians(35.0)), s.gain.astype(complex))
    limit = bickel_bates_limit(SCENE, state, 0.002)
    cov = sample_measured_covariance(rng, SCENE, state, 0.002, 50)
    err = wrap_error(BickelBates().from_covariance(cov, 50).omega - limit)
    assert abs(z_mean(err, 0.0)) < Z_ACCEPT
    assert np.std(limit - state.omega) > 5 * np.std(err) / np.sqrt(n)  # the bias itself is resolved


def test_freeman_noise_bias_and_its_subtraction():
    """Noise adds 2 sigma_n to both second moments: the estimate moves towards pi/8 unless subtracted."""
    omega = np.radians(5.0)
    sigma_n = _noise_for_snr(SCENE, 5.0)
    cov = measured_covariance(SCENE, SystemState.ideal(omega), sigma_n)
    biased = FreemanSecondMoment().from_covariance(cov, 1).omega
    corrected = FreemanSecondMoment(sigma_n).from_covariance(cov, 1).omega
    assert corrected == pytest.approx(omega, abs=1e-12)
    assert biased > omega + np.radians(1.0)
    assert BickelBates().from_covariance(cov, 1).omega == pytest.approx(omega, abs=1e-12)  # BB: no noise bias


def test_bad_inputs_are_named():
    with pytest.raises(PhysicsInputError, match="coherence must be in"):
        phase_variance(10, 1.5)
    with pytest.raises(PhysicsInputError, match="looks must be a positive integer"):
        phase_variance(0, 0.5)
    with pytest.raises(PhysicsInputError, match="form must be one of"):
        phase_variance(10, 0.5, "approximate")
    with pytest.raises(PhysicsInputError, match="noise_power must be a finite number >= 0"):
        FreemanSecondMoment(-1.0)
    with pytest.raises(PhysicsInputError, match="covariances must be 4x4"):
        BickelBates().from_covariance(np.eye(3), 1)
    img = simulate_scene(np.random.default_rng(0), SCENE, (4, 4), SystemState.ideal())
    with pytest.raises(PhysicsInputError, match="window must be two positive integers"):
        BickelBates().estimate(img, window=(0, 2))
    with pytest.raises(PhysicsInputError, match="larger than the image"):
        BickelBates().estimate(img, window=(8, 2))


@pytest.mark.parametrize("snr_db, omega_deg", [(10.0, 10.0), (20.0, 25.0), (10.0, 38.0)])
def test_freeman_variance_matches_simulation(rng, snr_db, omega_deg):
    """Validity: L = 1000 (delta-method regime), Omega away from 0 and 45 deg, noise subtracted. Freeman's
    SD is never below Bickel-Bates' (the better estimator, Rogers & Quegan 2014); they meet near 22.5 deg."""
    n, looks = 12_000, 1000
    sigma_n = _noise_for_snr(SCENE, snr_db)
    omega = np.radians(omega_deg)
    cov = sample_measured_covariance(rng, SCENE, SystemState.ideal(np.full(n, omega)), sigma_n, looks)
    err = FreemanSecondMoment(sigma_n).from_covariance(cov, looks).omega - omega
    predicted = freeman_variance(SCENE, sigma_n, omega, looks)
    assert abs(z_variance(err, predicted)) < Z_ACCEPT
    assert predicted >= 0.99 * bickel_bates_variance(bickel_bates_snr(SCENE, sigma_n), looks, "asymptotic")
