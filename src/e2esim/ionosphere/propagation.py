"""Faraday rotation, phase advance and range delay of a radar wave crossing the ionosphere.

Pure kernels, SI units, vectorised over any broadcastable shapes. Quegan et al. (2018), Section 3.

Sign convention (docs/theory/ionosphere.md, pinned by tests/test_faraday_sign.py): ``k`` is the unit
propagation vector of the *down-going* (transmitted) wave, satellite to ground. The polarisation plane
rotates right-handedly about B (the sense of electron gyration) on both legs, so with the radar's h-v
basis satisfying ``h x v = -k`` (e.g. ``h = k x z / |k x z|``, ``v = h x k``, v pointing up and away
from the radar) the one-way Faraday matrix is ``F(Omega) = [[cos, sin], [-sin, cos]]`` of Quegan et al.
(2018), eq. (2), with ``Omega = +A B.k TEC / f^2`` (eq. 3), the same ``F`` on the way down and up
(``M = F S F``, eq. 1).
"""

from __future__ import annotations

import numpy as np

from e2esim.ionosphere.constants import (
    CHARGE_TO_MASS_OVER_C,
    FARADAY_CONSTANT,
    PHASE_CONSTANT,
    RANGE_DELAY_CONSTANT,
)


def faraday_rotation(b_dot_k, tec, frequency):
    """One-way Faraday rotation angle Omega (rad), Quegan et al. (2018), eq. (3).

    b_dot_k : B.k, component of the geomagnetic field along the down-going propagation direction (T).
    tec : (slant) total electron content along the path (electrons/m^2).
    frequency : radar frequency f (Hz).
    """
    return FARADAY_CONSTANT * np.asarray(b_dot_k) * np.asarray(tec) / np.asarray(frequency, dtype=float) ** 2


def faraday_rotation_integral(faraday_integral, frequency):
    """Omega (rad) from the path integral ``int N_e B.k ds`` (T electrons/m^2), eq. (3) without a mean B.k."""
    return FARADAY_CONSTANT * np.asarray(faraday_integral) / np.asarray(frequency, dtype=float) ** 2


def phase_advance(tec, frequency):
    """One-way ionospheric phase advance phi_d (rad), Quegan et al. (2018), eq. (7a): ``c r_e TEC / f``.

    tec : slant TEC (electrons/m^2); frequency : f (Hz).
    """
    return PHASE_CONSTANT * np.asarray(tec) / np.asarray(frequency, dtype=float)


def range_delay(tec, frequency):
    """Slant range delay r_sd (m), Quegan et al. (2018), eq. (7b): ``c^2 r_e TEC / (2 pi f^2)``.

    The extra apparent range of the two-way group delay (40.3 TEC / f^2). tec : slant TEC
    (electrons/m^2); frequency : f (Hz).
    """
    return RANGE_DELAY_CONSTANT * np.asarray(tec) / np.asarray(frequency, dtype=float) ** 2


def omega_over_range_delay(b_dot_k):
    """Omega / r_sd (rad/m), the frequency-independent ratio of Quegan et al. (2018), eq. (8).

    ``Omega / r_sd = (e / (m_e c)) B.k``; b_dot_k in T. (The paper's 586.3 is e/(m_e c) with c = 3e8 m/s;
    CODATA gives 586.68, docs/errata.md.)
    """
    return CHARGE_TO_MASS_OVER_C * np.asarray(b_dot_k)


def range_delay_from_faraday(omega, b_dot_k):
    """Slant range delay (m) estimated from a measured Faraday rotation, inverting eq. (8).

    omega : one-way Faraday rotation (rad); b_dot_k : B.k along the path (T), non-zero.
    """
    return np.asarray(omega) / omega_over_range_delay(b_dot_k)


def tec_from_faraday(omega, b_dot_k, frequency):
    """Slant TEC (electrons/m^2) from a measured Faraday rotation, inverting eq. (3)."""
    return np.asarray(omega) * np.asarray(frequency, dtype=float) ** 2 / (FARADAY_CONSTANT * np.asarray(b_dot_k))
