"""Centred-dipole geomagnetic field, axis-aligned or tilted.

A centred dipole with Gauss coefficients (g_1^0, g_1^1, h_1^1) has the potential
``V = a (a/r)^2 [g_1^0 cos(theta) + (g_1^1 cos(phi) + h_1^1 sin(phi)) sin(theta)]`` (the n = 1 terms of
the IGRF expansion, Schmidt semi-normalised), whose field is

    B(r) = (a / r)^3 [3 (m . r_hat) r_hat - m],   m = (g_1^1, h_1^1, g_1^0)  (Earth-fixed x, y, z).

``m`` points to the geomagnetic *south* pole in the northern hemisphere (g_1^0 < 0), so the field points
down in the north. |m| = B0 is the field at the dipole equator on the reference sphere r = a. The
axis-aligned dipole keeps the same B0 along the geographic axis, ``m = (0, 0, -B0)`` (the "centred
dipole" of Quegan et al. 2018, Section 6 and Table 1).
"""

from __future__ import annotations

import numpy as np

from e2esim.geomag.igrf import IGRF_REFERENCE_RADIUS
from e2esim.orbit.frames import ecef_to_enu, to_ecef


def dipole_moment_vector(g10: float, g11: float = 0.0, h11: float = 0.0, aligned: bool = False) -> np.ndarray:
    """Dipole vector m (T) in Earth-fixed axes from the Gauss coefficients (T).

    aligned : put the whole moment |m| on the geographic axis (axis-aligned dipole of the same strength).
    """
    m = np.array([g11, h11, g10], dtype=float)
    if aligned:
        return np.array([0.0, 0.0, -np.linalg.norm(m)])
    return m


def dipole_field_ecef(position, moment, reference_radius: float = IGRF_REFERENCE_RADIUS) -> np.ndarray:
    """Field B (T) of a centred dipole at Earth-fixed positions (m), shape (..., 3).

    moment : dipole vector m (T) from ``dipole_moment_vector``.
    """
    position = np.asarray(position, float)
    r = np.linalg.norm(position, axis=-1, keepdims=True)
    rhat = position / r
    m = np.asarray(moment, float)
    return (reference_radius / r) ** 3 * (3 * np.sum(m * rhat, -1, keepdims=True) * rhat - m)


def dipole_field_spherical(r, theta, phi, moment, reference_radius: float = IGRF_REFERENCE_RADIUS):
    """(B_r, B_theta, B_phi) (T, up/south/east) of a centred dipole at radius r (m), colatitude and
    longitude (rad), for comparison with the n = 1 terms of ``igrf_geocentric``."""
    lat = np.pi / 2 - np.asarray(theta, float)
    b = dipole_field_ecef(to_ecef(lat, phi, r), moment, reference_radius)
    enu = ecef_to_enu(b, lat, phi)
    return enu[..., 2], -enu[..., 1], enu[..., 0]
