"""What e2esim computes faster than PyIRI for the IRI equals PyIRI's own, bit for bit: the magnetic inclination
(IGRF-13 read once per process, the months of a call in one synthesis) and the CCIR/URSI coefficient maps."""

import datetime as dt

import numpy as np
import pytest

from e2esim.ionosphere import iri
from e2esim.ionosphere.iri_inclination import inclination

# both hemispheres, the equator, the poles exactly (PyIRI's L'Hopital branches) and just off them
_LON, _LAT = (a.ravel() for a in np.meshgrid(np.arange(-180.0, 180.0, 15.0),
                                             [-90.0, -89.999, -60.0, -23.5, -1e-9, 0.0, 7.0, 45.0, 89.999, 90.0]))
_DATES = [(2010, 1), (2019, 6), (2024, 12), (2026, 3), (2026, 9)]  # interpolated and extrapolated (after 2025)


def _pyiri_inclination(year, month, lon, lat, alt_km):
    import PyIRI
    import PyIRI.igrf_library as igrf
    import PyIRI.main_library as ml

    date = ml.decimal_year(dt.datetime(year, month, 15))
    return igrf.inclination(PyIRI.coeff_dir, date, lon, lat, alt_km, only_inc=True)


@pytest.mark.parametrize("alt_km", [0.0, 300.0, 650.0])
def test_inclination_equals_pyiri_bit_for_bit(alt_km):
    for year, month in _DATES:
        ref = _pyiri_inclination(year, month, _LON, _LAT, alt_km)
        mine = inclination(iri._inclination_date(year, month), _LON, _LAT, alt_km)
        assert np.array_equal(mine, ref)
        assert np.abs(ref).max() > 80  # a real field: near-vertical at the poles


def test_months_in_one_synthesis_equal_pyiri_per_month():
    rng = np.random.default_rng(3)
    order = rng.permutation(_LON.size)  # the months' points interleaved in one call
    months = [_DATES[i % len(_DATES)] for i in range(_LON.size)]
    years = np.array([iri._inclination_date(*months[i]) for i in order])
    mine = inclination(years, _LON[order], _LAT[order], 300.0)
    for m in _DATES:
        sel = np.array([months[i] == m for i in order])
        assert np.array_equal(mine[sel], _pyiri_inclination(*m, _LON[order][sel], _LAT[order][sel], 300.0))


def test_monthly_parameters_with_and_without_given_inclination_are_equal():
    ut = np.linspace(0.0, 23.0, _LON.size)
    given = inclination(iri._inclination_date(2021, 4), _LON, _LAT, 300.0)
    a = iri.monthly_parameters(2021, 4, ut, _LON, _LAT, "ursi")
    b = iri.monthly_parameters(2021, 4, ut, _LON, _LAT, "ursi", given)
    for da, db in zip(a, b):
        for k in da:
            assert np.array_equal(da[k], db[k], equal_nan=True), k


@pytest.mark.parametrize("month", range(1, 13))
def test_coefficient_maps_equal_pyiri_reader_bit_for_bit(month):
    import PyIRI
    import PyIRI.main_library as ml

    ref = ml.read_ccir_ursi_coeff(month, PyIRI.coeff_dir)[:3]
    mine = iri._coefficients(month)
    for a, b in zip(mine, ref):
        assert a.dtype == float and a.shape == b.shape
        assert np.array_equal(a, np.asarray(b, float))
    assert mine[0][0, 0, 0] != mine[1][0, 0, 0]  # CCIR and URSI maps differ


def test_a_coefficient_file_of_another_format_is_left_to_pyiri(tmp_path):
    path = tmp_path / "ccir11.asc"
    path.write_text("  0.52396593E+01-0.56523629E-01\n   523.96593     \n")
    assert iri._read_map_file(str(path)) is None
    path.write_text("  0.52396593E+01-0.56523629E-01\n")
    assert iri._read_map_file(str(path)).tolist() == [5.2396593, -0.056523629]


def test_profiles_do_not_depend_on_the_chunk_size(monkeypatch):
    ut = np.linspace(0.0, 23.0, _LON.size)
    params = iri.daily_parameters(dt.date(2026, 3, 3), ut, _LON, _LAT, [120.0])[0]
    alt_km = np.arange(60.0, 667.0, 10.0)
    one_chunk = iri.density_profiles(params, alt_km)
    monkeypatch.setattr(iri, "_PROFILE_CHUNK", 7)
    assert np.array_equal(iri.density_profiles(params, alt_km), one_chunk)
    assert np.nanmax(one_chunk) > 1e11  # a real ionosphere (electrons/m^3)
