"""The radiometric consequences of scintillation as ``Effect``s of the error model (``e2esim.error_terms.effects``).

Each effect's level is CKL_LEVEL times a multiplier m of the climatology's C_kL (m = 1 as the climatology says; 0:
no irregularities): the structure function is linear in C_kL, so the residual phase Y ~ Gamma(k, m theta), the shift
and the Faraday-rotation spread scale as sqrt(m), and a requirement's level margin (``<source>.margin_db``) is
10 log10 of the factor by which the irregularities may strengthen before the requirement fails. The scale CKL_LEVEL
puts the climatology at -40 dB, inside the margins' search range (levels up to 1, so factors up to 10^4).
Per-acquisition parameters are tuples (n,) with the
acquisitions' probability weights ``weight``; the moments are those of the mixture (a random acquisition),
E[g] = sum w_i E_i[g], Var[g] = sum w_i (Var_i[g] + E_i[g]^2) - E[g]^2 (docs/theory/scintillation.md, eq. S18).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from e2esim.error_terms.effects import AddedPower, IntensityFactor

CKL_LEVEL = 1e-4
"""The level of a scintillation effect at the climatology's C_kL (module docstring)."""


def _arrays(*values):
    return tuple(np.asarray(v, dtype=float) for v in values)


def _mixture(weight, mean, second):
    """(E, Var) of the mixture from per-component means and second moments (..., n)."""
    m = np.sum(weight * mean, axis=-1)
    return m, np.sum(weight * second, axis=-1) - m * m


@dataclass(frozen=True)
class DistributedTargetFactor(IntensityFactor):
    """sigma0 of a distributed target over a product cell of length L_c through the screen (eq. S19). A phase-only
    screen conserves energy (Parseval), so what the cell loses is what its response moves out of it: the shift |X|
    (X ~ N(0, sigma_x^2), the fraction |X| rho_a / L_c of the cell's energy) and the part q of the incoherent halo
    1 - exp(-Y) that lands beyond the cell: a phase component of f cycles per aperture puts paired echoes f cells
    from the peak (Carrara, Goodman & Majewski 1995, Section 5.2), so q is the share of the phase spectrum beyond
    L_c / rho_a cells in the residual beyond 2 cells (``halo_share``). What comes in from the neighbours replaces a
    fraction 1 - c of it (c the contrast: 0 for a homogeneous forest, which is then exactly unbiased; 1 when the
    surroundings are dark, the upper bound), so

        g = 1 - c (a |X| + q (1 - exp(-Y))),  a = rho_a / L_c,
        E[g] = 1 - c (a sigma_x sqrt(2/pi) + q (1 - (1 + theta)^-k)),
        Var[g] = c^2 (a^2 sigma_x^2 (1 - 2/pi) + q^2 ((1 + 2 theta)^-k - (1 + theta)^-2k))

    (X and Y are independent: the tilt and the residual are orthogonal projections of a Gaussian phase; gamma Laplace
    transform E[exp(-sY)] = (1 + s theta)^-k)."""

    stacked_fields: ClassVar[dict] = {"weight": 1, "shape": 1, "scale": 1, "shift_sd_cells": 1, "halo_share": 1,
                                       "cell_fraction": 1, "contrast": 1}

    weight: tuple = ()
    shape: tuple = ()
    scale: tuple = ()
    shift_sd_cells: tuple = ()
    cell_fraction: float = 0.0  # a = rho_a / L_c
    halo_share: tuple = ()  # q per acquisition
    contrast: float = 1.0

    @property
    def active(self) -> bool:
        return self.level != 0.0 and self.contrast != 0.0

    def factor_moments(self, level):
        w, k, theta, sx, q = _arrays(self.weight, self.shape, self.scale, self.shift_sd_cells, self.halo_share)
        m = np.asarray(level, dtype=float)[..., None] / CKL_LEVEL
        a, c = self.cell_fraction, self.contrast
        sxm, thm = sx * np.sqrt(m), theta * m
        e1, e2 = (1.0 + thm) ** -k, (1.0 + 2.0 * thm) ** -k
        mean_f = a * sxm * math.sqrt(2.0 / math.pi) + q * (1.0 - e1)
        var_f = a * a * sxm * sxm * (1.0 - 2.0 / math.pi) + q * q * (e2 - e1 * e1)
        mean_g = 1.0 - c * mean_f
        return _mixture(w, mean_g, c * c * var_f + mean_g * mean_g)

    def factors(self, rng, shape):
        w, k, theta, sx, q = _arrays(self.weight, self.shape, self.scale, self.shift_sd_cells, self.halo_share)
        m = self.level / CKL_LEVEL
        sx, theta = sx * math.sqrt(m), theta * m
        pick = rng.choice(w.size, size=shape, p=w)
        x = sx[pick] * rng.standard_normal(shape)
        y = np.where(theta[pick] > 0.0, rng.gamma(k[pick], np.where(theta[pick] > 0.0, theta[pick], 1.0)), 0.0)
        return 1.0 - self.contrast * (self.cell_fraction * np.abs(x) + q[pick] * (1.0 - np.exp(-y)))


@dataclass(frozen=True)
class CalibratorFactor(IntensityFactor):
    """The gain error a point calibrator seen through the screen leaves (eq. S20). The gain is set from the peak
    power of n calibrator acquisitions; each peak is low by a factor rho_j = exp(-Z_j), so the calibrated sigma0 is
    multiplied by g = exp(mean_j Z_j). Z is the residual phase Y in weak scatter (the Marechal law of
    ``irf_analytic``) and the Monte Carlo's -ln(peak ratio) where an acquisition is not weak
    (``irf_monte_carlo.peak_log_loss``). With ln g normal of mean mu (the mixture mean of Z over the calibration
    site's acquisitions) and variance Var[Z] / n (central limit over the n calibrations),
    g is log-normal: E[g] = exp(mu + s^2 / 2), Var[g] = exp(2 mu + s^2)(exp(s^2) - 1) (Johnson, Kotz &
    Balakrishnan 1994, eq. 14.8a). At level m, mu -> m mu and s^2 -> m^2 s^2."""

    stacked_fields: ClassVar[dict] = {"mean_log": 0, "var_log": 0}

    mean_log: float = 0.0
    var_log: float = 0.0

    def factor_moments(self, level):
        m = np.asarray(level, dtype=float) / CKL_LEVEL
        mu, s2 = m * self.mean_log, m * m * self.var_log
        # far beyond the climatology (a margin's search) the gain error is astronomic, but kept finite (exponents
        # capped at 300) so that the bounds' arithmetic stays defined
        return (np.exp(np.minimum(mu + s2 / 2.0, 300.0)),
                np.exp(np.minimum(2.0 * mu + s2, 300.0)) * np.expm1(np.minimum(s2, 300.0)))

    def factors(self, rng, shape):
        m = self.level / CKL_LEVEL
        return np.exp(m * (self.mean_log + math.sqrt(self.var_log) * rng.standard_normal(shape)))


@dataclass(frozen=True)
class FaradayLeakage(AddedPower):
    """Co-polarised power leaking into HV through the spread of the Faraday rotation inside the estimation window
    (eq. S21). With the residual delta (zero mean, variance s^2 at level 1) of a pixel about its window's estimate,
    M_hv = S_hv + sin(2 delta) (S_hh + S_vv) / 2 (M = F S F with F of Quegan et al. 2018, eqs. 1-2, on a
    reflection-symmetric target), so HV gains the power

        N = E[sin^2(2 delta)] / 4 (sigma_hh + sigma_vv + 2 Re C_hhvv),   E[sin^2(2 delta)] = (1 - exp(-8 s^2)) / 2

    for a Gaussian delta, averaged over the acquisitions. It enters as ``AddedPower`` (speckled like the co-pol
    signal over the looks); the co-polarised channels change by a relative O(s^2), which is left out."""

    stacked_fields: ClassVar[dict] = {"scale": 1, "looks": 1, "weight": 1, "window_variance": 1,
                                       "copol_power": 0}

    weight: tuple = ()
    window_variance: tuple = ()
    copol_power: float = 0.0

    def _power(self, level, values):
        w, s2 = _arrays(self.weight, self.window_variance)
        m = np.asarray(level, dtype=float)[..., None] / CKL_LEVEL
        n = np.sum(w * 0.5 * (1.0 - np.exp(-8.0 * m * s2)), axis=-1) / 4.0 * self.copol_power
        return n[..., None] * np.asarray(self.scale, dtype=float) * np.ones_like(values)


__all__ = ["CKL_LEVEL", "CalibratorFactor", "DistributedTargetFactor", "FaradayLeakage"]
