"""Conventions pinned by synthetic cases whose answer is known (docs/conventions.md)."""

import numpy as np
import pytest

from e2esim.polarimetry.system_model import (
    CHANNELS,
    ESTIMATOR_WEIGHTS,
    distortion_operator,
    faraday_matrix,
    measured_matrix,
    to_matrix,
    to_vector,
)
from e2esim.units import level_db_from_variance, variance_from_level_db

NO_DELTA = np.zeros(4)
UNIT_F = np.ones(2)


def test_scattering_vector_order_is_column_major_hh_hv_vh_vv():
    s = np.array([[1, 3], [2, 4]])  # rows receive, columns transmit: [[hh, vh], [hv, vv]]
    assert CHANNELS == ("hh", "hv", "vh", "vv")
    np.testing.assert_array_equal(to_vector(s), [1, 2, 3, 4])
    np.testing.assert_array_equal(to_matrix(to_vector(s)), s)


def test_hv_is_transmit_h_receive_v():
    # A scatterer that turns transmitted H into received V only: S_hv = 1 (row v = receive, column h = transmit).
    s = np.array([[0, 0], [1, 0]], dtype=complex)
    # Transmit crosstalk delta3 leaks the H transmission into the V channel (T = [[1, d3], [d4, f2]]):
    # the V-transmit column then sees delta3 * S_hv at (receive v, transmit v).
    m = measured_matrix(s, [0, 0, 0.1, 0], UNIT_F, 0.0)
    assert to_vector(m)[1] == pytest.approx(1.0)  # hv
    assert to_vector(m)[3] == pytest.approx(0.1)  # vv = S_hv * delta3: delta3 is on the transmit side
    # Receive crosstalk delta2 leaks received V into the H channel (R = [[1, d2], [d1, f1]]).
    m = measured_matrix(s, [0, 0.2, 0, 0], UNIT_F, 0.0)
    assert to_vector(m)[0] == pytest.approx(0.2)  # hh = delta2 * S_hv: delta2 is on the receive side


def test_faraday_sign_for_a_trihedral():
    # M = F S F with S = I and F = [[cos, sin], [-sin, cos]] is a rotation by 2 Omega:
    # M_vh = sin 2 Omega (row h, column v) and M_hv = -sin 2 Omega, for Omega > 0.
    omega = np.radians(10.0)
    m = measured_matrix(np.eye(2), NO_DELTA, UNIT_F, omega)
    assert m[0, 1].real == pytest.approx(np.sin(2 * omega))
    assert m[1, 0].real == pytest.approx(-np.sin(2 * omega))
    assert m[0, 0].real == pytest.approx(np.cos(2 * omega))
    np.testing.assert_allclose(faraday_matrix(omega), [[np.cos(omega), np.sin(omega)], [-np.sin(omega), np.cos(omega)]])


def test_hv_estimator_is_independent_of_faraday_rotation_for_reciprocal_targets():
    # Men et al. (2021), eq. (2): (M_hv + M_vh)/2 does not depend on Omega.
    s = np.array([[0.7 + 0.1j, 0.3 - 0.2j], [0.3 - 0.2j, -0.4 + 0.5j]])
    for omega in (0.0, 0.3, 1.2, -2.0):
        est = ESTIMATOR_WEIGHTS["hv"] @ to_vector(measured_matrix(s, NO_DELTA, UNIT_F, omega))
        assert est == pytest.approx(s[1, 0])


def test_operator_matches_matrix_product():
    rng = np.random.default_rng(1)
    delta = rng.normal(size=4) + 1j * rng.normal(size=4)
    f = 1 + 0.2 * (rng.normal(size=2) + 1j * rng.normal(size=2))
    s = rng.normal(size=(2, 2)) + 1j * rng.normal(size=(2, 2))
    np.testing.assert_allclose(to_vector(measured_matrix(s, delta, f, 0.4)),
                               distortion_operator(delta, f, 0.4) @ to_vector(s))


@pytest.mark.parametrize("level_db", [-40.0, -30.0, -20.5])
def test_three_sigma_amplitude_label(level_db):
    # Men et al. (2021), Section V-B: label 10 log10((3 sigma)^2) = 10 log10(9 V / 2); V = 2 sigma^2.
    v = variance_from_level_db(level_db, "three_sigma_amplitude")
    sigma = np.sqrt(v / 2)
    assert 10 * np.log10((3 * sigma) ** 2) == pytest.approx(level_db)
    assert level_db_from_variance(v, "three_sigma_amplitude") == pytest.approx(level_db)
    assert variance_from_level_db(level_db, "variance") == pytest.approx(10 ** (level_db / 10))


def test_three_sigma_label_exceedance_probability(rng):
    # The amplitude of a circular Gaussian error exceeds its 3-sigma label with probability exp(-4.5) (eq. 20).
    v = variance_from_level_db(-30.0, "three_sigma_amplitude")
    n = 400_000
    d = np.sqrt(v / 2) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    p = np.mean(np.abs(d) ** 2 > 10 ** (-3.0))
    expected = np.exp(-4.5)  # 0.01111
    assert abs(p - expected) < 4.5 * np.sqrt(expected * (1 - expected) / n)


def test_unknown_level_convention_is_rejected():
    with pytest.raises(ValueError, match="unknown level convention"):
        variance_from_level_db(-30, "peak")
