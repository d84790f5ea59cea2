"""Temporal decorrelation between repeat passes.

Model (ground-cancellation.md, eq. 3): the volume's temporal coherence decays exponentially from 1 to a floor,

    gamma_v(dt) = gamma_inf + (1 - gamma_inf) exp(-dt / tau),

and the ground decorrelates a fraction r of the volume's loss, gamma_g(dt) = 1 - r (1 - gamma_v(dt)). The
ratio r is the BIOMASS processor's "ratio of temporal decorrelation between ground and volume" (0: the ground
does not decorrelate, 1: as the volume; BPS, github.com/BioPAL/BPS, ``xsd/biomass-xsd/bio-aux-pp2_2a.xsd``,
``temporalDecorrelationGroundToVolumeRatio``).
Temporal decorrelation of tropical forest at P-band is reported by the TropiScat tower experiment at Paracou
(Hamadi et al. 2014, IEEE TGRS 52(8); El Idrissi Essebtey et al. 2021, IEEE TGRS, doi:10.1109/TGRS.2021.3082395):
daily cycles in dry spells, perturbed by rain, depending on season, polarisation and the hour of acquisition.
Their numbers could not be read here, so the defaults below are **assumed** (gamma_v(3 days) = 0.91,
gamma_v(18 days) = 0.65): vary them in a study (the scenarios sweep gamma_inf).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError

DAY_S = 86_400.0

ASSUMED_FLOOR = 0.5
"""gamma_inf of the volume: assumed (no published P-band value could be read)."""
ASSUMED_TIME_CONSTANT_DAYS = 15.0
"""tau (days): assumed."""
ASSUMED_GROUND_RATIO = 0.0
"""r: assumed; the ground keeps its coherence (one end of the BPS processor's range)."""


@dataclass(frozen=True)
class TemporalDecorrelation:
    """Eq. (3): floor gamma_inf, time constant tau (s) and ground ratio r, each in [0, 1] (tau > 0)."""

    floor: float = ASSUMED_FLOOR
    time_constant_s: float = ASSUMED_TIME_CONSTANT_DAYS * DAY_S
    ground_ratio: float = ASSUMED_GROUND_RATIO

    def __post_init__(self):
        if not (0 <= self.floor <= 1 and self.time_constant_s > 0 and 0 <= self.ground_ratio <= 1):
            raise PhysicsInputError(f"temporal decorrelation needs a floor and ground ratio in [0, 1] and a time "
                                    f"constant > 0, got {self}")

    @classmethod
    def none(cls) -> TemporalDecorrelation:
        """No decorrelation: gamma_v = gamma_g = 1 at every lag."""
        return cls(floor=1.0, time_constant_s=DAY_S, ground_ratio=0.0)

    @property
    def is_none(self) -> bool:
        return self.floor == 1.0

    def volume(self, lag_s) -> np.ndarray:
        """gamma_v(|dt|), eq. (3)."""
        return self.floor + (1 - self.floor) * np.exp(-np.abs(np.asarray(lag_s, float)) / self.time_constant_s)

    def ground(self, lag_s) -> np.ndarray:
        """gamma_g(|dt|) = 1 - r (1 - gamma_v)."""
        return 1.0 - self.ground_ratio * (1.0 - self.volume(lag_s))
