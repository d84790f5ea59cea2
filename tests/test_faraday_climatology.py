"""Faraday-rotation climatology: variability nodes, the distribution object, the HDF5 cache, the global
table and the ionosphere modules in a chain."""

import os

import numpy as np
import pytest

from e2esim.case import Case, Services
from e2esim.errors import ConfigError
from e2esim.faraday import climatology as clim_mod
from e2esim.faraday.climatology import (
    FaradayClimatology,
    climatology_from_integrals,
    site_path_integrals,
    weighted_percentiles,
)
from e2esim.faraday.climatology_modules import IRIClimatologyModule, KlobucharModule, UserTECModule
from e2esim.faraday.distribution import EmpiricalFaraday
from e2esim.faraday.global_climatology import global_climatology
from e2esim.instrument.modules import BiomassInstrument
from e2esim.io.array_cache import ArrayCache, default_cache_dir, open_cache, resolve_cache_dir
from e2esim.ionosphere.propagation import faraday_rotation
from e2esim.ionosphere.slant import PathIntegrals, SlantSettings
from e2esim.ionosphere.variability import lognormal_nodes
from e2esim.orbit.modules import BiomassOrbit
from e2esim.orbit.sunsync import SunSynchronousOrbit
from e2esim.settings import SimulationSettings

SITE = {"name": "boreal", "lat_deg": 60.0, "lon_deg": 92.0}
FEW_DATES = {"start": "2026-02-01", "end": "2026-11-30", "step_days": 90}


def _case(geometry):
    case = Case(0, {}, SimulationSettings(), np.random.default_rng(0), services=Services(cache=open_cache))
    return case.adding({"geometry": geometry, **BiomassInstrument().forward(case)})


def test_lognormal_nodes_keep_the_median_and_the_log_variance():
    x = lognormal_nodes(0.25, 15)
    s2 = np.log1p(0.25**2)
    assert np.median(x) == pytest.approx(1.0)
    assert np.mean(np.log(x) ** 2) == pytest.approx(s2, rel=1e-12)
    assert np.std(x) / np.mean(x) == pytest.approx(0.25, rel=0.03)
    assert np.all(lognormal_nodes(0.0, 5) == 1)
    with pytest.raises(Exception, match="TEC variability"):
        lognormal_nodes(-0.1, 5)


def test_weighted_percentiles():
    v = np.arange(10.0)
    assert weighted_percentiles(v, np.ones(10), [50])[0] == pytest.approx(4.5)
    w = np.r_[np.full(5, 3.0), np.ones(5)]  # more weight on the small values moves the median down
    assert weighted_percentiles(v, w, [50])[0] < 4.5


def test_climatology_object_is_an_empirical_faraday_with_consistent_moments():
    f, stec = 435e6, np.array([5e16, 10e16, 20e16])
    bk = np.array([3e-5, 3.2e-5, 2.9e-5])
    p = PathIntegrals(stec[None] * 0.9, stec[None], (stec * bk)[None], bk, np.zeros(3), (70.0,), "thin_shell")
    c = climatology_from_integrals(p, 0, f, 0.3, 11, acquisition_weight=np.array([1, 1, 2.0]))
    assert isinstance(c, EmpiricalFaraday)
    omega = faraday_rotation(bk, stec, f)
    assert np.allclose(c.acquisition_omega, omega)
    x = lognormal_nodes(0.3, 11)
    w = np.array([0.25, 0.25, 0.5])
    assert c.mean_rad == pytest.approx(np.dot(w, omega) * x.mean())
    assert c.sd_rad ** 2 + c.mean_rad ** 2 == pytest.approx(np.dot(w, omega**2) * np.mean(x**2))
    k = np.array([2, 4])
    direct = np.array([np.dot(w, np.mean(np.exp(1j * kk * omega[:, None] * x[None]), 1)) for kk in k])
    assert np.allclose(c.circular_moment(k), direct)
    s = c.summary()
    assert s["omega_p50_deg"] == pytest.approx(np.degrees(weighted_percentiles(c.samples, c.weights, [50])[0]))
    assert s["range_delay_mean_m"] == pytest.approx(np.dot(w, 40.308 * stec / f**2), rel=1e-4)
    draws = c.sample(np.random.default_rng(1), 1000)
    assert set(np.round(draws, 12)) <= set(np.round(c.samples, 12))


def test_a_site_climatology_is_a_block_of_one_with_the_one_case_formulas_bit_for_bit(seed):
    """Issue 27: a climatology's statistics come from the block's row statistics (a case alone is a block of one);
    for a site's climatology, with equal or unequal acquisition weights, they are bit for bit the one-case formulas
    of ``EmpiricalFaraday`` (np.dot, np.interp, the circular moments)."""
    from e2esim.faraday.distribution import EVEN_WEIGHTS, PERCENTILES, FaradayDistribution

    rng = np.random.default_rng(seed)
    for trial in range(12):
        n = int(rng.integers(1, 40)) if trial < 10 else int(rng.integers(200, 2000))
        far = rng.normal(0.0, 1.0, n) * 10 ** rng.uniform(16.0, 18.0)
        stec = np.abs(rng.normal(1e17, 5e16, n))
        integrals = PathIntegrals(0.8 * stec[None], stec[None], far[None], np.full(n, 1e-5), np.full(n, 0.3),
                                  (120.0,), "thin_shell")
        weights = None if trial % 2 else rng.uniform(0.1, 2.0, n)
        c = climatology_from_integrals(integrals, 0, 435e6, 0.2, int(rng.integers(3, 9)), weights, ["dawn"] * n)
        assert c.case_shape == () and len(c) == 1 and c.item(0) is c
        assert c.mean_rad == EmpiricalFaraday.mean_rad.fget(c) and c.sd_rad == EmpiricalFaraday.sd_rad.fget(c)
        assert c.mean_abs_rad == np.dot(c.probabilities, np.abs(c.samples))
        assert c.trig_moments() == FaradayDistribution.trig_moments(c)
        phi = np.real(c.circular_moment(np.array([2.0, 4.0, 6.0, 8.0])))
        moments = np.array([1.0, phi[0], (1 + phi[1]) / 2, (3 * phi[0] + phi[2]) / 4, (3 + 4 * phi[1] + phi[3]) / 8])
        assert np.array_equal(c.even_quadrature()[1], EVEN_WEIGHTS @ moments)
        scalars = c.scalars()
        expected = np.degrees(weighted_percentiles(c.samples, c.probabilities, PERCENTILES))
        assert [scalars[f"omega_p{p:g}_deg".replace(".", "_")] for p in PERCENTILES] == expected.tolist()
        w = c.acquisition_weight / c.acquisition_weight.sum()
        assert scalars["stec_mean_tecu"] == np.dot(w, c.stec) / 1e16
        assert scalars["mean_deg"] == np.degrees(c.mean_rad) and "mean_deg" not in c.summary()


def test_cache_location(monkeypatch, tmp_path):
    monkeypatch.setenv("E2ESIM_CACHE", str(tmp_path / "c"))
    assert default_cache_dir() == tmp_path / "c"
    assert resolve_cache_dir(None) == tmp_path / "c"
    assert resolve_cache_dir("off") is None
    monkeypatch.delenv("E2ESIM_CACHE")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "x"))
    assert default_cache_dir() == tmp_path / "x" / "e2esim"


def test_site_integrals_cached_and_read_back(tmp_path, monkeypatch):
    geo = BiomassOrbit(site=SITE, swath_samples=2, acquisitions=FEW_DATES).geometry
    settings = SlantSettings("thin_shell")
    first = site_path_integrals(geo, [70.0], settings, ArrayCache(tmp_path))
    files = list(tmp_path.iterdir())
    assert len(files) == 1 and files[0].suffix == ".h5" and not any(f.name.endswith(".tmp") for f in files)

    def boom(*a, **k):
        raise AssertionError("recomputed instead of reading the cache")

    monkeypatch.setattr(clim_mod, "path_integrals", boom)
    again = site_path_integrals(geo, [70.0], settings, ArrayCache(tmp_path))
    assert np.array_equal(again.faraday, first.faraday) and np.array_equal(again.vtec, first.vtec)
    with pytest.raises(AssertionError, match="recomputed"):
        site_path_integrals(geo, [180.0], settings, ArrayCache(tmp_path))  # another key


def test_iri_module_in_a_chain(tmp_path):
    geo = BiomassOrbit(site=SITE, swath_samples=2, passes="dusk", acquisitions=FEW_DATES).geometry
    case = _case(geo)
    lo = IRIClimatologyModule(solar="min", method="thin_shell", cache_dir=str(tmp_path)).forward(case)[
        "faraday.geophysical"
    ]
    hi = IRIClimatologyModule(solar="max", method="thin_shell", cache_dir=str(tmp_path)).forward(case)[
        "faraday.geophysical"
    ]
    assert isinstance(lo, FaradayClimatology) and lo.samples.size == geo.size * 15
    assert 0 < lo.mean_rad < hi.mean_rad  # northern hemisphere: B.k > 0; more TEC at solar maximum
    assert lo.f107 == 70.0 and hi.f107 == 180.0 and lo.frequency_hz == 435e6
    assert set(lo.pass_label) == {"dusk"}


def test_fallback_and_user_tec_modules():
    geo = BiomassOrbit(site=SITE, swath_samples=2, acquisitions=FEW_DATES).geometry
    case = _case(geo)
    user = UserTECModule(vtec_tecu=10.0, tec_variability=0.0).forward(case)["faraday.geophysical"]
    # thin shell: Omega = A B.k (10 TECU / cos chi) / f^2 for every acquisition
    assert np.allclose(user.stec, 10e16 / np.cos(geo.pierce_zenith))
    assert user.sd_rad > 0  # from the spread of geometry alone
    klob = KlobucharModule().forward(case)["faraday.geophysical"]
    assert np.all(klob.vtec / 1e16 >= 9.2)
    assert np.all(np.sign(klob.acquisition_omega) == np.sign(user.acquisition_omega))


def test_module_bad_input_names_the_key():
    with pytest.raises(ConfigError, match="f107_sfu: is null, but solar is 'f107'; give f107_sfu when solar is 'f107'"):
        IRIClimatologyModule(solar="f107")
    with pytest.raises(ConfigError, match="method"):
        IRIClimatologyModule(method="raytrace")
    with pytest.raises(ConfigError, match="bottom_height_km: 150 is not below shell_height_km = 120; expected "
                       "bottom_height_km < shell_height_km"):
        IRIClimatologyModule(bottom_height_km=150.0, shell_height_km=120.0)
    with pytest.raises(ConfigError, match="tec_variability"):
        UserTECModule(vtec_tecu=10.0, tec_variability=-0.1)


def test_global_climatology_table_and_cache(tmp_path):
    orbit = SunSynchronousOrbit(666e3)
    kw = dict(step_deg=15.0, months=(3, 9), f107=(70.0, 180.0), incidence_deg=(28.0,),
              settings=SlantSettings("thin_shell"), cache=ArrayCache(tmp_path))
    c = global_climatology(orbit, **kw)
    assert c.faraday.shape == (2, 2, 2, 1, 12, 24)
    valid = np.isfinite(c.faraday)
    assert not valid[..., -1, :].any()  # 82.5 N: beyond the reach of the left-looking dawn-dusk orbit
    assert valid[..., 0, :].all()  # 82.5 S: left looks towards the south pole at the southern turn
    assert valid[..., 1:-1, :].all()
    stats = c.statistics(435e6, 0.25)
    assert stats["sd_deg"].shape == (2, 2, 12, 24)
    assert np.nanmean(stats["mean_abs_deg"][:, 1]) > np.nanmean(stats["mean_abs_deg"][:, 0])
    again = global_climatology(orbit, **kw)
    assert np.array_equal(again.faraday, c.faraday, equal_nan=True)
    assert len(os.listdir(tmp_path)) == 1


def test_latitude_band_and_missing_orbit(tmp_path):
    orbit = SunSynchronousOrbit(666e3)
    band = global_climatology(orbit, 10.0, months=(6,), f107=(100.0,), incidence_deg=(28.0,),
                              settings=SlantSettings("thin_shell"), lat_range=(40.0, 70.0), cache=None)
    assert band.lat_deg.tolist() == [45.0, 55.0, 65.0] and band.faraday.shape[-2:] == (3, 36)
    from e2esim.runner.scenario import Scenario

    sc = Scenario({"scene": {"type": "table1_forest"}, "instrument": {"type": "biomass"},
                   "ionosphere": {"type": "iri_climatology", "cache_dir": str(tmp_path)}})
    with pytest.raises(ConfigError, match=r"ionosphere type 'iri_climatology' needs the product 'geometry', which no "
                       r"stage of this chain provides.*modules that provide it: orbit.biomass_orbit, "
                       r"orbit.biomass_orbit_file, orbit.orbit_file, orbit.sun_synchronous") as info:
        sc.resolve()
    assert "<scenario>: ionosphere" in str(info.value)


def test_global_table_cell_equals_a_direct_site_computation():
    import datetime as dt

    from e2esim.ionosphere.slant import path_integrals
    from e2esim.orbit.geometry import view_geometry

    orbit = SunSynchronousOrbit(666e3)
    settings = SlantSettings("thin_shell")
    band = global_climatology(orbit, 10.0, months=(6,), f107=(100.0,), incidence_deg=(28.0,), settings=settings,
                              lat_range=(40.0, 50.0))
    for p, pass_name in enumerate(band.passes):
        j = 20
        lon = band.lon_deg[j]
        g = view_geometry(orbit, np.radians(45.0), np.radians(lon), np.radians(28.0), pass_name)
        ut = np.mod(g.local_time_h - lon / 15.0, 24.0)
        direct = path_integrals(g.target_ecef[None], g.satellite_ecef[None], dt.date(band.year, 6, 15), [ut],
                                (100.0,), settings)
        assert band.faraday[p, 0, 0, 0, 0, j] == pytest.approx(direct.faraday[0, 0], rel=2e-6)  # float32 table
        assert band.vtec[p, 0, 0, 0, 0, j] == pytest.approx(direct.vtec[0, 0], rel=2e-6)
