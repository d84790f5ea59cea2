"""The closed-form azimuth response of a uniform aperture with a quadratic phase error (defocus).

For psi(u) = a u^2 on u in [-1/2, 1/2] (a residual quadratic phase of a linear FM; the edge phase error is a / 4),
completing the square gives (Carrara, Goodman & Majewski 1995, Spotlight SAR, Section 5.2; docs/theory/
scintillation.md, eq. S10)

    h(x) = integral exp(i (a u^2 + 2 pi x u)) du = sqrt(pi / (2 a)) exp(-i pi^2 x^2 / a) [F(t_2) - F(t_1)],
    t_{1,2} = sqrt(2 a / pi) (-/+ 1/2 + pi x / a),      F(t) = C(t) + i S(t) (Fresnel integrals),

so the peak (x = 0) is |h(0)|^2 = (2 pi / a) |F(sqrt(a / (2 pi)))|^2 of the unit peak of a = 0, and the 3-dB width
follows by root finding on |h(x)|^2 (``defocus_width``). |h| does not depend on the sign of a.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.special import fresnel


def defocus_intensity(x, a):
    """|h(x)|^2 of eq. S10, 1 at x = 0 for a = 0 (x in resolution cells, a in rad)."""
    a = abs(float(a))
    x = np.asarray(x, dtype=float)
    if a < 1e-9:
        return np.sinc(x) ** 2
    scale = math.sqrt(2.0 * a / math.pi)
    s2, c2 = fresnel(scale * (0.5 + math.pi * x / a))
    s1, c1 = fresnel(scale * (-0.5 + math.pi * x / a))
    return math.pi / (2.0 * a) * ((c2 - c1) ** 2 + (s2 - s1) ** 2)


def defocus_peak(a) -> float:
    """Peak intensity ratio |h(0)|^2 of eq. S10."""
    return float(defocus_intensity(0.0, a))


def defocus_width(a) -> float:
    """3-dB width (resolution cells) of |h|^2 of eq. S10 (the response stays symmetric about x = 0)."""
    half = 0.5 * defocus_peak(a)
    from scipy.optimize import brentq  # here: scipy.optimize costs every e2esim process a fifth of a second

    return 2.0 * brentq(lambda x: float(defocus_intensity(x, a)) - half, 1e-6, 20.0)


@functools.lru_cache(maxsize=1)
def width_table() -> tuple:
    """(a, 3-dB width / width at a = 0) on 0 <= a <= 12 rad: a constant of the uniform aperture."""
    grid = np.linspace(0.0, 12.0, 241)
    widths = np.array([defocus_width(a) for a in grid])
    return grid, widths / widths[0]


def broadening(a):
    """3-dB width ratio of eq. S10 at quadratic coefficients |a| (broadcasts; held at the table's end beyond it)."""
    grid, ratio = width_table()
    return np.interp(np.abs(a), grid, ratio)


__all__ = ["broadening", "defocus_intensity", "defocus_peak", "defocus_width", "width_table"]
