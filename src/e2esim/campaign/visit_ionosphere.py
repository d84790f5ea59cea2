"""The ionosphere at each visit of a calibration site (issue 25, items 2 and 3; docs/theory/calibration-campaign.md).

Faraday rotation (item 2). At each visit the line of sight from the site to the satellite (its Earth-fixed position
at the visit's instant, ``visibility.satellite_state``) crosses the thin shell at the pierce point; the IRI electron
density there (PyIRI monthly median of the visit's month, at its UT and the campaign's F10.7) and the IGRF field
give the path integral F = int N_e B.k ds and Omega = A F / f^2 (Quegan et al. 2018, eq. 3) through the climatology
code of e2esim (``e2esim.ionosphere.slant.path_integrals``, thin shell; ``faraday_rotation_integral``). The visit
corrects it with the Bickel-Bates estimate (Quegan et al. 2018, eqs. 4-6; ``e2esim.faraday.theory.
bickel_bates_variance``) at the visit's SNR and looks (a point target: its 1/c = 1/SNR + 1/SCR, no speckle),
resolving the pi/2 ambiguity with the climatology as prior: the prior's
error is the day-to-day TEC variability, SD v |Omega| (v the coefficient of variation, Rishbeth & Mendillo 2001), and
a wrong branch leaves an error of pi/2 (``ambiguity_error_probability``). The residual variance of the correction is

    s_F^2 = Var_BB(SNR, L) + P_amb(v |Omega|, sqrt(Var_BB)) (pi/2)^2 + s_W^2,

s_W^2 the scintillation spread of Omega inside the estimation window (below).

Scintillation (item 3). The screen of the visit (``e2esim.scintillation.acquisitions.acquisition_screens``: C_kL of
the climatology at the pierce point's geomagnetic latitude, the visit's local time and day of year and the
campaign's sunspot number; the aperture of the visit's incidence) gives

* the peak-power loss of a point target, Z = -ln(peak ratio), with its moments E[Z], E[Z^2] from the weak-scatter
  gamma law of the residual phase, or the Monte Carlo of the compression where the scatter is strong
  (``irf_monte_carlo.peak_log_loss``). The visit cannot tell the loss from a gain change, so it adds its mean
  square (10/ln 10)^2 E[Z^2] (dB^2) to the point target's gain variance. The loss is common to the four channels
  (a phase screen is polarisation-blind), so the crosstalk and imbalance ratios keep it out. A distributed target's
  mean intensity over a homogeneous site is unbiased through a phase-only screen (energy is conserved, contrast 0,
  ``scintillation.effects.DistributedTargetFactor``): no term;
* the spread of Omega within the estimation window, s_W^2 of ``faraday_window.window_variance`` (eq. S23), with
  the parallel field at the pierce point (``faraday_window.parallel_field``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from e2esim.calibration.radiometric import DB_PER_NEPER_POWER
from e2esim.campaign.sites import CalibrationSite
from e2esim.campaign.visibility import SiteVisits, satellite_state
from e2esim.campaign.visits import POINT_TYPES, visit_snr
from e2esim.faraday.theory import ambiguity_error_probability, bickel_bates_variance
from e2esim.geomag.field import FieldModel
from e2esim.ionosphere.propagation import faraday_rotation_integral
from e2esim.ionosphere.slant import SlantSettings, path_integrals, pierce_point_lat_lon
from e2esim.orbit.frames import EARTH_MEAN_RADIUS, to_ecef
from e2esim.scintillation.acquisitions import ScreenSettings, acquisition_screens
from e2esim.scintillation.climatology import SOLAR_PRESETS as SOLAR_SUNSPOTS
from e2esim.scintillation.faraday_window import parallel_field, window_variance
from e2esim.scintillation.irf_monte_carlo import peak_log_loss

EXACT_LOOKS = 300
SOLAR_F107 = {"min": 70.0, "max": 180.0}
"""F10.7 (sfu) of the solar-activity presets, those of the ``iri_climatology`` module (NOAA SWPC cycles 23-25)."""


@dataclass(frozen=True)
class VisitIonosphereSettings:
    """What the ionosphere of the visits depends on besides their geometry (SI)."""

    start_date: str
    """The mission's day 0 (ISO date, 00:00 UTC): the visits' dates and months."""
    f107_sfu: float
    """Solar flux F10.7 of the campaign's epoch (IRI)."""
    sunspot_number: float
    """12-month sunspot number of the same epoch (scintillation climatology)."""
    frequency_hz: float
    """The radar's centre frequency."""
    shell_height_m: float = 350e3
    """Pierce-point and screen height."""
    tec_variability: float = 0.25
    """Day-to-day coefficient of variation of TEC: the prior that resolves the pi/2 ambiguity."""
    window_m: float = 2e3
    """Side of the Faraday-rotation estimation window on the ground."""
    scintillation: bool = True
    """False leaves scintillation out (its terms 0)."""
    seed: int = 0
    """Seed of the strong-scatter Monte Carlo of a point target's peak loss."""


@dataclass(frozen=True)
class VisitGeometry:
    """What the scintillation code reads of an acquisition geometry, for the visits of one site (arrays (n,))."""

    orbit: object
    target_ecef: np.ndarray
    satellite_ecef: np.ndarray
    incidence: np.ndarray
    pierce_lat: np.ndarray
    pierce_lon: np.ndarray
    local_time_h: np.ndarray
    time_utc: np.ndarray
    weight: np.ndarray


@dataclass(frozen=True)
class VisitIonosphere:
    """Per visit (arrays (n,)): omega (rad) from the climatology; the Faraday residual's parts (rad^2):
    estimator, ambiguity, window (scintillation), and their sum ``faraday_variance``; log10 C_kL of the screen;
    ``peak_loss_variance_db2``, the point target's scintillation gain term (dB^2; 0 for a distributed target)."""

    omega: np.ndarray
    estimator: np.ndarray
    ambiguity: np.ndarray
    window: np.ndarray
    log10_ckl: np.ndarray
    peak_loss_variance_db2: np.ndarray

    @property
    def faraday_variance(self) -> np.ndarray:
        return self.estimator + self.ambiguity + self.window


def visit_geometry(orbit, site: CalibrationSite, visits: SiteVisits, first_node_s: float, settings) -> VisitGeometry:
    """The lines of sight of a site's visits: target and satellite positions, pierce points, local times, dates."""
    n = visits.size
    target = np.broadcast_to(to_ecef(np.array(site.lat), np.array(site.lon), EARTH_MEAN_RADIUS), (n, 3)).copy()
    satellite, _ = satellite_state(orbit, visits.time_s, first_node_s, visits.track_offset)
    plat, plon = pierce_point_lat_lon(target, satellite, settings.shell_height_m)
    start = np.datetime64(settings.start_date, "s")
    time_utc = start + np.round(visits.time_s).astype("int64").astype("timedelta64[s]")
    return VisitGeometry(orbit, target, satellite, visits.incidence, plat, plon, visits.local_time_h, time_utc,
                         np.full(n, 1.0 / max(n, 1)))


def faraday_at_visits(geometries, settings: VisitIonosphereSettings) -> list:
    """Omega (rad) at each visit of each ``VisitGeometry`` from the IRI/IGRF climatology (module docstring), thin
    shell, all in one evaluation. The IRI monthly median of the visit's month is used (``SlantSettings.
    monthly_medians``), evaluated in the start date's year: the year enters a monthly median only through the
    secular change of the geomagnetic field, which the field model neglects over a mission as well (one IGRF
    epoch, the start date)."""
    slant = SlantSettings(method="thin_shell", shell_height_m=settings.shell_height_m,
                          field=FieldModel("igrf", settings.start_date), monthly_medians=True)
    time_utc = np.concatenate([g.time_utc for g in geometries])
    days = time_utc.astype("datetime64[D]")
    year = np.datetime64(settings.start_date, "D").item().year
    dates = [d.item().replace(year=year, day=min(d.item().day, 28)) for d in days]  # the month is what counts
    ut_h = (time_utc - days).astype("timedelta64[s]").astype(float) / 3600.0
    integrals = path_integrals(np.concatenate([g.target_ecef for g in geometries]),
                               np.concatenate([g.satellite_ecef for g in geometries]), dates, ut_h,
                               [settings.f107_sfu], slant)
    omega = faraday_rotation_integral(integrals.faraday[0], settings.frequency_hz)
    return np.split(omega, np.cumsum([g.incidence.size for g in geometries])[:-1])


def visit_ionosphere(site: CalibrationSite, geometry: VisitGeometry, omega, settings: VisitIonosphereSettings
                     ) -> VisitIonosphere:
    """The Faraday rotation's correction residual and the scintillation terms of every visit of a site, whose
    lines of sight are ``geometry`` and Faraday rotation ``omega`` (rad, ``faraday_at_visits``)."""
    visits, orbit = geometry, geometry.orbit
    snr = visit_snr(site, visits.incidence)
    point = site.type in POINT_TYPES
    estimator = _bickel_bates(1 / (1 / site.scr + 1 / snr) if point else snr, site.looks, exact=not point)
    ambiguity = ambiguity_error_probability(settings.tec_variability * np.abs(omega), np.sqrt(estimator)) * (
        math.pi / 2) ** 2
    n = visits.incidence.size
    if not settings.scintillation or n == 0:
        zero = np.zeros(n)
        return VisitIonosphere(omega, estimator, ambiguity, zero, np.full(n, -np.inf), zero)
    screen = ScreenSettings(sunspot_number=settings.sunspot_number, frequency_hz=settings.frequency_hz,
                            height_m=settings.shell_height_m)
    screens = acquisition_screens(geometry, screen)
    orbit_height = orbit.radius_m - EARTH_MEAN_RADIUS
    window = window_variance(settings.window_m, parallel_field(geometry, settings.shell_height_m),
                             settings.frequency_hz, 10.0 ** screens.log10_ckl, screen.spectral_index,
                             screen.outer_scale_m, screen.height_m, orbit_height, screens.zenith)
    if site.type in POINT_TYPES:
        rng = np.random.default_rng(np.random.SeedSequence(settings.seed, spawn_key=(_name_key(site.name),)))
        _, second = peak_log_loss(rng, geometry, screen, screens)
        peak = DB_PER_NEPER_POWER**2 * np.asarray(second, float)
    else:
        peak = np.zeros(n)
    return VisitIonosphere(omega, estimator, ambiguity, np.asarray(window, float), screens.log10_ckl, peak)


def _bickel_bates(snr, looks: float, exact: bool = True) -> np.ndarray:
    """The Bickel-Bates variance at each SNR. A distributed target (``exact``): the exact L-look phase density of
    its speckle below ``EXACT_LOOKS`` looks (one evaluation per distinct SNR), the corrected eq. (5) of Quegan et
    al. (2018) from there on (its relative error is about 1/L: under 1 % from 300 looks at SNRs of 0 dB and above).
    A point target has no speckle, only additive noise and clutter: eq. (5), which at coherence c / (1 + c) is
    1 / (16 c L) to first order, the phase noise of a deterministic response (each channel's phase SD 1/sqrt(2c))."""
    snr = np.atleast_1d(np.asarray(snr, float))
    looks = max(round(looks), 1)
    if looks >= EXACT_LOOKS or not exact:
        return np.asarray(bickel_bates_variance(snr, looks, "asymptotic"), float).reshape(snr.shape)
    values, inverse = np.unique(snr, return_inverse=True)
    return np.array([bickel_bates_variance(float(s), looks) for s in values])[inverse].reshape(snr.shape)


def _name_key(name: str) -> int:
    """A stable integer of a site's name (the spawn key of its Monte Carlo stream)."""
    return int.from_bytes(name.encode()[:8].ljust(8, b"\0"), "little")


__all__ = ["SOLAR_F107", "SOLAR_SUNSPOTS", "VisitIonosphere", "VisitIonosphereSettings", "faraday_at_visits",
           "visit_geometry", "visit_ionosphere"]
