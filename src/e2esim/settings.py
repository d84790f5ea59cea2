"""The ``simulation`` section of a scenario as the chain sees it: what to compute and the Monte Carlo sizes."""

from __future__ import annotations

from dataclasses import dataclass

MODES = ("analytic", "montecarlo", "both")
SEED_MAX = 2**64 - 1
"""The largest root seed: numpy's SeedSequence takes any integer, but results.h5 stores the seed as an unsigned
64-bit integer (HDF5 has no larger one)."""


@dataclass(frozen=True)
class SimulationSettings:
    """The ``simulation`` section: what to compute and with which Monte Carlo sizes.

    mode : "analytic", "montecarlo" or "both".
    seed : root of every random draw (numpy SeedSequence); case i uses the child with spawn key (i,).
    looks : L, independent pixels averaged into one sigma estimate (Men et al. 2021, eq. 17).
    realisations : M, joint system-error and Faraday-rotation realisations.
    noise_realisations : N, noise realisations per system-error realisation.
    keep_samples : store the Monte Carlo error samples in results.h5.
    """

    mode: str = "both"
    seed: int = 0
    looks: int = 100_000
    realisations: int = 10_000
    noise_realisations: int = 1
    keep_samples: bool = True

    @property
    def analytic(self) -> bool:
        return self.mode in ("analytic", "both")

    @property
    def montecarlo(self) -> bool:
        return self.mode in ("montecarlo", "both")
