"""The Bickel-Bates estimator: sign in e2esim's convention, and its variance (Quegan et al. 2018, eqs. 5-6)
checked by simulation. Statistical tests accept at z = 4 and hold for any seed."""

import numpy as np
import pytest

from e2esim.errors import PhysicsInputError
from e2esim.faraday.estimators import BickelBates
from e2esim.faraday.simulation import simulate_bickel_bates
from e2esim.faraday.theory import bickel_bates_coherence, bickel_bates_variance
from e2esim.polarimetry.system_model import measured_matrix

Z = 4.0


def test_noise_free_distributed_target_gives_exactly_omega():
    rng = np.random.default_rng(11)
    n = 50
    hh, hv, vv = (rng.standard_normal((3, n)) + 1j * rng.standard_normal((3, n)))
    s = np.stack([np.stack([hh, hv], -1), np.stack([hv, vv], -1)], -2)
    for omega in np.radians([-44.0, -10.0, 0.0, 3.0, 44.0]):
        m = measured_matrix(s, np.zeros(4), np.ones(2), np.full(n, omega))
        assert BickelBates().from_matrices(m, axis=0).omega == pytest.approx(omega, abs=1e-12)


def test_coherence_eq6():
    assert bickel_bates_coherence(10.0) == pytest.approx(10 / 11)
    g = 10 / 11
    assert bickel_bates_variance(10.0, 100, "printed") == pytest.approx((1 - g**2) / (16 * 2 * g * 100))
    assert bickel_bates_variance(10.0, 100, "asymptotic") == pytest.approx((1 - g**2) / (16 * 2 * g**2 * 100))


@pytest.mark.parametrize("snr_db, looks, trials", [(0.0, 256, 1500), (10.0, 128, 1500)])
def test_variance_is_the_corrected_eq5(rng, snr_db, looks, trials):
    omega = np.radians(15.0)
    est = simulate_bickel_bates(omega, 10 ** (snr_db / 10), looks, trials, rng, hhvv_correlation=0.4 + 0.2j)
    var = np.var(est, ddof=1)
    se = var * np.sqrt(2.0 / (trials - 1))  # standard error of a sample variance (near-Gaussian estimates)
    corrected = bickel_bates_variance(10 ** (snr_db / 10), looks, "asymptotic")
    printed = bickel_bates_variance(10 ** (snr_db / 10), looks, "printed")
    # unbiased: mean within z standard errors of +Omega
    assert abs(est.mean() - omega) < Z * np.sqrt(var / trials)
    # the Cramer-Rao form (gamma^2) is attained up to O(1/L) (about 1 % here), far inside z SE (~15 %)
    assert abs(var - corrected) < Z * se + 0.02 * corrected
    if snr_db == 0.0:  # gamma = 1/2: eq. (5) as printed is half the true variance, many SE away
        assert abs(var - printed) > 3 * Z * se


def test_simulation_rejects_bad_input():
    with pytest.raises(PhysicsInputError, match="SNR > 0"):
        simulate_bickel_bates(0.1, 0.0, 10, 10, np.random.default_rng(0))
