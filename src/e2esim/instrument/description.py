"""How an instrument states its specification: levels in dB with their convention, noise, frequency."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class InstrumentDescription:
    """How the instrument states its errors, for reports: levels in dB and their convention.

    crosstalk_db, imbalance_db : specified levels (dB) under ``convention``. nesz_db : NESZ (dB).
    centre_frequency_hz, bandwidth_hz : radar centre frequency and bandwidth (Hz). name : label.
    """

    name: str
    crosstalk_db: float
    imbalance_db: float
    convention: str
    nesz_db: float
    centre_frequency_hz: float
    bandwidth_hz: float

    def scalars(self) -> dict:
        """Output scalars (``instrument.*``): the stated levels (dB) and the centre frequency (Hz)."""
        return {"crosstalk_db": self.crosstalk_db, "channel_imbalance_db": self.imbalance_db,
                "nesz_db": self.nesz_db, "centre_frequency_hz": self.centre_frequency_hz}

    @property
    def level_convention(self) -> str:
        """The convention both levels share ("variance" when they differ, as for dB margins)."""
        return self.convention if self.convention != "mixed" else "variance"

    @property
    def states_levels(self) -> bool:
        return math.isfinite(self.crosstalk_db) and math.isfinite(self.imbalance_db)
