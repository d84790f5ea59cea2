"""The calibration record of a block of cases that have no calibration section (``e2esim.block.Batched``).

Without calibration steps the record of a case says only what the propagation gets: the raw system and
Faraday rotation (``CalibrationRecord`` with no steps, not declared: it writes no outputs). The block keeps the
block's products and makes a case's record when asked (``item``), so a sweep of 200 000 Faraday rotations makes
no 200 000 records.
"""

from __future__ import annotations

from dataclasses import dataclass

from e2esim.block import Batched
from e2esim.calibration.record import CalibrationRecord


@dataclass(frozen=True, eq=False)
class UncalibratedBlock(Batched):
    """``CalibrationRecord``s of B cases without calibration steps: their system, Faraday-rotation and scene
    products (``Factor`` or ``Batched``; scene None when the chain has none)."""

    system: object
    faraday: object
    scene: object = None

    def __len__(self) -> int:
        return len(self.system)

    def item(self, i: int) -> CalibrationRecord:
        return CalibrationRecord(self.system.item(i), self.faraday.item(i),
                                 None if self.scene is None else self.scene.item(i), declared=False)
