"""Recompute the published numbers of Quegan et al. (2018) (ids in ``e2esim.verification.published``).

Each function takes the ``Published`` record and returns ``(computed, tolerance or None, note)``.
"""

from __future__ import annotations

import functools
import re
from dataclasses import replace

from e2esim.ionosphere.constants import CHARGE_TO_MASS_OVER_C, FARADAY_CONSTANT, RANGE_DELAY_CONSTANT
from e2esim.ionosphere.geolocation import TABLE1_ASSUMPTIONS, excluded_zone


def omega_over_range_delay(record):
    """Eq. (8): Omega / r_sd = (e / m_e c) B.k, from CODATA constants; cross-checked as A / (c^2 r_e / 2 pi)
    (eqs. 3 and 7b)."""
    ratio = FARADAY_CONSTANT / RANGE_DELAY_CONSTANT
    note = (f"e/(m_e c) = {CHARGE_TO_MASS_OVER_C:.4f} (CODATA, scipy.constants); A/(c^2 r_e/2pi) from eqs. (3), (7b) = "
            f"{ratio:.4f}")
    return float(CHARGE_TO_MASS_OVER_C), None, note


@functools.lru_cache(maxsize=None)
def _zone(snr_db: int, looks: int, form: str) -> tuple:
    return excluded_zone(snr_db, looks, replace(TABLE1_ASSUMPTIONS, variance_form=form))


def table1_edge(record):
    """Table 1: edge of the excluded zone with the corrected Bickel-Bates variance under the assumption set
    ``TABLE1_ASSUMPTIONS`` (e2esim.ionosphere.geolocation)."""
    m = re.match(r"quegan2018\.table1\.snr(\d+)_L(\d+)\.(south|north)", record.id)
    snr, looks, side = int(m.group(1)), int(m.group(2)), m.group(3)
    i = 0 if side == "south" else 1
    value = _zone(snr, looks, "asymptotic")[i]
    printed = _zone(snr, looks, "printed")[i]
    a = TABLE1_ASSUMPTIONS
    note = (f"corrected eq. (5) (gamma^2); eq. (5) as printed gives {printed:.3f}. Assumptions: incidence "
            f"{a.incidence_deg:g} deg, B.k and latitude at a {a.pierce_height_m / 1e3:g} km pierce point, no Earth "
            f"rotation, aligned centred dipole B0 = {a.b0_tesla:g} T, z = {a.confidence_z:g} (99 %) on the "
            f"{a.requirement_m:g} m slant-range error")
    return float(value), None, note
