"""Geomagnetic field: IGRF against NOAA, the fast synthesis against ppigrf, the dipole against IGRF's
dipole terms."""

import numpy as np
import pytest

from e2esim.errors import PhysicsInputError
from e2esim.geomag.dipole import dipole_field_ecef, dipole_field_spherical, dipole_moment_vector
from e2esim.geomag.field import FieldModel
from e2esim.geomag.igrf import dipole_coefficients, igrf_geocentric, igrf_reference
from e2esim.orbit.frames import to_ecef

# NOAA NCEI geomagnetic calculator, IGRF-13, 2020-01-01, 64 N 20 E, 5 km (geodetic), nT
# (the values ppigrf's own tests use)
NOAA = {"X": 13028.6, "Y": 1937.9, "Z": 50828.7}


def test_igrf_matches_noaa_within_one_percent():
    import datetime as dt

    import ppigrf
    import ppigrf.ppigrf as pp

    for coeff in (pp.shc_fn_igrf13, pp.shc_fn_igrf14):
        be, bn, bu = ppigrf.igrf(20.0, 64.0, 5.0, dt.datetime(2020, 1, 1), coeff_fn=coeff)
        assert bn[0] == pytest.approx(NOAA["X"], rel=0.01)
        assert be[0] == pytest.approx(NOAA["Y"], rel=0.01)
        assert -bu[0] == pytest.approx(NOAA["Z"], rel=0.01)
    # e2esim's own synthesis at the same point (geodetic -> geocentric by ppigrf): total intensity
    theta, r, _, _ = pp.geod2geoc(np.array([64.0]), np.array([5.0]), np.zeros(1), np.zeros(1))
    br, bt, bp = igrf_geocentric(r * 1e3, np.radians(theta), np.radians(20.0), "2020-01-01", "IGRF13")
    total = np.sqrt(br**2 + bt**2 + bp**2)[0] * 1e9
    assert total == pytest.approx(np.sqrt(sum(v**2 for v in NOAA.values())), rel=0.01)


def test_fast_synthesis_equals_ppigrf():
    rng = np.random.default_rng(3)
    n = 500
    r = 6371.2e3 + rng.uniform(0, 800e3, n)
    theta = rng.uniform(0.01, np.pi - 0.01, n)
    phi = rng.uniform(-np.pi, np.pi, n)
    for when in ("2016-06-30", "2027-03-01"):
        fast = igrf_geocentric(r, theta, phi, when)
        ref = igrf_reference(r, theta, phi, when)
        for a, b in zip(fast, ref):
            assert np.max(np.abs(a - b)) < 1e-9 * 6e-5


def test_igrf13_dipole_coefficients_2020():
    # IGRF-13 coefficient file (Alken et al. 2021), epoch 2020: g10, g11, h11 in nT
    g10, g11, h11 = dipole_coefficients("2020-01-01", "IGRF13")
    assert (g10 * 1e9, g11 * 1e9, h11 * 1e9) == pytest.approx((-29404.8, -1450.9, 4652.5), abs=0.05)


def test_dipole_equals_igrf_dipole_terms():
    rng = np.random.default_rng(4)
    r = 6371.2e3 + rng.uniform(0, 1000e3, 300)
    theta = rng.uniform(0.01, np.pi - 0.01, 300)
    phi = rng.uniform(-np.pi, np.pi, 300)
    m = dipole_moment_vector(*dipole_coefficients("2024-05-01"))
    dip = dipole_field_spherical(r, theta, phi, m)
    igrf1 = igrf_geocentric(r, theta, phi, "2024-05-01", max_degree=1)
    for a, b in zip(dip, igrf1):
        assert np.max(np.abs(a - b)) < 1e-12 * 3e-5


def test_aligned_dipole_geometry():
    b0 = 3.12e-5
    m = np.array([0.0, 0.0, -b0])
    a = 6371.2e3
    eq = dipole_field_ecef(to_ecef(0.0, 0.3, a), m)
    assert np.allclose(eq, [0, 0, b0])  # horizontal, pointing north at the equator, |B| = B0
    pole = dipole_field_ecef(to_ecef(np.pi / 2, 0.0, 2 * a), m)
    assert np.allclose(pole, [0, 0, -2 * b0 / 8])  # down at the north pole, 2 B0 (a/r)^3
    field = FieldModel("aligned_dipole", "2020-01-01", b0_tesla=b0)
    assert np.allclose(field.moment(), m)


def test_field_model_igrf_enu_consistent_with_spherical_components():
    f = FieldModel("igrf", "2020-01-01")
    lat, lon, r = np.radians(45.0), np.radians(-30.0), 6371.2e3 + 350e3
    b = f.ecef(to_ecef(lat, lon, r))
    br, bt, bp = igrf_geocentric(r, np.pi / 2 - lat, lon, "2020-01-01")
    assert np.linalg.norm(b) == pytest.approx(float(np.sqrt(br**2 + bt**2 + bp**2)), rel=1e-12)
    up = to_ecef(lat, lon, 1.0)
    assert b @ up == pytest.approx(float(br), rel=1e-12)


def test_bad_field_inputs_are_explained():
    with pytest.raises(PhysicsInputError, match="outside IGRF14"):
        igrf_geocentric(7e6, 1.0, 0.0, "1890-01-01")
    with pytest.raises(PhysicsInputError, match="field kind 'quadrupole'"):
        FieldModel("quadrupole")
    with pytest.raises(PhysicsInputError, match="not an ISO date"):
        FieldModel("igrf", "next tuesday")
