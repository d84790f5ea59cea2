"""The product this plug-in adds to e2esim's chain, declared the way e2esim declares its own."""

from __future__ import annotations

from dataclasses import dataclass

from e2esim.products import Product


@dataclass(frozen=True)
class Scintillation:
    """Amplitude scintillation seen by one backscatter estimate.

    s4 : scintillation index, the normalised SD of the intensity of one pattern (dimensionless).
    independent_patterns : N, independent scintillation patterns averaged into the estimate.
    The intensity factor of one pattern is Nakagami-m (gamma) distributed with m = 1/S4^2, mean 1 (Fremouw,
    Livingston & Miller 1980, J. Atmos. Terr. Phys. 42, 717-731); the mean of N independent ones is gamma
    with shape N/S4^2, mean 1 and variance ``variance = S4^2 / N``.
    """

    s4: float
    independent_patterns: int

    @property
    def variance(self) -> float:
        """Variance of the multiplicative intensity factor after averaging, S4^2 / N."""
        return self.s4**2 / self.independent_patterns

    def scalars(self) -> dict:
        return {"s4": self.s4, "independent_patterns": float(self.independent_patterns),
                "factor_variance": self.variance}


SCINTILLATION = Product(
    "ionosphere.scintillation", Scintillation,
    "amplitude scintillation of the case: S4 index and independent patterns per estimate", scalars="scintillation",
    units=(("s4|independent_patterns|factor_variance", "1"),))
