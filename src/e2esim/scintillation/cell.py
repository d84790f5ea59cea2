"""The acquisitions of a map cell without an orbit stage: what a map sweep gives a scintillation term.

A map sweep's chain has no ``geometry`` product (the global climatology looks each cell up instead), so a
scintillation term builds the acquisitions of a cell from its latitude, longitude, month and pass: the BIOMASS
dawn-dusk orbit sees it at 06 h (dawn) or 18 h (dusk) local time (the node times of the sun-synchronous orbit; mission
facts), on the 15th of the month, at the near, middle and far incidence of the swath (23 deg to 33.75 deg), equally
weighted; the pierce points are taken over the cell itself (within about 3 deg of it at 350 km). The fields are those
of ``e2esim.orbit.acquisition.AcquisitionGeometry`` that ``acquisitions.acquisition_screens`` reads.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from e2esim.orbit.frames import EARTH_MEAN_RADIUS

PASS_LOCAL_TIME_H = {"dawn": 6.0, "dusk": 18.0}
BIOMASS_INCIDENCE_DEG = (23.0, 28.375, 33.75)


@dataclass(frozen=True)
class CellOrbit:
    radius_m: float


@dataclass(frozen=True)
class CellAcquisitions:
    """Acquisitions of one cell (module docstring): arrays (n,); of several sites stacked, arrays (cases, n)
    (``e2esim.scintillation.stacked.stack_acquisitions``)."""

    orbit: CellOrbit
    pierce_lat: np.ndarray
    pierce_lon: np.ndarray
    incidence: np.ndarray
    local_time_h: np.ndarray
    time_utc: np.ndarray
    weight: np.ndarray


def cell_acquisitions(lat_deg: float, lon_deg: float, month: int, pass_name: str, year: int = 2026,
                      orbit_height_m: float = 666e3) -> CellAcquisitions:
    """The acquisitions of a cell on the 15th of ``month`` on the ``pass_name`` (dawn or dusk) pass."""
    n = len(BIOMASS_INCIDENCE_DEG)
    day = np.datetime64(f"{year:04d}-{month:02d}-15T00:00:00")
    return CellAcquisitions(CellOrbit(EARTH_MEAN_RADIUS + orbit_height_m), np.full(n, math.radians(lat_deg)),
                            np.full(n, math.radians(lon_deg)), np.radians(BIOMASS_INCIDENCE_DEG),
                            np.full(n, PASS_LOCAL_TIME_H[pass_name]), np.full(n, day), np.full(n, 1.0 / n))


__all__ = ["BIOMASS_INCIDENCE_DEG", "PASS_LOCAL_TIME_H", "CellAcquisitions", "CellOrbit", "cell_acquisitions"]
