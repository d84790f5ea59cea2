"""Power-law relation between AGB and sigma_hv, Men et al. (2021), eqs. (15)-(16).

``B = A sigma_hv^p`` (eq. 15); a relative AGB error q corresponds to a relative sigma_hv error
``(1 + q)^(1/p) - 1`` (eq. 16). Exponents from Schlund et al. (2018) as quoted in Men et al. (2021),
Section III-D: p = 2.2 for boreal and 1.9 for tropical forest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError

BIOME_EXPONENTS = {"boreal": 2.2, "tropical": 1.9}
"""Power-law exponent p by biome, Men et al. (2021), Section III-D and Table III."""


def sigma_relative_error(agb_relative_error, exponent):
    """Relative sigma_hv error giving relative AGB error q: ``(1 + q)^(1/p) - 1``, eq. (16).

    agb_relative_error : q (dimensionless, > -1), any shape. exponent : p > 0.
    """
    q = np.asarray(agb_relative_error, dtype=float)
    if np.any(q <= -1):
        raise PhysicsInputError("a relative AGB error must be > -1 (AGB estimate > 0)")
    return (1.0 + q) ** (1.0 / exponent) - 1.0


def agb_relative_error(sigma_relative, exponent):
    """Relative AGB error from a relative sigma_hv error x: ``q = (1 + x)^p - 1`` (inverse of eq. 16).

    A sigma_hv estimate at or below zero (x <= -1, possible in the tails of a Gaussian model of the
    error, never in the simulated power) means an AGB estimate of zero: q = -1.
    """
    x = np.asarray(sigma_relative, dtype=float)
    return np.clip(1.0 + x, 0.0, None) ** exponent - 1.0


@dataclass(frozen=True)
class PowerLaw:
    """``AGB = coefficient * sigma^exponent`` (eq. 15); AGB in t/ha, sigma in m^2/m^2 (linear)."""

    coefficient: float
    exponent: float

    def __post_init__(self):
        if not (self.coefficient > 0 and self.exponent > 0):
            raise PhysicsInputError("power law needs coefficient > 0 and exponent > 0")

    def agb(self, sigma):
        """AGB (t/ha) from sigma_hv (m^2/m^2)."""
        return self.coefficient * np.clip(np.asarray(sigma, dtype=float), 0.0, None) ** self.exponent

    def sigma(self, agb):
        """sigma_hv (m^2/m^2) for an AGB (t/ha)."""
        return (np.asarray(agb, dtype=float) / self.coefficient) ** (1.0 / self.exponent)
