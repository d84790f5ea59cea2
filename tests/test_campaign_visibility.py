"""Every pass over a calibration site (issue 25, item 2) against an independent propagation of the same orbit.

The reference is written here in another formulation: inertial axes, the Earth turning at the sidereal rate from
a Greenwich sidereal angle tied to the mean Sun (UT 0 h: the mean Sun over the antimeridian), the node at a fixed
angle to the mean Sun (the LTAN), the secular J2 rate of the argument of latitude written from Vallado (2013),
eqs. 9-41, and the passes found by sampling the range to the site every 10 s and refining its minimum by
bisection on the range rate. The kernel instead solves the zero-Doppler condition by Newton's method in Earth-fixed
axes from each latitude crossing."""

from __future__ import annotations

import numpy as np
import pytest

from e2esim.campaign.repeat_orbit import repeat_altitude, repeat_track, revolutions_in
from e2esim.campaign.visibility import site_visits
from e2esim.errors import PhysicsInputError
from e2esim.orbit.sunsync import SunSynchronousOrbit

R_EQ, J2, MU = 6378137.0, 1.08262668e-3, 3.986004418e14
YEAR_S = 365.2421897 * 86400.0
OMEGA_EARTH = 2 * np.pi / 86400.0 + 2 * np.pi / YEAR_S  # sidereal: one solar day plus the Sun's yearly turn


def _reference_state(orbit, first_node_s, offset=None):
    """state(t): Earth-fixed position and Earth-relative velocity; ``offset(day)``: the node moved east (rad)."""
    a = R_EQ + orbit.altitude_m
    n = np.sqrt(MU / a**3)
    k = 0.75 * J2 * (R_EQ / a) ** 2
    ci = np.cos(orbit.inclination_rad)
    u_rate = n * (1 + k * (3 * ci**2 - 1)) + n * k * (5 * ci**2 - 1)
    radius = 6371008.8 + orbit.altitude_m

    def state(t):
        t = np.atleast_1d(t)
        sun = 2 * np.pi * t / YEAR_S  # right ascension of the mean Sun
        node = sun + (orbit.ltan_h - 12.0) * np.pi / 12.0 + (0.0 if offset is None else offset(t / 86400.0))
        theta = -np.pi + OMEGA_EARTH * t  # Greenwich sidereal angle
        u = u_rate * (t - first_node_s)
        si = np.sin(orbit.inclination_rad)
        p = np.stack([np.cos(u), np.sin(u) * ci, np.sin(u) * si], -1) * radius
        v = np.stack([-np.sin(u), np.cos(u) * ci, np.cos(u) * si], -1) * radius * u_rate
        cn, sn = np.cos(node)[:, None], np.sin(node)[:, None]
        r_i = np.stack([cn[:, 0] * p[:, 0] - sn[:, 0] * p[:, 1], sn[:, 0] * p[:, 0] + cn[:, 0] * p[:, 1], p[:, 2]], -1)
        v_i = np.stack([cn[:, 0] * v[:, 0] - sn[:, 0] * v[:, 1], sn[:, 0] * v[:, 0] + cn[:, 0] * v[:, 1], v[:, 2]], -1)
        v_i = v_i + (2 * np.pi / YEAR_S) * np.stack([-r_i[:, 1], r_i[:, 0], 0 * r_i[:, 2]], -1)  # node precession
        v_rel = v_i - OMEGA_EARTH * np.stack([-r_i[:, 1], r_i[:, 0], 0 * r_i[:, 2]], -1)
        c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
        to_fixed = (lambda x: np.stack([c[:, 0] * x[:, 0] + s[:, 0] * x[:, 1], -s[:, 0] * x[:, 0] + c[:, 0] * x[:, 1],
                                        x[:, 2]], -1))
        return to_fixed(r_i), to_fixed(v_rel)

    return state


def _reference_passes(orbit, lat, lon, days, near, far, first_node_s, from_day=0.0, offset=None):
    target = 6371008.8 * np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    state = _reference_state(orbit, first_node_s, offset)

    def rate(t):
        r, v = state(t)
        return np.einsum("ij,ij->i", r - target, v)

    t = np.arange(from_day * 86400.0, days * 86400.0, 10.0)
    f = rate(t)
    lo = t[:-1][(f[:-1] < 0) & (f[1:] >= 0)]
    hi = lo + 10.0
    for _ in range(40):
        mid = (lo + hi) / 2
        neg = rate(mid) < 0
        lo, hi = np.where(neg, mid, lo), np.where(neg, hi, mid)
    tc = (lo + hi) / 2
    r, v = state(tc)
    los = r - target
    inc = np.arccos(los @ target / np.linalg.norm(los, axis=1) / np.linalg.norm(target))
    left = np.einsum("ij,ij->i", np.cross(r, v), target - r) > 0
    keep = left & (inc >= near) & (inc <= far) & (np.linalg.norm(los, axis=1) < 3e6)
    return tc[keep], inc[keep]


@pytest.mark.parametrize(("lat_deg", "lon_deg", "first_node_min", "from_day", "days"), [
    (-31.048, 116.192, 8.0, 0.0, 12.0),   # the New Norcia transponder, seen from the first days
    (-75.1, 123.35, 0.0, 0.0, 6.0),       # Dome-C: both passes, converging tracks
    (-31.048, 116.192, 8.0, 216.0, 222.0),  # a pass at day 218.9 whose Newton start lay far from it (fixed)
])
def test_acquisition_dates_match_an_independent_propagation(lat_deg, lon_deg, first_node_min, from_day, days):
    orbit = SunSynchronousOrbit(666e3)
    near, far = np.radians(23.0), np.radians(33.75)
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    got = site_visits(orbit, lat, lon, days, near, far, first_node_min * 60.0)
    keep = got.time_s >= from_day * 86400.0
    got = type(got)(got.site_name, got.time_s[keep], got.incidence[keep], got.pass_name[keep], got.local_time_h[keep])
    t_ref, inc_ref = _reference_passes(orbit, lat, lon, days, near, far, first_node_min * 60.0, from_day)
    assert got.size >= 2
    # a pass at the swath edge may fall either side of it in one of the two: compare those clearly inside
    inner = (inc_ref > near + 1e-4) & (inc_ref < far - 1e-4)
    idx = np.searchsorted(got.time_s, t_ref[inner])
    idx = np.clip(idx, 0, got.size - 1)
    nearest = np.where(np.abs(got.time_s[idx] - t_ref[inner]) < np.abs(got.time_s[idx - 1] - t_ref[inner]),
                       idx, idx - 1)
    np.testing.assert_allclose(got.time_s[nearest], t_ref[inner], atol=0.05)  # s
    np.testing.assert_allclose(got.incidence[nearest], inc_ref[inner], atol=1e-6)  # rad
    assert abs(got.size - t_ref.size) <= (~inner).sum()  # the same passes, but for those at an edge


# --- the operational repeat orbit and the mission timeline (repeat_orbit) ---

BIOMASS = SunSynchronousOrbit(666e3)
NEAR, FAR = np.radians(23.0), np.radians(33.75)
NORCIA = (np.radians(-31.048), np.radians(116.192))


def test_the_tuned_orbit_repeats_its_ground_track_after_44_revolutions_in_3_days():
    """The reference (its own J2 rate, inertial axes, a sidereal Earth) puts the tuned orbit back on the same
    Earth-fixed point 3 days later. Tolerance 1 cm: the altitude is solved to far below a millimetre (its rate error
    over 3 days moves the satellite < 1 mm) and double rounding of 2 pi x 44 rad is ~1e-13 rad (1e-6 m); the
    stated 666 km orbit (43.9996 revolutions) moves by kilometres."""
    track = repeat_track(BIOMASS, 30.0, 91.0)
    assert track.revolutions == 44
    assert abs(track.orbit.altitude_m - 666e3) < 1e3  # the tuning is a small change of the stated altitude
    assert track.orbit.inclination_rad == pytest.approx(np.radians(98.05), abs=np.radians(0.01))  # sun-synchronous
    t = np.array([0.0, 1234.5, 40000.0, 200000.0])
    state = _reference_state(track.orbit, 480.0)
    moved = np.linalg.norm(state(t + 3 * 86400.0)[0] - state(t)[0], axis=1)
    assert np.all(moved < 0.01)
    stated = _reference_state(BIOMASS, 480.0)
    assert np.all(np.linalg.norm(stated(t + 3 * 86400.0)[0] - stated(t)[0], axis=1) > 5e3)
    assert revolutions_in(track.orbit, 3.0) == pytest.approx(44.0, abs=1e-9)


@pytest.mark.parametrize(("lat_deg", "lon_deg", "from_day", "days"), [
    (-31.048, 116.192, 0.0, 16.0),    # New Norcia in commissioning: a new track position every 3 days
    (-75.1, 123.35, 100.0, 116.0),    # Dome-C across a tomographic stack boundary (day 112)
])
def test_acquisition_dates_on_the_drifting_repeat_track_match_an_independent_propagation(lat_deg, lon_deg, from_day,
                                                                                        days):
    track = repeat_track(BIOMASS, 1826.25, 91.0)
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    got = site_visits(track.orbit, lat, lon, days, NEAR, FAR, 480.0, track=track, point=False)
    keep = got.time_s >= from_day * 86400.0
    t_got, inc_got = got.time_s[keep], got.incidence[keep]
    t_ref, inc_ref = _reference_passes(track.orbit, lat, lon, days, NEAR, FAR, 480.0, from_day,
                                       offset=lambda d: track.stack_of(d)[3])
    # a crossing the reference finds at a stack boundary is the jump of the track, not a pass
    _, _, before, _ = track.stack_of((t_ref - 30.0) / 86400.0)
    _, _, after, _ = track.stack_of((t_ref + 30.0) / 86400.0)
    t_ref, inc_ref = t_ref[before == after], inc_ref[before == after]
    inner = (inc_ref > NEAR + 1e-4) & (inc_ref < FAR - 1e-4)
    assert inner.sum() >= 3
    idx = np.clip(np.searchsorted(t_got, t_ref[inner]), 1, t_got.size - 1)
    nearest = np.where(np.abs(t_got[idx] - t_ref[inner]) < np.abs(t_got[idx - 1] - t_ref[inner]), idx, idx - 1)
    np.testing.assert_allclose(t_got[nearest], t_ref[inner], atol=0.05)  # s
    np.testing.assert_allclose(inc_got[nearest], inc_ref[inner], atol=1e-6)  # rad
    assert abs(t_got.size - t_ref.size) <= (~inner).sum()
    # the track moved: the incidence at the site changes from stack to stack
    stacks = track.stack_of(t_got / 86400.0)[2]
    assert np.unique(stacks).size >= 2 and np.ptp(inc_got) > np.radians(1.0)


@pytest.mark.parametrize("site", [NORCIA, (np.radians(21.5), np.radians(29.3))])
def test_the_visits_of_each_phase_follow_the_mission_timeline(site):
    """Quegan et al. (2018), Section 2: a point is imaged in the tomographic phase 7 times 3 days apart, in each
    interferometric cycle 3 times 3 days apart (per pass direction); in commissioning at every pass in the swath,
    at several incidences; never while the track moves between stacks."""
    days = 91.0 + 425.0 + 219.0
    track = repeat_track(BIOMASS, days, 91.0)
    assert [(p.name, p.passes, p.stacks) for p in track.phases] == [
        ("commissioning", 1, 30), ("tomographic", 7, 20), ("interferometric", 3, 24)]
    v = site_visits(track.orbit, *site, days, NEAR, FAR, 480.0, track=track)
    area = site_visits(track.orbit, *site, days, NEAR, FAR, 480.0, track=track, point=False)
    phase, _, stack, _ = track.stack_of(v.day)
    assert np.all(stack >= 0)
    for p, (first, last, passes) in enumerate([(91.0, 516.0, 7), (516.0, 735.0, 3)], start=1):
        assert np.all((v.day[phase == p] >= first) & (v.day[phase == p] < last))
        for direction in ("ascending", "descending"):
            sel = (phase == p) & (v.pass_name == direction)
            assert sel.sum() == passes, (p, direction)
            np.testing.assert_allclose(np.diff(v.day[sel]), 3.0, atol=1e-7)  # the repeat: Newton to 1e-3 s
            assert np.unique(stack[sel]).size == 1
            # the plan's stack is the one of the area's passes nearest the middle of the swath
            a_sel = (track.stack_of(area.day)[0] == p) & (area.pass_name == direction)
            mid = 0.5 * (NEAR + FAR)
            assert np.abs(v.incidence[sel] - mid).max() <= np.abs(area.incidence[a_sel] - mid).min() + 1e-9
            assert a_sel.sum() > sel.sum()  # the site lies in the incidence range in more than one stack
    cp = phase == 0
    np.testing.assert_array_equal(v.time_s[cp], area.time_s[track.stack_of(area.day)[0] == 0])
    assert cp.sum() >= 6 and np.ptp(v.incidence[cp]) > np.radians(5.0)


def test_an_orbit_that_cannot_repeat_is_refused_naming_it():
    with pytest.raises(PhysicsInputError, match=r"repeats after 1 revolutions in 0\.05 days"):
        repeat_altitude(1, 0.05)
