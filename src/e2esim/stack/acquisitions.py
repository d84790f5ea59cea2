"""The acquisition stack: N repeat passes over one site, each with its time, vertical wavenumber and incidence.

BIOMASS images a site 3 times, 3 days apart, in the interferometric phase, and 7 times in the tomographic
phase (Quegan et al. 2018, Section 2). After phase calibration and
ground steering a scatterer at height z above the terrain has the phase k_z,n z in image n (BPS AGB ATBD,
eq. 3.2), so what the stack needs from the geometry is each pass's vertical wavenumber relative to the first
pass. For repeat-pass (monostatic) geometry

    k_z = 4 pi B_perp / (lambda rho sin theta)                                   (ground-cancellation.md, eq. 1)

with B_perp the perpendicular baseline, rho the slant range and theta the incidence.

Presets (``PHASES``): the project found no published nominal BIOMASS k_z values. The presets are *inferred*
from the BioPAL prototype's configuration (github.com/BioPAL/BioPAL, ``biopal/_package_data/conf/
Configuration_File.xml``: the forest/non-forest classifier's ``max_vertical_wavenumber`` values 0.0432, 0.0869,
0.1294 and 0.1729 rad/m, multiples of about 0.0432 rad/m): a tomographic step of
0.0435 rad/m and an interferometric step of twice that (the BPS AGB ATBD, Section 3.2.4.1, takes every second
tomographic pass as "nominally consistent with" the interferometric baselines). They are assumptions:
give ``kz_rad_m`` or ``perpendicular_baselines_m`` for a study.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.ionosphere.constants import SPEED_OF_LIGHT

DAY_S = 86_400.0

TOMOGRAPHIC_KZ_STEP = 0.0435
"""rad/m: assumed elementary k_z step of the tomographic phase (inferred from the BioPAL configuration: module
docstring; low confidence)."""

PHASES = {
    # name: (passes, repeat interval in days, k_z step in rad/m between consecutive passes)
    "interferometric": (3, 3.0, 2 * TOMOGRAPHIC_KZ_STEP),  # Quegan et al. (2018), Section 2: 3 passes, 3-day repeat
    "tomographic": (7, 3.0, TOMOGRAPHIC_KZ_STEP),  # Quegan et al. (2018), Section 2: 7 passes, 3 days apart
}
"""Stack presets: number of passes and repeat interval (published), k_z step (assumed)."""


def vertical_wavenumber(perpendicular_baseline_m, wavelength_m, slant_range_m, incidence_rad):
    """k_z = 4 pi B_perp / (lambda rho sin theta) (rad/m), ground-cancellation.md eq. (1); broadcasts."""
    return 4 * np.pi * np.asarray(perpendicular_baseline_m, float) / (
        wavelength_m * np.asarray(slant_range_m, float) * np.sin(np.asarray(incidence_rad, float)))


@dataclass(frozen=True)
class AcquisitionStack:
    """N passes over one site.

    time_s : acquisition times relative to the first pass (s), shape (N,).
    kz_rad_m : vertical wavenumber of each pass relative to the first (rad/m), shape (N,); image n sees a
        scatterer at height z with the phase ``kz_rad_m[n] z`` after ground steering.
    incidence_rad : incidence of each pass (rad), shape (N,).
    label : e.g. "interferometric phase, 3 passes".
    """

    time_s: np.ndarray
    kz_rad_m: np.ndarray
    incidence_rad: np.ndarray
    label: str = "stack"

    def __post_init__(self):
        t, k, inc = (np.atleast_1d(np.asarray(x, float)) for x in (self.time_s, self.kz_rad_m, self.incidence_rad))
        if not (t.shape == k.shape == inc.shape) or t.ndim != 1 or t.size < 1:
            raise PhysicsInputError(f"a stack needs one time, k_z and incidence per pass, got shapes {t.shape}, "
                                    f"{k.shape}, {inc.shape}")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(k)) and np.all((inc > 0) & (inc < np.pi / 2))):
            raise PhysicsInputError("stack times and k_z must be finite and incidences between 0 and 90 deg")
        for name, value in (("time_s", t), ("kz_rad_m", k), ("incidence_rad", inc)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @property
    def passes(self) -> int:
        return int(self.time_s.size)

    def lag_s(self) -> np.ndarray:
        """|t_n - t_m| (s), shape (N, N)."""
        return np.abs(self.time_s[:, None] - self.time_s[None, :])

    def kz_difference(self) -> np.ndarray:
        """k_z,m - k_z,n (rad/m), shape (N, N): the wavenumber of the interferogram of passes m and n."""
        return self.kz_rad_m[:, None] - self.kz_rad_m[None, :]

    def scalars(self) -> dict:
        """Output scalars (``stack.*``): passes, span in days, the largest k_z difference (rad/m)."""
        return {"passes": float(self.passes), "span_days": float(np.ptp(self.time_s) / DAY_S),
                "kz_span_rad_m": float(np.ptp(self.kz_rad_m))}


def preset_stack(phase: str, incidence_rad: float, repeat_days: float | None = None,
                 kz_step_rad_m: float | None = None) -> AcquisitionStack:
    """The stack of a mission phase (``PHASES``) at one incidence, equally spaced in time and k_z."""
    if phase not in PHASES:
        raise PhysicsInputError(f"unknown stack phase {phase!r}; phases: {', '.join(PHASES)}")
    n, days, step = PHASES[phase]
    days = days if repeat_days is None else repeat_days
    step = step if kz_step_rad_m is None else kz_step_rad_m
    k = np.arange(n)
    return AcquisitionStack(k * days * DAY_S, k * step, np.full(n, incidence_rad), f"{phase} phase, {n} passes")


def radar_wavelength(frequency_hz: float) -> float:
    """lambda = c / f (m)."""
    return SPEED_OF_LIGHT / frequency_hz
