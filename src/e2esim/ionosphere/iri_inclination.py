"""Magnetic inclination for the IRI from PyIRI's IGRF-13, with the coefficient file read once per process.

PyIRI's ``igrf_library.inclination`` (IGRF-13, Alken et al. 2021, Earth Planets Space 73:49) re-reads
``IGRF13.shc`` with ``np.genfromtxt`` on every call, which costs more than the field synthesis at the few
hundred points of a site climatology. ``inclination`` here runs PyIRI's own steps with the same arithmetic
(``gg_to_geo``, linear interpolation of the 5-year coefficient slots by ``scipy.interpolate.interp1d``,
``synth_values``, the rotation to geodetic X and Z, ``xyz2dhif``) on a table read once and kept as a
read-only float array. It also takes one decimal year per point, so the months of one IRI call share one
synthesis: every step is elementwise per point, so each point's inclination is the same bits as PyIRI's call
for its date alone (tests/test_iri_pyiri_bits.py checks ``np.array_equal``).
"""

from __future__ import annotations

import functools
import os

import numpy as np

from e2esim.ionosphere.pyiri_import import import_pyiri

_IGRF_EPOCHS = np.arange(1900, 2025 + 5, 5)  # the 5-year slots of IGRF13.shc, as PyIRI's inclination
_IGRF_NMAX = 13  # maximum spherical-harmonic degree of IGRF-13
_SYNTHESIS_CHUNK = 16384  # points per synthesis (memory ~ 220 doubles per point for the Legendre table)


def _igrf():
    import_pyiri()  # without PyIRI's plotting (see pyiri_import)
    import PyIRI.igrf_library as igrf

    return igrf


@functools.lru_cache(maxsize=1)
def _igrf_coefficient_slots() -> np.ndarray:
    """Gauss coefficients (nT) of IGRF-13 at its 5-year epochs, shape (195, 26), as PyIRI reads them."""
    PyIRI = import_pyiri()
    path = os.path.join(PyIRI.coeff_dir, "IGRF", "IGRF13.shc")
    if not os.path.isfile(path):
        raise OSError(f"unable to find the IGRF coefficient file of PyIRI: {path}")
    with open(path) as f:
        table = np.genfromtxt(f, delimiter="", skip_header=5)
    slots = table[:, 2:]  # the first two columns are the degree n and order m
    slots.flags.writeable = False
    return slots


def _igrf_coefficients(date_decimal: float) -> np.ndarray:
    """IGRF-13 Gauss coefficients (nT), shape (195,), linearly interpolated (extrapolated after 2025) to a
    decimal year, as PyIRI's ``inclination``."""
    interp1d = _igrf().interpolate.interp1d  # scipy's, as PyIRI's igrf_library imports it
    return interp1d(_IGRF_EPOCHS, _igrf_coefficient_slots(), fill_value="extrapolate")(date_decimal)


def inclination(date_decimal, lon_deg, lat_deg, alt_km: float = 300.0) -> np.ndarray:
    """Magnetic inclination (deg) of IGRF-13 at N points (geodetic lon, lat in deg; height in km), each at
    its own decimal year (a scalar for all, or one per point): PyIRI's ``igrf_library.inclination``."""
    lon = np.asarray(lon_deg, float).ravel()
    lat = np.asarray(lat_deg, float).ravel()
    years = np.broadcast_to(np.asarray(date_decimal, float), lon.shape)
    out = np.empty(lon.shape)
    for a in range(0, lon.size, _SYNTHESIS_CHUNK):
        part = slice(a, a + _SYNTHESIS_CHUNK)
        out[part] = _inclination_chunk(years[part], lon[part], lat[part], alt_km)
    return out


def _inclination_chunk(years, lon, lat, alt_km):
    igrf = _igrf()
    distinct, which = np.unique(years, return_inverse=True)
    if distinct.size == 1:
        coeffs = _igrf_coefficients(float(distinct[0]))  # as PyIRI: one coefficient vector for all points
    else:
        coeffs = np.stack([_igrf_coefficients(float(y)) for y in distinct])[which.ravel()]  # (N, 195)
    radius, colat, sd, cd = igrf.gg_to_geo(np.full(lon.shape, alt_km), 90.0 - lat)
    br, bt, bp = igrf.synth_values(coeffs, radius, colat, lon, _IGRF_NMAX)
    x, y, z = -bt, bp, -br
    x, z = x * cd + z * sd, z * cd - x * sd  # rotate to geodetic north and down
    return igrf.xyz2dhif(x, y, z)[2]
