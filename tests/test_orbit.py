"""Sun-synchronous orbit, side-looking geometry, pierce points and the mission timeline (Quegan et al.
2018, Section 2)."""

import datetime as dt
import itertools

import numpy as np
import pytest

from e2esim.errors import ConfigError, PhysicsInputError
from e2esim.orbit.acquisition import Site, acquisitions, swath_incidences
from e2esim.orbit.frames import EARTH_MEAN_RADIUS, EARTH_ROTATION_RATE, ecef_to_enu, from_ecef
from e2esim.orbit.geometry import ray_points, side_looking_angles, view_geometry
from e2esim.orbit.modules import BiomassOrbit
from e2esim.orbit.sunsync import (
    SunSynchronousOrbit,
    ground_track_heading,
    keplerian_period,
    subsatellite_local_time,
    sun_synchronous_inclination,
)
from e2esim.orbit.timeline import MissionTimeline, period_dates

BIOMASS = SunSynchronousOrbit(666e3)


def test_sun_synchronous_inclination_and_period():
    # CEOS EO Handbook, BIOMASS mission summary: 666 km, 98 deg. The CEOS period of 102.6 min does not belong to a
    # 666 km circular orbit: Kepler gives 98.06 min (102.6 min would be about 890 km).
    assert np.degrees(sun_synchronous_inclination(666e3)) == pytest.approx(98.05, abs=0.02)
    assert keplerian_period(666e3) / 60 == pytest.approx(98.06, abs=0.01)
    # NISAR, 747 km sun-synchronous: 98.4 deg (NASA/JPL NISAR quick facts)
    assert np.degrees(sun_synchronous_inclination(747e3)) == pytest.approx(98.4, abs=0.05)


def test_heading_at_equator_with_and_without_earth_rotation():
    i, n = BIOMASS.inclination_rad, BIOMASS.mean_motion
    still = SunSynchronousOrbit(666e3, earth_rotation=False)
    assert ground_track_heading(still, 0.0, "ascending") == pytest.approx(np.arcsin(np.cos(i)), abs=1e-12)
    expected = np.arctan2(n * np.cos(i) - EARTH_ROTATION_RATE, n * np.sin(i))  # east, north of the ground velocity
    assert ground_track_heading(BIOMASS, 0.0, "ascending") == pytest.approx(expected, abs=1e-12)
    assert np.degrees(ground_track_heading(BIOMASS, 0.0, "ascending")) == pytest.approx(-11.88, abs=0.01)
    # descending mirrors ascending about east-west
    asc = ground_track_heading(BIOMASS, np.radians(40), "ascending")
    desc = ground_track_heading(BIOMASS, np.radians(40), "descending")
    assert np.degrees(desc) == pytest.approx(-180 - np.degrees(asc), abs=1e-9)


def test_local_time_along_the_dawn_dusk_orbit():
    assert BIOMASS.pass_label("ascending") == "dawn" and BIOMASS.pass_label("descending") == "dusk"
    assert subsatellite_local_time(BIOMASS, 0.0, "ascending") == pytest.approx(6.0)
    assert subsatellite_local_time(BIOMASS, 0.0, "descending") == pytest.approx(18.0)
    # RA offset atan(cos i tan u), u = asin(sin(lat)/sin(i))
    lat = np.radians(60)
    u = np.arcsin(np.sin(lat) / np.sin(BIOMASS.inclination_rad))
    expected = 6 + np.degrees(np.arctan(np.cos(BIOMASS.inclination_rad) * np.tan(u))) / 15
    assert subsatellite_local_time(BIOMASS, lat, "ascending") == pytest.approx(expected, abs=1e-12)
    assert expected == pytest.approx(5.05, abs=0.01)


@pytest.mark.parametrize("pass_name", ["ascending", "descending"])
@pytest.mark.parametrize("earth_rotation", [True, False])
def test_view_geometry_incidence_zero_doppler_and_side(pass_name, earth_rotation):
    orbit = SunSynchronousOrbit(666e3, earth_rotation=earth_rotation)
    lat = np.radians(np.array([-70.0, -20.0, 0.0, 1.9, 45.0, 75.0]))
    inc = np.radians(np.array([23.0, 26.0, 28.4, 30.0, 33.75, 25.0]))
    g = view_geometry(orbit, lat, np.radians(37.0), inc, pass_name)
    assert g.valid.all()
    up = g.target_ecef / np.linalg.norm(g.target_ecef, axis=-1, keepdims=True)
    assert np.allclose(np.arccos(-np.sum(g.k_ecef * up, -1)), inc, atol=1e-8)  # incidence at the target
    assert np.allclose(np.sum(g.k_ecef * g.velocity_ecef, -1) / np.linalg.norm(g.velocity_ecef, axis=-1), 0,
                       atol=1e-8)  # zero Doppler
    left = np.sum(np.cross(g.satellite_ecef, g.velocity_ecef) * (g.target_ecef - g.satellite_ecef), -1)
    assert np.all(left > 0)
    _, _, rho = side_looking_angles(inc, orbit.radius_m)
    assert np.allclose(np.linalg.norm(g.target_ecef - g.satellite_ecef, axis=-1), rho, rtol=1e-9)
    assert np.allclose(np.linalg.norm(g.satellite_ecef, axis=-1), orbit.radius_m)
    assert np.all((np.cos(g.u) > 0) == (pass_name == "ascending"))
    # left-looking: at low latitude (little meridian convergence between nadir and target) the horizontal
    # look direction is 90 deg left of the heading, within the Earth-rotation yaw of a degree or so
    diff = np.degrees(np.angle(np.exp(1j * (g.look_azimuth - g.heading))))
    low = np.abs(lat) < np.radians(25)
    assert np.all(np.abs(diff[low] + 90) < 1.5)


def test_reach_of_the_left_looking_dawn_dusk_orbit():
    # nadir reaches 180 - 98.05 = 81.95 deg; left looks away from the north pole at the northern turn and
    # towards the south pole at the southern one (BIOMASS's Antarctic coverage)
    g = view_geometry(BIOMASS, np.radians(np.array([78.0, 80.0, -84.0, -86.0])), 0.0, np.radians(28.0), "ascending")
    assert g.valid.tolist() == [True, False, True, False]
    with pytest.raises(PhysicsInputError, match="out of reach of the ascending pass"):
        acquisitions(BIOMASS, Site("arctic", np.radians(80.0), 0.0), [dt.datetime(2026, 1, 1)], ("ascending",),
                     np.radians([28.0]))


def test_pierce_points_on_the_line_of_sight():
    g = view_geometry(BIOMASS, np.radians(50.0), np.radians(10.0), np.radians(30.0), "ascending")
    heights = np.array([100e3, 350e3, 600e3])
    ray = ray_points(g.target_ecef, g.satellite_ecef, heights)
    assert np.allclose(np.linalg.norm(ray.position, axis=-1), EARTH_MEAN_RADIUS + heights)
    # on the segment from target to satellite
    d = ray.position - g.target_ecef
    e = (g.satellite_ecef - g.target_ecef) / np.linalg.norm(g.satellite_ecef - g.target_ecef)
    assert np.allclose(np.linalg.norm(np.cross(d, e), axis=-1), 0, atol=1e-3)
    # spherical geometry: sin(chi_h) (R + h) = sin(theta) R
    assert np.allclose(np.sin(ray.zenith) * (EARTH_MEAN_RADIUS + heights), np.sin(np.radians(30.0)) * EARTH_MEAN_RADIUS)
    assert np.allclose(ray.path_per_height, 1 / np.cos(ray.zenith))
    # the pierce point lies towards the satellite: east-north-east of the target for the ascending left look
    enu = ecef_to_enu(ray.position[1] - g.target_ecef, np.radians(50.0), np.radians(10.0))
    assert enu[0] > 0 and enu[1] > 0
    lat, _, _ = from_ecef(ray.position[1])
    assert np.degrees(lat) > 50.0


def test_swath_incidences_equal_ground_range():
    inc = swath_incidences(BIOMASS, np.radians(23.0), np.radians(33.75), 4)
    gamma = side_looking_angles(inc, BIOMASS.radius_m)[1]
    g0, g1 = side_looking_angles(np.radians([23.0, 33.75]), BIOMASS.radius_m)[1]
    assert np.allclose(gamma, g0 + (np.arange(4) + 0.5) / 4 * (g1 - g0))
    assert np.all(np.diff(inc) > 0)


def test_mission_timeline_quegan2018_section2():
    tl = MissionTimeline(start="2025-04-29", site_slot=0.0)
    cp = tl.acquisition_dates("commissioning")
    assert len(cp) == 21 and cp[0] >= dt.datetime(2025, 4, 29) and cp[-1] < dt.datetime(2025, 7, 29)
    tp = tl.acquisition_dates("tomographic")
    assert len(tp) == 7
    assert tp[0] == dt.datetime(2025, 7, 29)  # first day after the 91-day CP
    assert all((b - a).days == 3 for a, b in itertools.pairwise(tp))
    ip = tl.acquisition_dates("interferometric")
    ip0 = dt.datetime(2025, 7, 29) + dt.timedelta(days=425)
    n_cycles = int((tl.end_date - ip0).days // 219)
    assert len(ip) == 3 * n_cycles == 15
    assert ip[0] == ip0 and ip[3] == ip0 + dt.timedelta(days=219)
    mid = MissionTimeline(site_slot=0.5).acquisition_dates("tomographic")
    assert mid[0] == dt.datetime(2025, 7, 29) + dt.timedelta(days=int(0.5 * (425 - 18 - 1)))
    assert len(tl.acquisition_dates("mission")) == 21 + 7 + 15
    assert MissionTimeline().phase_of(tp[0]) == "tomographic"


def test_period_dates_and_bad_dates():
    d = period_dates("2026-01-01", "2026-12-31", 3)
    assert len(d) == 122 and d[-1] == dt.datetime(2026, 12, 30)
    with pytest.raises(PhysicsInputError, match="not an ISO date"):
        period_dates("2026-13-01", "2026-12-31", 3)
    with pytest.raises(PhysicsInputError, match="before its start"):
        period_dates("2026-02-01", "2026-01-01", 3)


def test_biomass_orbit_module_geometry():
    mod = BiomassOrbit(site={"name": "lope", "lat_deg": -0.2, "lon_deg": 11.6}, passes="dawn", swath_samples=3,
                       acquisitions={"start": "2026-03-01", "end": "2026-03-31", "step_days": 10})
    g = mod.geometry
    assert g.size == 4 * 3 and set(g.pass_name) == {"ascending"} and set(g.pass_label) == {"dawn"}
    assert np.all(np.degrees(g.incidence) > 23) and np.all(np.degrees(g.incidence) < 33.75)
    # local time near 06:00 at the equator (target offset from the track shifts it by minutes)
    assert np.all(np.abs(g.local_time_h - 6.0) < 0.5)
    ut = (g.time_utc - g.time_utc.astype("datetime64[D]")).astype(float) / 3600
    assert np.allclose(ut, np.mod(g.local_time_h - 11.6 / 15, 24), atol=1 / 3600)  # whole seconds
    assert np.allclose(np.linalg.norm(g.k_enu, axis=-1), 1)
    assert g.weight.sum() == pytest.approx(1)


def test_orbit_module_bad_input_names_the_key():
    with pytest.raises(ConfigError, match=r"incidence_near_deg: 35 is not below incidence_far_deg = 33.75"):
        BiomassOrbit(site={"lat_deg": 0, "lon_deg": 0}, incidence_near_deg=35.0)
    with pytest.raises(ConfigError, match="out of reach"):
        BiomassOrbit(site={"lat_deg": 85.0, "lon_deg": 0})
    with pytest.raises(ConfigError, match=r"site.lat_deg"):
        BiomassOrbit(site={"lat_deg": 95.0, "lon_deg": 0})
