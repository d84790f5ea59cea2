"""Real orbits (e2esim.orbit.real): SGP4 against its published verification vectors, the TEME to Earth-fixed
rotation, Hermite interpolation against an analytic orbit, and EO CFI / NISAR files written from the circular
model reproducing its site geometry, or moving it by what a changed file implies."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from orbit_files import circular_trajectory, eocfi_text, write_nisar_orbit

from e2esim.errors import MissingExtraError
from e2esim.orbit.frames import EARTH_MEAN_RADIUS
from e2esim.orbit.real.eocfi import read_eocfi_orbit
from e2esim.orbit.real.nisar import read_nisar_orbit
from e2esim.orbit.real.tle import gmst, parse_tle, tle_trajectory
from e2esim.orbit.real.trajectory import hermite
from e2esim.orbit.real_modules import BiomassOrbitFile
from e2esim.orbit.sunsync import SunSynchronousOrbit

BIOMASS = SunSynchronousOrbit(666e3, 6.0, "left")
SITE = {"name": "siberia", "lat_deg": 60.0, "lon_deg": 92.0}

# Vallado, Crawford, Hujsak & Kelso (2006), "Revisiting Spacetrack Report #3", AIAA 2006-6753: the verification
# element sets (SGP4-VER.TLE) and their TEME positions (km) at minutes since epoch (tcppver.out).
VALLADO_2006 = {
    "00005": (("1 00005U 58002B   00179.78495062  .00000023  00000-0  28098-4 0  4753",
               "2 00005  34.2682 348.7242 1859667 331.7664  19.3264 10.82419157413667"),
              {0.0: (7022.46529266, -1400.08296755, 0.03995155),
               360.0: (-7154.03120202, -3783.17682504, -3536.19412294),
               720.0: (-7134.59340119, 6531.68641334, 3260.27186483)}),
    "06251": (("1 06251U 62025E   06176.82412014  .00008885  00000-0  12808-3 0  3985",
               "2 06251  58.0579  54.0425 0030035 139.1568 221.1854 15.56387291  6774"),
              {0.0: (3988.31022699, 5498.96657235, 0.90055879),
               120.0: (-3935.69800083, 409.10980837, 5471.33577327)}),
    "28057": (("1 28057U 03049A   06177.78615833  .00000060  00000-0  35940-4 0  1836",
               "2 28057  98.4283 247.6961 0000884  88.1964 271.9322 14.35478080140550"),
              {0.0: (-2715.28237486, -6619.26436889, -0.01341443),
               120.0: (-1816.87920942, -1835.78762132, 6661.07926465),
               240.0: (1483.17364291, 5395.21248786, 4448.65907172)}),
}


@pytest.mark.parametrize("number", sorted(VALLADO_2006))
def test_sgp4_reproduces_the_published_verification_positions(number):
    """TEME positions to 1 mm: the published values have 1e-8 km and the sgp4 package is Vallado's own code, so
    only a wrong epoch or unit in e2esim's wrapper (seconds since the element set's epoch, m) can move them."""
    lines, expected = VALLADO_2006[number]
    _, l1, l2 = parse_tle("\n".join(lines), "test")  # the published checksums pass
    trajectory = tle_trajectory(l1, l2)
    minutes = np.array(sorted(expected))
    r, _, _ = trajectory.teme(minutes * 60.0)
    np.testing.assert_allclose(r, np.array([expected[m] for m in minutes]) * 1e3, rtol=0, atol=1e-3)


def test_gmst_matches_vallado_example_3_5():
    """Vallado (2013), Example 3-5: 1992 August 20, 12:14 UT1 -> GMST 152.578787886 deg (to 1e-6 deg)."""
    jd = 2448854.5 + (12 + 14 / 60) / 24
    assert np.degrees(gmst(jd)) == pytest.approx(152.578787886, abs=1e-6)


def test_earth_fixed_tle_velocity_is_the_derivative_of_its_position():
    """The TEME -> Earth-fixed rotation includes the Earth's rotation in the velocity: v_ef = d r_ef / dt to 0.1 m/s
    (central difference over 0.1 s). SGP4's own velocity differs from the derivative of its position by a few cm/s
    (checked in TEME here too); leaving out omega_E x r would be 500 m/s off."""
    trajectory = tle_trajectory(*VALLADO_2006["28057"][0])
    t = np.array([600.0 - 0.05, 600.0, 600.0 + 0.05])
    r_teme, v_teme, _ = trajectory.teme(t)
    assert np.max(np.abs((r_teme[2] - r_teme[0]) / 0.1 - v_teme[1])) < 0.1
    r, v = trajectory.state(t)
    np.testing.assert_allclose((r[2] - r[0]) / 0.1, v[1], atol=0.1)


def test_hermite_interpolation_of_an_analytic_orbit():
    """4-point Hermite (degree 7) on the circular orbit's exact Earth-fixed trajectory: at 60 s spacing the
    mid-interval error is below 1 mm and 1 um/s; halving the spacing divides it by about 2^8 (eighth order)."""
    errors = []
    for step in (60.0, 120.0):
        times, r, v, _ = circular_trajectory(BIOMASS, 60.0, 92.0, 28.0, "ascending", step_s=step / 2)
        t = (times - times[0]) / np.timedelta64(1, "s")
        pos, vel = hermite(t[::2], r[::2], v[::2], t[5:-5:2])  # the mid-points, away from the ends
        errors.append((np.max(np.linalg.norm(pos - r[5:-5:2], axis=-1)),
                       np.max(np.linalg.norm(vel - v[5:-5:2], axis=-1))))
    assert errors[0][0] < 1e-3 and errors[0][1] < 1e-6
    assert errors[1][0] / errors[0][0] > 100


@pytest.fixture(scope="module")
def circular_pass():
    return circular_trajectory(BIOMASS, 60.0, 92.0, 28.0, "ascending")


def _module(path, **kw):
    return BiomassOrbitFile(file=str(path), surface="sphere", site=SITE, **kw)


def _check_reproduces(geometry, view, date="2026-05-01"):
    """The circular model's geometry, to 1e-6 rad / 1e-6 h: the file holds it to 1 mm (positions) and 1 um/s,
    Hermite adds < 1 mm and the zero-Doppler time is found to 1 us (7 mm along track); a mm at a 330 km range is
    3e-9 rad."""
    assert geometry.size == 1
    for name in ("incidence", "heading", "look_azimuth"):
        assert getattr(geometry, name)[0] == pytest.approx(float(getattr(view, name)), abs=1e-6), name
    assert geometry.local_time_h[0] == pytest.approx(float(view.local_time_h), abs=1e-6)
    np.testing.assert_allclose(geometry.satellite_ecef[0], view.satellite_ecef, atol=0.05)
    assert str(geometry.dates[0].date()) == date and geometry.pass_name[0] == "ascending"


def test_eocfi_file_from_the_circular_model_reproduces_its_geometry(circular_pass, tmp_path):
    times, r, v, view = circular_pass
    path = tmp_path / "orbit.EOF"
    path.write_text(eocfi_text(times, r, v))
    module = _module(path)
    _check_reproduces(module.geometry, view)
    assert module.orbit.altitude_m == pytest.approx(666e3, abs=1.0)  # the equivalent circular orbit
    assert module.orbit.ltan_h == pytest.approx(6.0, abs=1e-6)
    assert module.orbit.inclination_rad == pytest.approx(BIOMASS.inclination_rad, abs=1e-9)


def test_nisar_orbit_group_from_the_circular_model_reproduces_its_geometry(circular_pass, tmp_path):
    times, r, v, view = circular_pass
    path = tmp_path / "product.h5"
    write_nisar_orbit(path, times, r, v)
    assert read_nisar_orbit(path).kind == "NISAR orbit, orbitType POE, interpMethod Hermite"
    _check_reproduces(_module(path).geometry, view)


def test_a_later_node_moves_the_local_time_by_the_shift(circular_pass, tmp_path):
    """The same Earth-fixed track 10 minutes later: the site is seen from the same place, 10 min later in local
    mean solar time (UTC + lon / 15), at the same incidence."""
    times, r, v, view = circular_pass
    path = tmp_path / "later.EOF"
    path.write_text(eocfi_text(times + np.timedelta64(600, "s"), r, v))
    g = _module(path).geometry
    assert g.local_time_h[0] - float(view.local_time_h) == pytest.approx(600 / 3600, abs=1e-6)
    assert g.incidence[0] == pytest.approx(float(view.incidence), abs=1e-6)


def test_a_higher_orbit_raises_the_incidence_by_the_triangle(circular_pass, tmp_path):
    """Positions and velocities scaled by (R + H + 40 km) / (R + H): the zero-Doppler instant stays (r . v = 0 on a
    circular orbit) and so does the Earth-central angle gamma between site and satellite, so the incidence is
    atan2(r' sin gamma, r' cos gamma - R) of the spherical triangle (e2esim.orbit.geometry): the site is
    seen more steeply, 28 -> 26.75 deg."""
    times, r, v, view = circular_pass
    scale = (BIOMASS.radius_m + 40e3) / BIOMASS.radius_m
    path = tmp_path / "higher.EOF"
    path.write_text(eocfi_text(times, r * scale, v * scale))
    g = _module(path).geometry
    s = np.asarray(view.satellite_ecef)
    gamma = np.arccos(np.dot(s, view.target_ecef) / (np.linalg.norm(s) * EARTH_MEAN_RADIUS))
    radius = BIOMASS.radius_m * scale
    expected = np.arctan2(radius * np.sin(gamma), radius * np.cos(gamma) - EARTH_MEAN_RADIUS)
    assert g.incidence[0] == pytest.approx(expected, abs=1e-6)
    assert 28.0 - np.degrees(g.incidence[0]) > 1.0
    assert g.local_time_h[0] == pytest.approx(float(view.local_time_h), abs=1e-6)


def test_the_wgs84_site_lies_below_the_sphere_and_lowers_the_incidence(circular_pass, tmp_path):
    """On the ellipsoid the site at 60 deg is 9.0 km inside the mean sphere: the same pass sees it at 27.6 deg
    (the ellipsoid's normal also tilts by the 0.17 deg geodetic - geocentric latitude difference)."""
    times, r, v, _ = circular_pass
    path = tmp_path / "orbit.EOF"
    path.write_text(eocfi_text(times, r, v))
    g = BiomassOrbitFile(file=str(path), site=SITE).geometry
    assert EARTH_MEAN_RADIUS - np.linalg.norm(g.target_ecef[0]) == pytest.approx(9.0e3, abs=0.1e3)
    assert np.degrees(g.incidence[0]) == pytest.approx(27.6, abs=0.05)


def test_eocfi_reader_reads_times_and_units(circular_pass, tmp_path):
    times, r, v, _ = circular_pass
    path = tmp_path / "orbit.EOF"
    path.write_text(eocfi_text(times, r, v))
    trajectory = read_eocfi_orbit(path)
    assert trajectory.epoch == times[0] and trajectory.end_s == pytest.approx(3600.0)
    np.testing.assert_allclose(trajectory.position, r, atol=5e-4)


def test_missing_sgp4_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "sgp4.api", None)
    with pytest.raises(MissingExtraError, match=r"optional extra 'orbits'.*pip install 'e2esim\[orbits\]'"):
        tle_trajectory(*VALLADO_2006["00005"][0])


@pytest.mark.parametrize("file", ["biomass_like.tle", "biomass_circular_siberia.EOF"])
def test_orbit_file_modules_conform(file):
    """Configuration round trip and pickling (a TLE's Satrec is rebuilt from its lines) for workers and resume."""
    from e2esim.testing import check_module
    from quick_runs import SCENARIOS

    module = check_module(BiomassOrbitFile, {"file": str(SCENARIOS / "orbits" / file), "site": SITE})
    assert module.geometry.size == 1
