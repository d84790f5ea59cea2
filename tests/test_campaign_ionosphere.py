"""The ionosphere at each visit of a calibration site (issue 25, items 2 and 3): the Faraday rotation from the
climatology at the visit's time and place, its correction's residual, the scintillation terms against the
scintillation module's Monte Carlo, and the antenna's pointing and pattern estimated in the Kalman state."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ndtr

from e2esim.campaign.antenna import SWATH_WEIGHTS, gain_rows, swath_gain_variance
from e2esim.campaign.drift import DriftModel, joint_residual_variance, residual_variance
from e2esim.campaign.sites import PRESETS, CalibrationSite
from e2esim.campaign.visibility import site_visits
from e2esim.campaign.visit_ionosphere import (
    VisitGeometry,
    VisitIonosphereSettings,
    faraday_at_visits,
    visit_geometry,
    visit_ionosphere,
)
from e2esim.geomag.field import FieldModel
from e2esim.ionosphere.slant import SlantSettings, vertical_tec_at
from e2esim.orbit.frames import EARTH_MEAN_RADIUS
from e2esim.orbit.geometry import ray_points
from e2esim.orbit.sunsync import SunSynchronousOrbit
from e2esim.scintillation.aperture import biomass_aperture, two_way_structure
from e2esim.scintillation.irf import compress, ideal_response, phase_draws

ORBIT = SunSynchronousOrbit(666e3)
NEAR, FAR = math.radians(23.0), math.radians(33.75)
SETTINGS = VisitIonosphereSettings("2025-06-01", f107_sfu=150.0, sunspot_number=100.0, frequency_hz=435e6)
DB = 10 / math.log(10)


@pytest.fixture(scope="module")
def norcia():
    site = PRESETS["new_norcia_transponder"]
    visits = site_visits(ORBIT, site.lat, site.lon, 25.0, NEAR, FAR, 480.0, site.name)
    assert visits.size >= 2
    return site, visits, visit_geometry(ORBIT, site, visits, 480.0, SETTINGS)


def test_the_faraday_rotation_of_a_visit_is_equation_3_at_its_pierce_point_date_and_time(norcia):
    # Quegan et al. (2018), eq. (3): Omega = 2.365e4 B cos(theta) TEC / f^2 (SI), thin shell: TEC = VTEC / cos(chi)
    # at the pierce point, B.k there; the VTEC of the IRI monthly median at the visit's month and UT
    _, visits, geometry = norcia
    omega = faraday_at_visits([geometry], SETTINGS)[0]
    ray = ray_points(geometry.target_ecef, geometry.satellite_ecef, np.array([SETTINGS.shell_height_m]))
    k = geometry.target_ecef - geometry.satellite_ecef
    k /= np.linalg.norm(k, axis=-1, keepdims=True)
    bk = FieldModel("igrf", SETTINGS.start_date).b_dot_k(ray.position[:, 0], k)
    days = geometry.time_utc.astype("datetime64[D]")
    ut = (geometry.time_utc - days).astype(float) / 3600.0
    top = float(np.linalg.norm(geometry.satellite_ecef[0])) - EARTH_MEAN_RADIUS
    vtec = np.array([vertical_tec_at(np.degrees(ray.lat[i, 0]), np.degrees(ray.lon[i, 0]), days[i].item(), ut[i],
                                     SETTINGS.f107_sfu, top, SlantSettings(monthly_medians=True))[0]
                     for i in range(visits.size)])
    expected = 2.365e4 * bk * vtec / np.cos(ray.zenith[:, 0]) / SETTINGS.frequency_hz**2
    # 2.365e4 is the paper's rounding of A = 2.3648e4: 1e-4 relative; the satellite heights differ by < 1 km
    assert omega == pytest.approx(expected, rel=5e-4)
    assert np.all(np.abs(omega) > math.radians(1.0))  # a real rotation, not a stated residual


def test_the_correction_residual_is_the_estimator_variance_plus_the_ambiguity_at_that_rotation(norcia):
    # a point target: Bickel-Bates at coherence c/(1+c) to first order 1/(16 c L) (no speckle); the climatology
    # prior of SD v |Omega| picks the wrong pi/2 branch with probability 2 Phi(-(pi/4) / sd)
    site, visits, geometry = norcia
    omega = np.radians([5.0, 40.0])[np.arange(visits.size) % 2]
    ion = visit_ionosphere(site, geometry, omega, SETTINGS)
    c = 1 / (1 / site.scr + 1 / site.snr)
    assert ion.estimator == pytest.approx(1 / (16 * c), rel=2e-3)  # eq. (5) vs its first order: (1 + 1/c)
    sd = np.hypot(SETTINGS.tec_variability * np.abs(omega), np.sqrt(ion.estimator))
    assert ion.ambiguity == pytest.approx(2 * ndtr(-(math.pi / 4) / sd) * (math.pi / 2) ** 2, rel=1e-12)
    assert ion.ambiguity[1] > 1e3 * ion.ambiguity[0]  # the larger rotation is the less certain prior
    assert ion.faraday_variance == pytest.approx(ion.estimator + ion.ambiguity + ion.window, rel=1e-15)
    quiet = visit_ionosphere(site, geometry, omega, VisitIonosphereSettings(**{**SETTINGS.__dict__,
                                                                              "scintillation": False}))
    assert np.all(quiet.window == 0) and np.all(quiet.peak_loss_variance_db2 == 0)
    assert np.all(ion.window > 0) and np.all(ion.peak_loss_variance_db2 > 0)


def _equatorial_visits(n: int = 3) -> VisitGeometry:
    """Point-target visits at the crest of the equatorial anomaly at 19-20 h local time, sunspot number 50
    (scintillation strong enough to matter, weak enough for the weak-scatter law: E[Y] 0.02-0.1), three incidences."""
    lat, lon = math.radians(5.6), math.radians(-72.7)  # about 15 deg geomagnetic (pole at 80.6 N 72.7 W)
    target = np.broadcast_to(np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])
                             * EARTH_MEAN_RADIUS, (n, 3)).copy()
    up = target / EARTH_MEAN_RADIUS
    satellite = target + 800e3 * up + 300e3 * np.cross([0.0, 0.0, 1.0], up)
    incidence = np.radians(np.linspace(24.0, 33.0, n))
    return VisitGeometry(ORBIT, target, satellite, incidence, np.full(n, lat), np.full(n, lon),
                         np.linspace(19.0, 20.0, n), np.full(n, np.datetime64("2025-03-20T02:00:00")), np.ones(n) / n)


def test_the_point_target_scintillation_term_matches_the_monte_carlo_of_the_compression(rng):
    # the gain term (10/ln 10)^2 E[Z^2], Z = -ln(peak / undistorted peak), against the scintillation module's Monte
    # Carlo (phase screens drawn with the visit's structure function, compressed, peak measured). Tolerance: 4
    # standard errors plus 10 % (the Strehl-Marechal law of the weak-scatter theory is good to about 5 % below
    # E[Y] = 0.3; docs/theory/scintillation.md)
    geometry = _equatorial_visits()
    site = CalibrationSite("equatorial_reflector", 0.1, -1.27, "corner_reflector", ("gain",), 35.0, 25.0)
    settings = VisitIonosphereSettings("2025-03-20", f107_sfu=180.0, sunspot_number=50.0, frequency_hz=435e6)
    ion = visit_ionosphere(site, geometry, np.zeros(3), settings)
    peak, _ = ideal_response(64, 16)
    checked = 0
    for i in range(3):
        aperture = biomass_aperture(geometry.incidence[i], ORBIT.radius_m - EARTH_MEAN_RADIUS)
        c_kl = 10.0 ** ion.log10_ckl[i]

        def structure(lag, aperture=aperture, c_kl=c_kl):
            return two_way_structure(lag, aperture, c_kl, 2.67, 10e3)

        z = -np.log(compress(phase_draws(rng, structure, 64, 4000), None, 16).max(axis=-1) / peak)
        sample = (DB * z) ** 2
        se = sample.std(ddof=1) / math.sqrt(sample.size)
        assert ion.peak_loss_variance_db2[i] == pytest.approx(sample.mean(), abs=4 * se + 0.1 * sample.mean())
        checked += ion.peak_loss_variance_db2[i] > 1e-2  # a contribution that counts (> 0.1 dB RMS)
    assert checked == 3


def test_the_antenna_parameters_combine_against_the_closed_form_of_static_least_squares(rng):
    # no drift: the Kalman filter's posterior is (P0^-1 + H' R^-1 H)^-1 with rows (1, u, u^2 - 1/3)
    v = 40
    days = np.sort(rng.uniform(0.0, 100.0, v))
    rows = gain_rows(rng.uniform(NEAR, FAR, v), NEAR, FAR)
    r = rng.uniform(0.01, 0.05, v)
    prior = np.array([0.5, 0.3, 0.2]) ** 2
    out = joint_residual_variance(tuple(DriftModel(math.sqrt(p)) for p in prior), [0.0, 50.0, 200.0], days, rows, r)
    for column, day in ((1, 50.0), (2, 200.0)):
        k = days <= day
        post = np.linalg.inv(np.diag(1 / prior) + rows[k].T @ (rows[k] / r[k, None]))
        assert out[:, column] == pytest.approx(np.diag(post), rel=1e-10)
    assert out[:, 0] == pytest.approx(prior, rel=1e-12)
    # with drift, a parameter the others do not touch is the scalar filter (the joint one defers its predictions)
    drift = (DriftModel(0.5, 2e-4, 0.1, 0.1), DriftModel(0.1, 1e-6, 0.01, 0.02), DriftModel(0.1, 1e-6, 0.01, 0.02))
    alone = np.column_stack([np.ones(v), np.zeros((v, 2))])
    grid = np.arange(0.0, 120.0, 0.5)
    joint = joint_residual_variance(drift, grid, days, alone, r)
    assert joint[0] == pytest.approx(residual_variance(drift[0], grid, days, r), rel=1e-12)
    assert joint[1] == pytest.approx(residual_variance(drift[1], grid, [], []), rel=1e-12)
    # one parameter alone is the scalar filter, bit for bit
    one = joint_residual_variance((DriftModel(0.5, 1e-4, 0.1, 0.1),), days, days, np.ones((v, 1)), r)[0]
    assert np.array_equal(one, residual_variance(DriftModel(0.5, 1e-4, 0.1, 0.1), days, days, r))


def test_visits_at_one_elevation_angle_cannot_tell_the_pointing_from_the_gain():
    # every visit at the swath centre (u = 0) sees g - c/3 only: the pointing stays at its prior, and the swath's
    # gain error is Var g + Var b / 3 + (4/45) Var c
    n = 50
    rows = gain_rows(np.full(n, (NEAR + FAR) / 2), NEAR, FAR)
    assert rows[:, 1] == pytest.approx(0.0, abs=1e-12)
    out = joint_residual_variance((DriftModel(0.5), DriftModel(0.3), DriftModel(0.2)), [10.0], np.arange(n) / 10,
                                  rows, np.full(n, 0.01))
    assert out[1, 0] == pytest.approx(0.09, rel=1e-12)
    spread = joint_residual_variance((DriftModel(0.5), DriftModel(0.3), DriftModel(0.2)), [10.0], np.arange(n) / 10,
                                     gain_rows(np.linspace(NEAR, FAR, n), NEAR, FAR), np.full(n, 0.01))
    assert spread[1, 0] < 0.01 * 0.09  # visits across the swath measure it
    u = np.linspace(-1.0, 1.0, 200001)
    weights = [np.trapezoid(f ** 2, u) / 2 for f in (np.ones_like(u), u, u * u - 1 / 3)]
    assert SWATH_WEIGHTS == pytest.approx(weights, rel=1e-9)
    assert swath_gain_variance(out[:, 0]) == pytest.approx(np.dot(SWATH_WEIGHTS, out[:, 0]), rel=1e-15)


def test_the_solar_presets_are_those_of_the_climatology_modules():
    from e2esim.campaign.visit_ionosphere import SOLAR_F107
    from e2esim.faraday.climatology_modules import SOLAR_PRESETS

    assert SOLAR_F107 == SOLAR_PRESETS
