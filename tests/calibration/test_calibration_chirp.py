"""Faraday rotation from the chirp slope (seed 003, eq. 12): accuracy, crosstalk insensitivity, its limits."""

from __future__ import annotations

import numpy as np
import pytest

from cal_helpers import Z_ACCEPT, biomass_system, forest, z_mean, z_variance
from e2esim.errors import PhysicsInputError
from e2esim.faraday.chirp import (
    ChirpSlopeEstimator,
    chirp_omega0_sd,
    fit_slope,
    locate_zero_crossing,
    sample_subband_covariances,
)
from e2esim.faraday.theory import bickel_bates_bias, bickel_bates_limit, bickel_bates_snr
from e2esim.polarimetry.simulate import (
    SystemState,
    faraday_at_frequency,
    measured_covariance,
    simulate_chirp_scene,
)

F0, BW = 435e6, 6e6  # BIOMASS: Quegan et al. (2018) Sect. 5; WMO OSCAR "SAR-P"
SCENE = forest("boreal_200")
NOISE = 10 ** (-27 / 10)


def _population(state, est, delta_slope=None):
    """Sub-band population covariances (infinite looks): the estimator's large-window limit."""
    omega_k = faraday_at_frequency(state.omega, F0, est.frequencies)
    delta = np.broadcast_to(state.delta, (est.subbands, 4)).astype(complex)
    if delta_slope is not None:
        delta = delta + np.asarray(delta_slope)[None, :] * (est.frequencies - F0)[:, None]
    sub = SystemState(delta, np.broadcast_to(state.f, (est.subbands, 2)), omega_k, np.ones(est.subbands))
    return measured_covariance(SCENE, sub, NOISE)


def test_slope_recovers_omega0_without_errors():
    """Eq. (12) on noise-free sub-bands: Omega0 = -(f0/2) dOmega/df, exact up to the 1/f^2 curvature."""
    est = ChirpSlopeEstimator(F0, BW, 6)
    for omega0 in np.radians([-30.0, 0.5, 20.0, 70.0]):
        r = est.from_subband_covariances(_population(SystemState.ideal(omega0), est), 10**9)
        assert r.omega0 == pytest.approx(omega0, rel=2e-4, abs=1e-12)


def test_line_fit():
    freq = F0 + np.array([-2e6, 0.0, 2e6])
    omega0, slope, intercept, _ = fit_slope(0.1 - 1e-9 * (freq - F0), freq, F0)
    assert slope == pytest.approx(-1e-9)
    assert intercept == pytest.approx(0.1)
    assert omega0 == pytest.approx(0.5 * F0 * 1e-9)


@pytest.mark.parametrize("looks, subbands", [(40_000, 4), (400_000, 8)])
def test_slope_estimator_sd_matches_prediction(rng, looks, subbands):
    """Validity: independent speckle between sub-bands, per-band looks >= 100, no system errors."""
    est = ChirpSlopeEstimator(F0, BW, subbands)
    n = 8000
    omega0 = np.radians(8.0)
    covs, per_band = sample_subband_covariances(rng, SCENE, SystemState.ideal(np.full(n, omega0)), NOISE, looks, est)
    r = est.from_subband_covariances(covs, per_band)
    sd = chirp_omega0_sd(bickel_bates_snr(SCENE, NOISE), looks, est)
    assert abs(z_mean(r.omega0, omega0)) < Z_ACCEPT
    assert abs(z_variance(r.omega0, sd**2)) < Z_ACCEPT


def test_slope_sd_hardly_depends_on_the_number_of_subbands():
    snr = bickel_bates_snr(SCENE, NOISE)
    sds = [chirp_omega0_sd(snr, 10**6, ChirpSlopeEstimator(F0, BW, k), "asymptotic") for k in (2, 4, 16, 64)]
    # sqrt(3)/4 (f0/B) / sqrt(SNR L) times sqrt(K^2/(K^2-1)): within 16 % from 2 to 64 sub-bands
    assert max(sds) / min(sds) < 1.16
    assert sds[-1] == pytest.approx(np.sqrt(3) / 4 * F0 / BW / np.sqrt(snr * 1e6), rel=0.01)


def test_slope_is_almost_unaffected_by_constant_crosstalk():
    """Large-window limits at -20 dB crosstalk: the full-band Bickel-Bates estimate (the intercept) is biased
    by the crosstalk, the slope estimate of Omega0 by a fraction of Omega0 of the order of the crosstalk."""
    rng = np.random.default_rng(3)
    est = ChirpSlopeEstimator(F0, BW, 4)
    s = biomass_system(crosstalk_db=-20.0).sample(rng, 50)
    omega0 = np.radians(2.0)
    slope_err, bb_err = [], []
    for d, f in zip(s.delta, s.f):
        r = est.from_subband_covariances(_population(SystemState(d, f, omega0, 1.0), est), 10**9)
        slope_err.append(r.omega0 - omega0)
        bb_err.append(r.intercept - omega0)
    slope_err, bb_err = np.abs(slope_err), np.abs(bb_err)
    assert np.max(slope_err) < 0.05 * omega0
    assert np.median(bb_err) > 5 * np.median(slope_err)


def test_frequency_dependent_crosstalk_biases_the_slope():
    """The caveat of Sect. 5.2: crosstalk that changes across the band adds the slope of the Bickel-Bates
    bias, ``dOmega0 = -(f0/2) d(bias)/df``; a 10 % change of -30 dB crosstalk across the 6 MHz swamps a
    Faraday rotation of 1 deg (f0/B = 72.5 amplifies the bias change)."""
    est = ChirpSlopeEstimator(F0, BW, 4)
    delta = np.array([1, -1, 1j, -1j]) * 10 ** (-30 / 20)
    slope = 0.1 * delta / BW
    state = SystemState(delta, np.ones(2), np.radians(1.0), 1.0)
    flat = est.from_subband_covariances(_population(state, est), 10**9).omega0
    tilted = est.from_subband_covariances(_population(state, est, delta_slope=slope), 10**9).omega0
    f_k = est.frequencies
    bias = [bickel_bates_bias(SCENE, SystemState(delta + slope * (f - F0), np.ones(2),
                                                 np.radians(1.0) * (F0 / f) ** 2, 1.0), NOISE)
            for f in f_k]
    predicted = -0.5 * F0 * np.polyfit(f_k - F0, bias, 1)[0]
    assert tilted - flat == pytest.approx(predicted, rel=0.05)
    assert abs(tilted - np.radians(1.0)) > np.radians(1.0)
    assert abs(flat - np.radians(1.0)) < np.radians(0.02)


def test_image_path_on_a_simulated_chirp(rng):
    """Band built in the range-frequency domain with Omega(f) = Omega0 (f0/f)^2; slope from the FFT."""
    est = ChirpSlopeEstimator(F0, BW, 4)
    omega0 = np.radians(12.0)
    img = simulate_chirp_scene(rng, SCENE, (400, 512), SystemState.ideal(omega0), F0, BW, NOISE)
    r = est.estimate(img, window=(400, 512))
    sd = chirp_omega0_sd(bickel_bates_snr(SCENE, NOISE), 400 * 512, est)
    assert abs(float(r.omega0[0, 0]) - omega0) < Z_ACCEPT * sd
    assert abs(float(r.intercept[0, 0]) - omega0) < np.radians(0.5)


def test_bad_inputs_are_named():
    with pytest.raises(PhysicsInputError, match="subbands must be an integer >= 2"):
        ChirpSlopeEstimator(F0, BW, 1)
    with pytest.raises(PhysicsInputError, match="bandwidth < 2 x centre frequency"):
        ChirpSlopeEstimator(F0, -1.0)
    est = ChirpSlopeEstimator(F0, BW, 8)
    with pytest.raises(PhysicsInputError, match="cannot be shared among 8 sub-bands"):
        chirp_omega0_sd(10.0, 5, est)
    img = simulate_chirp_scene(np.random.default_rng(0), SCENE, (4, 8), SystemState.ideal(), F0, BW)
    with pytest.raises(PhysicsInputError, match="cannot be split into 8 sub-bands"):
        est.estimate(img)


def test_locating_the_zero_faraday_rotation_line(rng):
    """Sect. 5.2: along a track across the magnetic equator (Omega0 = g (lat - lat0)) the chirp-slope
    estimates give a zero crossing centred on lat0 with the predicted standard error, while the
    Bickel-Bates estimates, biased by crosstalk, put it at lat0 - bias / g."""
    est = ChirpSlopeEstimator(F0, BW, 4)
    lat = np.linspace(-3, 3, 31)
    lat0, g = 0.4, np.radians(0.8)
    d = biomass_system().sample(np.random.default_rng(8), 1)
    n = lat.size
    state = SystemState(np.repeat(d.delta, n, 0), np.repeat(d.f, n, 0), g * (lat - lat0), np.ones(n))
    looks = 2_000_000
    sd = chirp_omega0_sd(bickel_bates_snr(SCENE, NOISE), looks, est)
    x0, se = [], []
    for _ in range(150):
        covs, per = sample_subband_covariances(rng, SCENE, state, NOISE, looks, est)
        x, s = locate_zero_crossing(lat, est.from_subband_covariances(covs, per).omega0, sd)
        x0.append(x)
        se.append(s)
    assert abs(z_mean(x0, lat0)) < Z_ACCEPT
    assert abs(z_variance(x0, np.mean(se) ** 2)) < Z_ACCEPT
    bias0 = float(bickel_bates_bias(SCENE, SystemState(d.delta[0], d.f[0], 0.0, 1.0), NOISE))
    bb = bickel_bates_limit(SCENE, state, NOISE)
    assert locate_zero_crossing(lat, bb)[0] == pytest.approx(lat0 - bias0 / g, abs=0.02)
    assert abs(bias0 / g) > 3 * np.mean(se)  # the crosstalk shift is resolved


def test_zero_crossing_bad_input():
    with pytest.raises(PhysicsInputError, match="at least three"):
        locate_zero_crossing([0.0, 1.0], [0.1, 0.2])
    with pytest.raises(PhysicsInputError, match="zero slope"):
        locate_zero_crossing([0.0, 1.0, 2.0], [0.1, 0.1, 0.1], 0.01)
