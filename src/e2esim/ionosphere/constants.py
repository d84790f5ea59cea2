"""Physical constants of ionospheric propagation, CODATA 2022 (Tiesinga et al., CODATA recommended values of
the fundamental physical constants, the values ``scipy.constants`` gives; tests/test_constants.py checks that
they agree), SI units. Written out rather than imported: ``scipy.constants`` costs a tenth of a second at
start-up.

Quegan et al. (2018), eq. (3): ``Omega = (A / f^2) B.k TEC`` with ``A = (c / 2 pi)(e / m_e) r_e``.
Since ``r_e = e^2 / (4 pi eps0 m_e c^2)`` this is ``A = e^3 / (8 pi^2 eps0 m_e^2 c)``, the usual
Faraday-rotation constant (about 2.365e4 in SI units: B in T, TEC in electrons/m^2, f in Hz, Omega in rad).
"""

from __future__ import annotations

import math

ELECTRON_CHARGE = 1.602176634e-19  # C, exact (SI definition)
ELECTRON_MASS = 9.1093837139e-31  # kg
SPEED_OF_LIGHT = 299792458.0  # m/s, exact (SI definition)
VACUUM_PERMITTIVITY = 8.8541878188e-12  # F/m
CLASSICAL_ELECTRON_RADIUS = 2.8179403205e-15  # m, r_e = e^2/(4 pi eps0 m_e c^2)

FARADAY_CONSTANT = ELECTRON_CHARGE**3 / (8 * math.pi**2 * VACUUM_PERMITTIVITY * ELECTRON_MASS**2 * SPEED_OF_LIGHT)
"""A of Quegan et al. (2018), eq. (3) = (c/2pi)(e/m_e) r_e = e^3/(8 pi^2 eps0 m_e^2 c):
rad Hz^2 per (T electrons/m^2), about 2.3648e4."""

RANGE_DELAY_CONSTANT = ELECTRON_CHARGE**2 / (8 * math.pi**2 * VACUUM_PERMITTIVITY * ELECTRON_MASS)
"""c^2 r_e / (2 pi) of Quegan et al. (2018), eq. (7b) = e^2/(8 pi^2 eps0 m_e): m Hz^2 per (electrons/m^2),
about 40.308 (the "40.3" of GNSS ionospheric delay)."""

PHASE_CONSTANT = SPEED_OF_LIGHT * CLASSICAL_ELECTRON_RADIUS
"""c r_e of Quegan et al. (2018), eq. (7a): rad Hz per (electrons/m^2), about 8.448e-7."""

CHARGE_TO_MASS_OVER_C = ELECTRON_CHARGE / (ELECTRON_MASS * SPEED_OF_LIGHT)
"""e/(m_e c) of Quegan et al. (2018), eq. (8): rad per metre of range delay per tesla of B.k, 586.679
with CODATA 2018 constants (the paper prints 586.3, which is what c = 3e8 m/s gives; docs/errata.md)."""

TECU = 1.0e16
"""One TEC unit: 1e16 electrons per square metre."""
