"""Geomagnetic field models behind one interface, and the field component along a propagation path.

``FieldModel("igrf", epoch)`` is IGRF (through ppigrf's coefficients, ``e2esim.geomag.igrf``);
``FieldModel("dipole", epoch)`` the tilted centred dipole of that IGRF epoch (its n = 1 terms);
``FieldModel("aligned_dipole", epoch)`` a dipole of the same strength on the geographic axis; a given
``b0_tesla`` overrides the dipole strength. Positions are Earth-fixed (m, spherical Earth,
``e2esim.orbit.frames``); the field is returned in the same axes (T).
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.geomag.dipole import dipole_field_ecef, dipole_moment_vector
from e2esim.geomag.igrf import IGRF_MODELS, dipole_coefficients, igrf_geocentric, to_datetime
from e2esim.orbit.frames import enu_to_ecef, from_ecef

FIELD_KINDS = ("igrf", "dipole", "aligned_dipole")


@dataclass(frozen=True)
class FieldModel:
    """A geomagnetic field model at a fixed epoch.

    kind : "igrf", "dipole" (tilted centred dipole of IGRF at the epoch) or "aligned_dipole".
    epoch : date of the coefficients (ISO string or datetime); the secular variation over a mission
        year (about 0.1 % of B) is neglected.
    model : IGRF coefficient file, "IGRF14" or "IGRF13".
    b0_tesla : dipole strength |m| (T) for the dipole kinds; None takes it from IGRF at the epoch.
    """

    kind: str = "igrf"
    epoch: str = "2026-01-01"
    model: str = "IGRF14"
    b0_tesla: float | None = None

    def __post_init__(self):
        if self.kind not in FIELD_KINDS:
            raise PhysicsInputError(f"field kind {self.kind!r} is not one of {', '.join(FIELD_KINDS)}")
        if self.model not in IGRF_MODELS:
            raise PhysicsInputError(f"IGRF model {self.model!r} is not one of {', '.join(IGRF_MODELS)}")
        to_datetime(self.epoch)
        if self.b0_tesla is not None and not self.b0_tesla > 0:
            raise PhysicsInputError(f"b0_tesla must be > 0, got {self.b0_tesla}")

    @property
    def epoch_datetime(self) -> dt.datetime:
        return to_datetime(self.epoch)

    def moment(self) -> np.ndarray:
        """Dipole vector m (T, Earth-fixed axes) of the dipole kinds."""
        g10, g11, h11 = dipole_coefficients(self.epoch, self.model)
        m = dipole_moment_vector(g10, g11, h11, aligned=self.kind == "aligned_dipole")
        if self.b0_tesla is not None:
            m = m * (self.b0_tesla / np.linalg.norm(m))
        return m

    def ecef(self, position) -> np.ndarray:
        """Field B (T) at Earth-fixed positions (m), shape (..., 3)."""
        position = np.asarray(position, float)
        if self.kind != "igrf":
            return dipole_field_ecef(position, self.moment())
        lat, lon, r = from_ecef(position)
        br, bt, bp = igrf_geocentric(r, np.pi / 2 - lat, lon, self.epoch, self.model)
        return enu_to_ecef(np.stack([bp, -bt, br], -1), lat, lon)

    def b_dot_k(self, position, direction) -> np.ndarray:
        """B.k (T): field component along unit vectors ``direction`` (Earth-fixed) at ``position``."""
        return np.sum(self.ecef(position) * np.asarray(direction, float), -1)
