"""How the co-polarised estimates treat Faraday rotation: not corrected, corrected perfectly, or corrected with
an estimate that leaves a residual rotation (co-pol sec. 4).

Correcting with an estimate W_hat of the rotation Omega gives (Quegan et al. 2018, eq. 4)

    F(-W_hat) M F(-W_hat) = [F(-W_hat) R F(W_hat)] F(dW) S F(dW) [F(W_hat) T F(-W_hat)],   dW = Omega - W_hat,

the raw model with rotated distortion matrices and the residual rotation dW. The symmetrised HV estimate is
unchanged by the correction for any W_hat (Men et al. 2021, eq. 2); the co-polarised ones are not. The
moments are averaged over (Omega, dW) with Omega from the geophysical distribution and dW independent of it
(the distribution ``CalibrationRecord.faraday_error()`` gives), on a product of the exact Fourier quadratures
of both (``FaradayDistribution.quadrature``). Every quantity is a trigonometric polynomial of degree <= 8 in dW;
in Omega too without a correction. With one, the rotated distortion terms F(-W_hat) R_i F(W_hat) carry harmonics
2 Omega (one error term) and 4 Omega (two): the mean and the covariance to O(V^2) stay within degree 8, the O(V^3)
and O(V^4) covariance terms and the spread of the conditional mean reach degree 16 (``CORRECTED_DEGREE``, co-pol
sec. 4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.faraday.distribution import FINE_QUADRATURE_DEGREE, QUADRATURE_DEGREE, ConstantFaraday, FaradayDistribution

MODES = ("none", "perfect", "estimated")
HV_UNCHANGED_BY_ROTATION = (
    "sigma_hv is estimated from the symmetrised (M_hv + M_vh)/2 of each image, which no rotation F(a) M F(a) of the "
    "data changes (Men et al. 2021, eq. 2; docs/theory/ground-cancellation.md, Section 3.3): a Faraday-rotation "
    "correction, and the error of its estimate, cannot change it")
"""Why an HV estimate ignores the settings of a Faraday-rotation correction (``Stage.insensitivity``)."""
CORRECTED_DEGREE = FINE_QUADRATURE_DEGREE  # 16: its rule is kept with the distribution
"""Highest harmonic in Omega of the exact covariance of corrected co-polarised channels (module docstring)."""


@dataclass(frozen=True)
class FaradayCorrection:
    """mode : "none" (the co-polarised channels are estimated from M as measured), "perfect" (rotated back by
    the true Omega) or "estimated" (rotated back by Omega - dW). residual : the distribution of dW = Omega -
    W_hat (rad) for "estimated"."""

    mode: str = "none"
    residual: FaradayDistribution | None = None

    def __post_init__(self):
        if self.mode not in MODES:
            raise PhysicsInputError(f"Faraday-rotation correction must be one of {MODES}, got {self.mode!r}")
        if (self.mode == "estimated") != (self.residual is not None):
            raise PhysicsInputError("an estimated correction needs the residual rotation dW (and only it does)")

    @property
    def corrects(self) -> bool:
        return self.mode != "none"

    def describe(self) -> str:
        if self.mode == "estimated":
            return f"Faraday rotation corrected by an estimate (residual {self.residual.describe()})"
        return {"none": "Faraday rotation not corrected", "perfect": "Faraday rotation corrected exactly"}[self.mode]

    def nodes(self, faraday: FaradayDistribution, corrected_degree: int = QUADRATURE_DEGREE) -> tuple:
        """(omega, omega_hat or None, weights), each (G,): nodes and weights that average a trigonometric
        polynomial of degree <= 8 in dW, and in Omega of degree <= 8 without a correction and <=
        ``corrected_degree`` with one, over the distributions exactly."""
        om, w = nodes_of(faraday, QUADRATURE_DEGREE if self.mode == "none" else corrected_degree)
        if self.mode == "none":
            return om, None, w
        if self.mode == "perfect":
            return om, om, w
        dw, v = nodes_of(self.residual)
        omega = np.repeat(om, dw.size)
        return omega, omega - np.tile(dw, om.size), np.outer(w, v).ravel()

    def estimate(self, rng: np.random.Generator, omega: np.ndarray) -> np.ndarray | None:
        """W_hat for Monte Carlo realisations of Omega (None when not corrected); dW drawn independently."""
        if self.mode == "none":
            return None
        if self.mode == "perfect":
            return np.asarray(omega, float)
        return np.asarray(omega, float) - self.residual.sample(rng, np.shape(omega))


def nodes_of(dist: FaradayDistribution, degree: int = QUADRATURE_DEGREE) -> tuple:
    """Quadrature nodes and weights of a distribution, exact to ``degree``; a single node for a constant
    rotation."""
    if isinstance(dist, ConstantFaraday):
        return np.array([float(dist.value)]), np.ones(1)
    return dist.quadrature(degree)
