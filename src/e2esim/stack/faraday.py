"""Faraday rotation of every pass of a stack: a common value and day-to-day differences.

Model (ground-cancellation.md, eq. 6): pass n sees Omega_n = Omega_0 + Delta_n, where Omega_0 follows the
case's Faraday-rotation distribution (the climatology of the site, or a given distribution) and the
Delta_n are independent N(0, sigma_D^2 / 2), so that the difference between any two passes has SD sigma_D.
When sigma_D is not given it follows from the day-to-day variability of the TEC (``e2esim.ionosphere.
variability``): TEC_n = TEC_median X_n with ln X_n of SD s = sqrt(ln(1 + cv^2)) and correlation rho between
passes, so Omega_n - Omega_m ~ Omega (ln X_n - ln X_m) has SD

    sigma_D = Omega_rms s sqrt(2 (1 - rho)),  Omega_rms = sqrt(E[Omega_0^2])        (ground-cancellation.md, eq. 7)

The project found no published correlation rho of the day-to-day TEC deviations of passes 3 days apart: the
default rho = 0 (independent days) is an **assumption** and the worst
case; the scenarios sweep sigma_D directly. The small widening of each pass's marginal (variance of Omega_0
plus sigma_D^2 / 2) is accepted.

Averages over (Omega_0, Delta) split Delta into its mean over the passes, Delta_bar ~ N(0, sigma_D^2 / (2N)),
and the deviations from it, U zeta with U an orthonormal basis of the (N - 1)-dimensional subspace orthogonal to
(1, ..., 1) and zeta ~ N(0, sigma_D^2 / 2 I). Omega_0 + Delta_bar has the circular moments of Omega_0 times
exp(-k^2 sigma_D^2 / (4N)) (``ShiftedFaraday``), so its quadrature stays exact; zeta is averaged with a
cubature (``gaussian_cubature``): for up to 3 passes (1 or 2 dimensions) of degree 5 (the 3-point Gauss-Hermite
rule, Radon's 7-point rule), exact for every monomial of degree <= 5, so the neglected terms are O(sigma_D^6);
for more passes of degree 3 (+-sqrt(d) e_i, 2 d points), neglecting O(sigma_D^4) terms (the tests bound them
against the fully symmetric degree-5 rule). The moments of the error are smooth functions of zeta.

Each pass's co-polarised channels may be corrected with an *estimate* of its rotation, Omega_hat_n = Omega_n -
dW_n (a calibration section's ``faraday_correction`` step, docs/theory/ground-cancellation.md, Section 3.3): the
residual rotations dW_n are independent between the passes (each pass's estimate has its own window, speckle and
noise), of Omega and of the system errors, each distributed as ``residual`` (``CalibrationRecord.faraday_error()``,
as for one pass in ``e2esim.distortion.faraday_correction``). The Monte Carlo draws them from it; the analytic
moments average them with a cubature for a Gaussian of the residual's mean and SD (``residual_nodes``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.faraday.distribution import FaradayDistribution
from e2esim.faraday.estimators import AMBIGUITY_PERIOD


def gaussian_cubature(dim: int, degree: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Nodes (K, dim) and weights (K,) of a cubature rule for N(0, I_dim) of ``degree`` 3 or 5 (None: 5 up to
    2 dimensions, 3 above, the rule the stack uses).

    Degree 3: +-sqrt(d) e_i, weight 1 / (2 d) each.

    dim 2: Radon's rule, the origin (weight 1/2) and six points at radius 2 and angles k 60 deg (weight 1/12
    each); hexagonal symmetry integrates every harmonic below 6 exactly, and the radius and weights give
    E[r^2] = 2, E[r^4] = 8. Otherwise the fully symmetric rule: 0; +-sqrt(3) e_i; +-sqrt(3) e_i +- sqrt(3) e_j
    (i < j), weights 1 + (d^2 - 7 d)/18, (4 - d)/18 and 1/36, which give E[x_i^2] = 1, E[x_i^4] = 3,
    E[x_i^2 x_j^2] = 1 and every odd moment 0.
    """
    if dim == 0:
        return np.zeros((1, 0)), np.ones(1)
    degree = (5 if dim <= 2 else 3) if degree is None else degree
    if degree == 3:
        nodes = np.sqrt(dim) * np.vstack([np.eye(dim), -np.eye(dim)])
        return nodes, np.full(2 * dim, 1.0 / (2 * dim))
    if dim == 2:
        angle = np.arange(6) * np.pi / 3
        nodes = np.vstack([np.zeros((1, 2)), 2.0 * np.stack([np.cos(angle), np.sin(angle)], -1)])
        return nodes, np.concatenate([[0.5], np.full(6, 1.0 / 12.0)])
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
class ShiftedFaraday(FaradayDistribution):
    """Omega_0 + Delta_bar: a distribution plus an independent N(0, ``shift_sd``^2) (circular moments times
    exp(-k^2 shift_sd^2 / 2), so its quadrature is exact)."""

    base: FaradayDistribution
    shift_sd: float

    def circular_moment(self, k) -> np.ndarray:
        k = np.asarray(k, dtype=float)
        return self.base.circular_moment(k) * np.exp(-0.5 * (k * self.shift_sd) ** 2)

    def sample(self, rng, size) -> np.ndarray:
        return self.base.sample(rng, size) + self.shift_sd * rng.standard_normal(size)

    @property
    def mean_rad(self) -> float:
        return self.base.mean_rad

    @property
    def sd_rad(self) -> float:
        return float(np.hypot(self.base.sd_rad, self.shift_sd))


def deviation_basis(passes: int) -> np.ndarray:
    """U (N, N - 1): an orthonormal basis of the subspace orthogonal to (1, ..., 1)."""
    q, _ = np.linalg.qr(np.hstack([np.ones((passes, 1)), np.eye(passes)[:, : passes - 1]]))
    return q[:, 1:]


@dataclass(frozen=True, eq=False)
class StackFaraday:
    """Omega_n = Omega_0 + Delta_n (eq. 6): common distribution ``common`` and difference SD ``difference_sd``
    (rad, the SD of Omega_n - Omega_m)."""

    common: FaradayDistribution
    difference_sd: float = 0.0
    residual: FaradayDistribution | None = None
    """dW_n = Omega_n - Omega_hat_n of each pass's co-polarised correction (module docstring); None: corrected
    with the true rotation."""

    def __post_init__(self):
        if not (np.isfinite(self.difference_sd) and self.difference_sd >= 0):
            raise PhysicsInputError(f"the SD of the Faraday-rotation difference must be >= 0, got {self.difference_sd}")

    def nodes(self, passes: int, difference_sd: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(Omega (K, N) rad, weights (K,)) averaging smooth functions of (Omega_1..Omega_N) over eq. (6)."""
        sd = self.difference_sd if difference_sd is None else float(difference_sd)
        # computed at each call (the node terms that read them are kept: ``StackModelBase.node_terms``); a dict of
        # them kept here went with every ``dataclasses.replace`` copy, so a copy with another common rotation read
        # the nodes of this one
        omega, weights = self._make_nodes(passes, sd)
        omega.setflags(write=False)
        weights.setflags(write=False)
        return omega, weights

    def _make_nodes(self, passes: int, sd: float) -> tuple[np.ndarray, np.ndarray]:
        if sd == 0.0:
            base, w0 = self.common.quadrature()
            return np.repeat(base[:, None], passes, axis=1), np.asarray(w0)
        s = sd / np.sqrt(2.0)  # SD of each Delta_n
        base, w0 = ShiftedFaraday(self.common, s / np.sqrt(passes)).quadrature()
        u, wu = gaussian_cubature(passes - 1)
        dev = s * u @ deviation_basis(passes).T  # (K, N)
        omega = base[:, None, None] + dev[None, :, :]
        return omega.reshape(-1, passes), (np.asarray(w0)[:, None] * wu[None, :]).ravel()

    def sample(self, rng: np.random.Generator, realisations: int, passes: int) -> np.ndarray:
        """Omega of every pass, shape (M, N)."""
        common = self.common.sample(rng, realisations)
        delta = self.difference_sd / np.sqrt(2.0) * rng.standard_normal((realisations, passes))
        return common[:, None] + delta

    def corrections(self, rng: np.random.Generator, omega: np.ndarray) -> np.ndarray:
        """Omega_hat (M, N), the rotation each pass's co-polarised channels are corrected with: Omega itself, or
        Omega - dW with dW drawn from ``residual`` for every pass and realisation."""
        if self.residual is None:
            return omega
        return omega - self.residual.sample(rng, np.shape(omega))

    def residual_nodes(self, passes: int) -> tuple[np.ndarray, np.ndarray]:
        """(dW (J, N) rad, weights (J,)): a cubature (``gaussian_cubature``) for independent N(mu, s^2) per pass, mu
        and s the residual's mean and SD after its pi/2 ambiguity errors are taken out (``residual_moments``); one
        node at 0 without a residual. A residual enters HH and VV at second order and the spread of their
        conditional means at fourth, so the rule is of degree 5 (O(s^6) left out); above 4 passes, where that rule
        has negative weights, of degree 3, which leaves out the mixed terms dW_n^2 dW_m^2 of two passes: O(s^4), a
        part of about 5 s^2 (rad) of the bias the residual adds, and its spread (ground-cancellation.md, Section
        3.3)."""
        if self.residual is None:
            return np.zeros((1, passes)), np.ones(1)
        mu, sd, _ = residual_moments(self.residual)
        u, w = gaussian_cubature(passes, 5 if passes <= 4 else 3)
        return mu + sd * u, w


def residual_moments(residual: FaradayDistribution) -> tuple[float, float, float]:
    """(mean, SD, fraction of pi/2 ambiguity errors) of a residual rotation dW: its samples folded into
    (-pi/4, pi/4] (an estimate resolved on the wrong branch is off by a multiple of pi/2, which swaps HH and VV:
    the Monte Carlo draws those; the analytic moments describe the rest). A distribution without samples gives its
    own mean and SD."""
    samples = getattr(residual, "samples", None)
    if samples is None:
        return float(residual.mean_rad), float(residual.sd_rad), 0.0
    weights = residual.probabilities
    branch = np.round(samples / AMBIGUITY_PERIOD)
    wrong = branch != 0
    folded = samples - AMBIGUITY_PERIOD * branch
    mu = float(np.sum(weights * folded))
    sd = float(np.sqrt(max(np.sum(weights * (folded - mu) ** 2), 0.0)))
    return mu, sd, float(np.sum(weights[wrong]))
