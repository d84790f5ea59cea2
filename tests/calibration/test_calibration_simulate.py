"""Simulated calibration data: Wishart windows, images and calibrator responses through the system model."""

from __future__ import annotations

import numpy as np
import pytest

from cal_helpers import Z_ACCEPT, biomass_system, forest, z_mean
from e2esim.calibration.targets import (
    Calibrators,
    calibrator_responses,
    dihedral,
    mean_response,
    response_covariance,
    target_matrix,
    transponder,
    trihedral,
)
from e2esim.errors import PhysicsInputError
from e2esim.polarimetry.simulate import (
    QuadPolImage,
    SystemState,
    complex_wishart,
    measured_covariance,
    reciprocal_covariance4,
    sample_measured_covariance,
    simulate_scene,
)
from e2esim.polarimetry.system_model import measured_matrix, to_matrix, to_vector

CLUTTER = np.array([[1.0, 0, 0.6], [0, 0.1, 0], [0.6, 0, 1.0]], dtype=complex)


def _state(rng, n=None, omega=0.4):
    s = biomass_system(crosstalk_db=-20, imbalance_db=-20).sample(rng, 1 if n is None else n)
    sl = 0 if n is None else slice(None)
    om = omega if n is None else np.full(n, omega)
    return SystemState(s.delta[sl], s.f[sl], om, (s.gain[sl] * np.exp(0.3j)))


def test_measured_covariance_is_the_system_model_applied_to_the_scene(rng):
    """<m m^H> = K C4 K^H + sigma_n I, with K the system model's response to the four unit matrices."""
    state = _state(rng)
    scene = forest("boreal_200")
    basis = np.stack([to_matrix(np.eye(4)[i]) for i in range(4)])
    k = to_vector(measured_matrix(basis, state.delta, state.f, state.omega, state.gain)).T  # columns K e_i
    expected = k @ reciprocal_covariance4(scene) @ k.conj().T + 0.01 * np.eye(4)
    np.testing.assert_allclose(measured_covariance(scene, state, 0.01), expected, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("looks", [2, 7, 50])
def test_wishart_sample_covariance_is_unbiased(rng, looks):
    """Each element of the Wishart draw has the population value as mean (Bartlett and small-L paths)."""
    state = _state(rng)
    cov = measured_covariance(forest("tropical_338"), state, 0.002)
    draws = complex_wishart(rng, np.broadcast_to(cov, (20_000, 4, 4)), looks)
    assert np.all(np.imag(np.diagonal(draws, axis1=1, axis2=2)) == 0)  # powers are real
    parts = [(0, 0, np.real), (1, 1, np.real)] + [(i, j, f) for i, j in [(0, 3), (1, 0), (2, 3)]
                                                   for f in (np.real, np.imag)]
    for i, j, part in parts:
        x = part(draws[:, i, j])
        assert np.std(x) > 0  # a draw that returned its input would have no spread
        assert abs(z_mean(x, part(cov[i, j]))) < Z_ACCEPT
        # Var(Re C_ij) = (C_ii C_jj + Re(C_ij^2)) / (2L) for a complex Wishart / L (Im: minus Re(C_ij^2));
        # on the diagonal Var(C_ii) = C_ii^2 / L
        sign = 1 if part is np.real else -1
        var = np.real(cov[i, i] * cov[j, j] + sign * cov[i, j] ** 2) / (2 * looks)
        assert abs(z_mean((x - part(cov[i, j])) ** 2, var)) < Z_ACCEPT


def test_wishart_variance_of_a_power(rng):
    """Var(C_hat_ii) = C_ii^2 / L for the diagonal of a complex Wishart / L."""
    cov = measured_covariance(forest(), _state(rng), 0.001)
    looks = 9
    draws = np.real(complex_wishart(rng, np.broadcast_to(cov, (40_000, 4, 4)), looks)[:, 0, 0])
    x = (draws - cov[0, 0].real) ** 2
    assert abs(z_mean(x, cov[0, 0].real ** 2 / looks)) < Z_ACCEPT


def test_image_pixels_have_the_measured_covariance(rng):
    state = _state(rng)
    scene = forest("boreal_50")
    img = simulate_scene(rng, scene, (200, 300), state, noise_power=0.005)
    m = img.vector().reshape(-1, 4)
    cov = measured_covariance(scene, state, 0.005)
    for i, j in [(0, 0), (3, 3), (1, 2), (0, 3)]:
        x = np.real(m[:, i] * np.conj(m[:, j]))
        assert abs(z_mean(x, cov[i, j].real)) < Z_ACCEPT


def test_sample_measured_covariance_batches_over_realisations(rng):
    state = _state(rng, n=5)
    out = sample_measured_covariance(rng, forest(), state, 0.001, 100)
    assert out.shape == (5, 4, 4)
    np.testing.assert_allclose(out, np.conj(np.swapaxes(out, -1, -2)))
    # each realisation's window is centred on its own measured covariance, with the spread of L = 100 looks
    one = _state(rng, n=1)
    cov = measured_covariance(forest(), one, 0.001)[0]
    many = sample_measured_covariance(rng, forest(), SystemState(*(np.repeat(getattr(one, f), 4000, axis=0)
                                                                    for f in ("delta", "f", "omega", "gain"))),
                                      0.001, 100)
    x = np.real(many[:, 1, 1])
    assert abs(z_mean(x, cov[1, 1].real)) < Z_ACCEPT
    assert abs(z_mean((x - cov[1, 1].real) ** 2, cov[1, 1].real ** 2 / 100)) < Z_ACCEPT


def test_canonical_calibrators():
    np.testing.assert_allclose(trihedral(), np.eye(2))
    np.testing.assert_allclose(dihedral(0.0), np.diag([1, -1]))
    np.testing.assert_allclose(dihedral(np.pi / 4), [[0, 1], [1, 0]], atol=1e-15)
    np.testing.assert_allclose(target_matrix("dihedral_22.5"), np.array([[1, 1], [1, -1]]) / np.sqrt(2))
    # transponder "hv": transmit h, receive v, the (row 1, column 0) element
    np.testing.assert_allclose(transponder("hv"), [[0, 0], [1, 0]])
    np.testing.assert_allclose(to_vector(transponder("vh")), [0, 0, 1, 0])


def test_calibrator_responses_mean_and_clutter_covariance(rng):
    """Responses are A R F S F T + clutter + noise: mean from the system model, covariance of the clutter
    scaled to the SCR through the system, plus noise."""
    cal = Calibrators.named(["trihedral", "transponder_hv"], [20.0, 25.0], CLUTTER, noise_to_signal_db=-30)
    state = _state(rng)
    n = 20_000
    batch = SystemState(*(np.broadcast_to(x, (n,) + np.shape(x)) for x in (state.delta, state.f)),
                        np.full(n, state.omega), np.full(n, state.gain))
    resp = to_vector(calibrator_responses(rng, cal, batch))  # (n, 2, 4)
    mean = mean_response(cal, state)  # (2, 4)
    cov = response_covariance(cal, state)  # (2, 4, 4)
    for k in range(2):
        for i in range(4):
            assert abs(z_mean(np.real(resp[:, k, i]), mean[k, i].real)) < Z_ACCEPT
            d = resp[:, k, i] - mean[k, i]
            assert abs(z_mean(np.abs(d) ** 2, cov[k, i, i].real)) < Z_ACCEPT
    # SCR: co-polarised clutter power over the (unit) peak power
    cc = cal.clutter_covariances()
    np.testing.assert_allclose(0.5 * (cc[0, 0, 0] + cc[0, 3, 3]).real, 10 ** (-20 / 10))


def test_bad_inputs_are_named():
    with pytest.raises(PhysicsInputError, match="unknown calibrator 'dihedral_x'"):
        target_matrix("dihedral_x")
    with pytest.raises(PhysicsInputError, match="transponder channel 'xx'"):
        transponder("xx")
    with pytest.raises(PhysicsInputError, match="clutter covariance must be 3x3"):
        Calibrators.named(["trihedral"], 30.0, np.eye(4))
    with pytest.raises(PhysicsInputError, match="one system realisation"):
        simulate_scene(np.random.default_rng(0), forest(), (4, 4), SystemState.ideal(np.zeros(3)))
    with pytest.raises(PhysicsInputError, match="same shape"):
        QuadPolImage(np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 3)), np.zeros((2, 2)))
    with pytest.raises(PhysicsInputError, match="looks must be >= 1"):
        sample_measured_covariance(np.random.default_rng(0), forest(), SystemState.ideal(), 0.0, 0)
