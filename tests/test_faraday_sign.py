"""Magnitude and sign of Faraday rotation, pinned against a cold magnetised plasma and the polarimetric
system model (Quegan et al. 2018, eqs. 1-3; e2esim.ionosphere.propagation).

The reference is independent of eq. (3): the Jones matrix of a wave crossing a slab of cold electron plasma
is computed from the dielectric tensor of the electron equation of motion, ``eps = I + i sigma/(eps0 w)``
with ``sigma = N e^2 (-i w m I - e [B]x)^-1`` (time dependence e^{-i w t}), propagated to first order in
the plasma frequency, ``E(L) = expm(i k0 L (eps_perp - I) / 2) E(0)``.
"""

import numpy as np
import pytest
from scipy import constants as sc
from scipy.linalg import expm

from e2esim.faraday.estimators import BickelBates
from e2esim.ionosphere.constants import FARADAY_CONSTANT, TECU
from e2esim.ionosphere.propagation import faraday_rotation
from e2esim.polarimetry.system_model import faraday_matrix, measured_matrix

F_BIOMASS = 435e6  # Hz, Quegan et al. (2018), Section 5


def _cross(b):
    return np.array([[0, -b[2], b[1]], [b[2], 0, -b[0]], [-b[1], b[0], 0]])


def plasma_jones(k_hat, h_hat, v_hat, b_field, density, length, frequency):
    """Jones matrix (in the basis h, v) of a plasma slab crossed along k_hat (cold electrons)."""
    w = 2 * np.pi * frequency
    sigma = density * sc.e**2 * np.linalg.inv(-1j * w * sc.m_e * np.eye(3) - sc.e * _cross(b_field))
    eps = np.eye(3) + 1j * sigma / (sc.epsilon_0 * w)
    basis = np.stack([h_hat, v_hat], 1)  # 3 x 2
    eps_perp = basis.T @ eps @ basis
    return expm(1j * (w / sc.c) * length * (eps_perp - np.eye(2)) / 2)


def rotation_angle(jones):
    """Omega of a Jones matrix proportional to F(Omega) = [[cos, sin], [-sin, cos]]."""
    r = jones / np.sqrt(np.linalg.det(jones))
    return float(np.arctan2(np.real(r[0, 1] - r[1, 0]) / 2, np.real(r[0, 0] + r[1, 1]) / 2))


def radar_basis(incidence_deg=30.0, azimuth_deg=-100.0):
    """Down-going look vector k and a basis with h x v = -k (h horizontal, v up and away from the radar)."""
    th, az = np.radians(incidence_deg), np.radians(azimuth_deg)
    k = np.array([np.sin(th) * np.sin(az), np.sin(th) * np.cos(az), -np.cos(th)])  # east, north, up
    h = np.cross(k, [0, 0, 1.0])
    h /= np.linalg.norm(h)
    v = np.cross(h, k)
    return k, h, v


def test_faraday_constant_and_biomass_magnitude():
    # K = e^3/(8 pi^2 eps0 m_e^2 c) = 2.365e4 SI (CODATA); 0.716 deg per TECU per 10 uT at 435 MHz
    assert FARADAY_CONSTANT == pytest.approx(2.365e4, rel=1e-3)
    deg = np.degrees(faraday_rotation(10e-6, TECU, F_BIOMASS))
    assert deg == pytest.approx(0.716, abs=5e-4)
    assert faraday_rotation(-10e-6, TECU, F_BIOMASS) == pytest.approx(-faraday_rotation(10e-6, TECU, F_BIOMASS))
    # 1/f^2: L-band (NISAR 1.257 GHz) rotates (435/1257)^2 as much
    ratio = faraday_rotation(1e-5, TECU, 1.257e9) / faraday_rotation(1e-5, TECU, F_BIOMASS)
    assert ratio == pytest.approx((435 / 1257) ** 2, rel=1e-12)


@pytest.mark.parametrize("b_along_k", [3.0e-5, -2.2e-5])
def test_sign_and_size_against_cold_plasma(b_along_k):
    k, h, v = radar_basis()
    assert np.allclose(np.cross(h, v), -k)
    b_perp = 2.0e-5 * h  # a transverse component must not matter to first order
    b = b_along_k * k + b_perp
    density, length = 1.0e12, 1.0e5  # 10 TECU
    expected = faraday_rotation(b @ k, density * length, F_BIOMASS)
    down = plasma_jones(k, h, v, b, density, length, F_BIOMASS)
    assert rotation_angle(down) == pytest.approx(expected, rel=5e-3)  # X, Y corrections ~ 3e-3
    assert np.allclose(down / np.sqrt(np.linalg.det(down)), faraday_matrix(expected), atol=5e-3)
    # the return leg (propagation along -k, same antenna basis) rotates the same way: M = F S F, not F S F^T
    up = plasma_jones(-k, h, v, b, density, length, F_BIOMASS)
    assert rotation_angle(up) == pytest.approx(expected, rel=5e-3)


def test_trihedral_through_faraday_gives_sin_two_omega_and_bickel_bates_recovers_plus_omega():
    omega = np.radians(np.array([-40.0, -7.0, 0.0, 12.5, 33.0]))
    m = measured_matrix(np.eye(2), np.zeros(4), np.ones(2), omega)  # M = F S F, trihedral S = I
    assert np.allclose(m[..., 0, 1], np.sin(2 * omega))  # M_vh (row h receive, column v transmit)
    assert np.allclose(m[..., 1, 0], -np.sin(2 * omega))
    assert np.allclose(BickelBates().from_matrices(m[:, None], axis=-1).omega, omega)
    # the often-quoted arg(Z12 Z21*)/4 has the opposite sign in this convention
    hh, vh, hv, vv = m[..., 0, 0], m[..., 0, 1], m[..., 1, 0], m[..., 1, 1]
    z12, z21 = vh - hv + 1j * (hh + vv), hv - vh + 1j * (hh + vv)  # off-diagonal entries of P M P
    assert np.allclose(np.angle(z12 * np.conj(z21)) / 4, -omega)
