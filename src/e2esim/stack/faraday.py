"""Faraday rotation of every pass of a stack: a common value and day-to-day differences.

Model (ground-cancellation.md, eq. 6): pass n sees Omega_n = Omega_0 + Delta_n, where Omega_0 follows the
case's Faraday-rotation distribution (the climatology of the site, or a given distribution) and the
Delta_n are independent N(0, sigma_D^2 / 2), so that the difference between any two passes has SD sigma_D.
When sigma_D is not given it follows from the day-to-day variability of the TEC (``e2esim.ionosphere.
variability``): TEC_n = TEC_median X_n with ln X_n of SD s = sqrt(ln(1 + cv^2)) and correlation rho between
passes, so Omega_n - Omega_m ~ Omega (ln X_n - ln X_m) has SD

    sigma_D = Omega_rms s sqrt(2 (1 - rho)),    Omega_rms = sqrt(E[Omega_0^2])            (ground-cancellation.md, eq. 7)

The correlation rho of the day-to-day TEC deviations of passes 3 days apart was not found in what could be
read (research notes Section 7): the default rho = 0 (independent days) is an **assumption** and the worst
case; the scenarios sweep sigma_D directly. The small widening of each pass's marginal (variance of Omega_0
plus sigma_D^2 / 2) is accepted.

Averages over (Omega_0, Delta) use the exact quadrature of Omega_0 (``FaradayDistribution.quadrature``) times
a fully symmetric degree-5 cubature for the N-dimensional Gaussian Delta (``gaussian_cubature``: 2 N^2 + 1
nodes, exact for every monomial of degree <= 5, which the tests check): the moments of the error are smooth functions of
Delta, so the neglected terms are O(sigma_D^6).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.faraday.distribution import FaradayDistribution


def gaussian_cubature(dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes (K, dim) and weights (K,) of the degree-5 fully symmetric rule for N(0, I_dim).

    Nodes: 0; +-sqrt(3) e_i; +-sqrt(3) e_i +- sqrt(3) e_j (i < j). Weights 1 + (d^2 - 7 d)/18, (4 - d)/18 and
    1/36, which give E[x_i^2] = 1, E[x_i^4] = 3, E[x_i^2 x_j^2] = 1 and every odd moment 0.
    """
    r = np.sqrt(3.0)
    nodes = [np.zeros(dim)]
    weights = [1.0 + (dim * dim - 7 * dim) / 18.0]
    eye = np.eye(dim)
    for i in range(dim):
        for s in (1.0, -1.0):
            nodes.append(s * r * eye[i])
            weights.append((4.0 - dim) / 18.0)
    for i in range(dim):
        for j in range(i + 1, dim):
            for si in (1.0, -1.0):
                for sj in (1.0, -1.0):
                    nodes.append(r * (si * eye[i] + sj * eye[j]))
                    weights.append(1.0 / 36.0)
    return np.array(nodes), np.array(weights)


def tec_difference_sd(omega_rms_rad: float, tec_variability: float, tec_correlation: float) -> float:
    """sigma_D of eq. (7) (rad) from the rms Faraday rotation, the TEC coefficient of variation and the
    correlation of the day-to-day deviations of two passes."""
    if tec_variability < 0 or not -1 <= tec_correlation <= 1:
        raise PhysicsInputError(f"TEC variability must be >= 0 and the correlation in [-1, 1], got "
                                f"{tec_variability}, {tec_correlation}")
    s = np.sqrt(np.log1p(tec_variability**2))
    return float(omega_rms_rad * s * np.sqrt(2.0 * (1.0 - tec_correlation)))


@dataclass(frozen=True, eq=False)
class StackFaraday:
    """Omega_n = Omega_0 + Delta_n (eq. 6): common distribution ``common`` and difference SD ``difference_sd``
    (rad, the SD of Omega_n - Omega_m)."""

    common: FaradayDistribution
    difference_sd: float = 0.0

    def __post_init__(self):
        if not (np.isfinite(self.difference_sd) and self.difference_sd >= 0):
            raise PhysicsInputError(f"the SD of the Faraday-rotation difference must be >= 0, got {self.difference_sd}")

    def nodes(self, passes: int, difference_sd: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(Omega (K, N) rad, weights (K,)) averaging smooth functions of (Omega_1..Omega_N) over eq. (6)."""
        sd = self.difference_sd if difference_sd is None else float(difference_sd)
        base, w0 = self.common.quadrature()
        if sd == 0.0:
            return np.repeat(base[:, None], passes, axis=1), np.asarray(w0)
        u, wu = gaussian_cubature(passes)
        omega = base[:, None, None] + sd / np.sqrt(2.0) * u[None, :, :]
        return omega.reshape(-1, passes), (np.asarray(w0)[:, None] * wu[None, :]).ravel()

    def sample(self, rng: np.random.Generator, realisations: int, passes: int) -> np.ndarray:
        """Omega of every pass, shape (M, N)."""
        common = self.common.sample(rng, realisations)
        delta = self.difference_sd / np.sqrt(2.0) * rng.standard_normal((realisations, passes))
        return common[:, None] + delta
