"""The power-law phase screen (Rino 1979) and its climatology: closed forms against quadrature, the model's range,
and the climatology's morphology (Aarons 1982; ITU-R P.531)."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from e2esim.errors import PhysicsInputError
from e2esim.scintillation.climatology import geomagnetic_latitude, log10_ckl
from e2esim.scintillation.screen import (
    PhaseScreen,
    check_screen,
    phase_spectrum,
    phase_variance,
    structure_function,
)

WAVELENGTH = 299792458.0 / 435e6


@pytest.mark.parametrize("p", [1.5, 2.67, 3.5, 4.5])
def test_variance_and_structure_function_are_the_integrals_of_the_spectrum(p):
    """eq. S3 and S4 (Matern closed forms) against numerical quadrature of the spectrum eq. S2 (1e-6: quadrature)."""
    args = (1e24, p, 10e3, WAVELENGTH)
    var = quad(lambda k: phase_spectrum(k, *args) / math.pi, 0.0, np.inf, limit=400)[0]
    assert phase_variance(*args) == pytest.approx(var, rel=1e-6)
    for lag in (50.0, 2e3, 30e3):
        cos_part = quad(lambda k: phase_spectrum(k, *args) / math.pi, 0.0, np.inf, weight="cos", wvar=lag)[0]
        d = 2.0 * (var - cos_part)
        assert structure_function(lag, *args) == pytest.approx(d, rel=1e-4)  # the reference subtracts two integrals


def test_structure_function_is_a_power_law_below_the_outer_scale():
    """D(Delta) ~ Delta^(p - 1) for Delta << L_0 (Rino 1979, phase structure function of a power law, 1 < p < 3)."""
    p = 2.5
    d1, d2 = structure_function(np.array([10.0, 20.0]), 1e24, p, 1e7, WAVELENGTH)
    assert math.log2(d2 / d1) == pytest.approx(p - 1.0, abs=0.01)
    # and saturates at twice the variance far beyond it
    assert structure_function(1e6, 1e24, p, 1e3, WAVELENGTH) == pytest.approx(
        2.0 * phase_variance(1e24, p, 1e3, WAVELENGTH), rel=1e-9)


def test_phase_scales_with_wavelength_squared_and_strength():
    ratio = phase_variance(1e24, 2.67, 1e4, 2 * WAVELENGTH) / phase_variance(1e24, 2.67, 1e4, WAVELENGTH)
    assert ratio == pytest.approx(4.0)
    assert phase_variance(3e24, 2.67, 1e4, WAVELENGTH) == pytest.approx(3 * phase_variance(1e24, 2.67, 1e4, WAVELENGTH))


@pytest.mark.parametrize("kwargs, key, text", [
    ({"c_kl": -1.0}, "c_kl", "C_kL must be finite and >= 0"),
    ({"spectral_index": 1.0}, "spectral_index", "outside the power-law model's range 1 < p < 5"),
    ({"spectral_index": 5.5}, "spectral_index", "outside the power-law model's range"),
    ({"height_m": 700e3}, "screen_height_km", "is not below the orbit"),
])
def test_bad_screens_are_refused_by_name(kwargs, key, text):
    args = {"c_kl": 1e24, "spectral_index": 2.67, "outer_scale_m": 1e4, "height_m": 350e3, **kwargs}
    with pytest.raises(PhysicsInputError, match=text) as info:
        check_screen(**args, orbit_height_m=666e3)
    assert info.value.key == key
    if "height_m" not in kwargs:
        with pytest.raises(PhysicsInputError, match=text):
            PhaseScreen(args["c_kl"], args["spectral_index"], args["outer_scale_m"], args["height_m"])


def test_geomagnetic_latitude_of_the_dipole_pole_and_equator():
    """The IGRF-13 2020 dipole pole (about 80.6 N, 72.7 W) has geomagnetic latitude 90 deg, its antipode -90 deg,
    a point 90 deg from it 0 deg, and a point 30 deg from it 60 deg."""
    from e2esim.scintillation.climatology import POLE_LAT, POLE_LON
    assert math.degrees(geomagnetic_latitude(POLE_LAT, POLE_LON)) == pytest.approx(90.0, abs=1e-6)
    assert math.degrees(geomagnetic_latitude(-POLE_LAT, POLE_LON + math.pi)) == pytest.approx(-90.0, abs=1e-6)
    assert math.degrees(geomagnetic_latitude(POLE_LAT - math.pi / 2, POLE_LON)) == pytest.approx(0.0, abs=1e-9)
    assert math.degrees(geomagnetic_latitude(POLE_LAT - math.pi / 6, POLE_LON)) == pytest.approx(60.0, abs=1e-9)


def test_climatology_morphology():
    """Aarons (1982), ITU-R P.531: high latitudes above mid-latitudes, stronger at solar maximum; equatorial
    post-sunset (21 h) above the BIOMASS dawn (06 h) and dusk (18 h) passes; the percentile orders the values."""
    mag = np.radians([45.0, 70.0])
    mid, high = log10_ckl(mag, 6.0, 80, 150.0)
    assert high > mid + 2.0
    assert log10_ckl(mag[1], 6.0, 80, 150.0) > log10_ckl(mag[1], 6.0, 80, 10.0)
    eq = np.radians(15.0)
    assert log10_ckl(eq, 21.0, 80, 150.0) > log10_ckl(eq, 18.0, 80, 150.0) + 2.0
    assert log10_ckl(eq, 6.0, 80, 150.0) == pytest.approx(log10_ckl(np.radians(45.0), 6.0, 80, 150.0), abs=0.02)
    assert log10_ckl(mag[1], 6.0, 80, 150.0, 90.0) > log10_ckl(mag[1], 6.0, 80, 150.0, 50.0)


@pytest.mark.parametrize("kwargs, text", [({"sunspot_number": 400.0}, "outside the climatology's range"),
                                          ({"percentile": 100.0}, "strictly between 0 and 100")])
def test_climatology_refuses_values_outside_its_range(kwargs, text):
    args = {"mag_lat_rad": 1.0, "local_time_h": 6.0, "day_of_year": 1, "sunspot_number": 100.0, **kwargs}
    with pytest.raises(PhysicsInputError, match=text):
        log10_ckl(**args)
