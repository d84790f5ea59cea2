"""The orbit and ionosphere modules behave like every module: registered, configuration round trip,
pickling, deterministic output."""

import pickle

import numpy as np
import pytest

from e2esim import registry
from e2esim.orbit.modules import BiomassOrbit

NEW = [("orbit", "sun_synchronous"), ("orbit", "biomass_orbit"), ("ionosphere", "iri_climatology"),
       ("ionosphere", "klobuchar_tec"), ("ionosphere", "user_tec")]
CONFIGS = {
    "sun_synchronous": dict(altitude_km=747.0, ltan_hours=18.0, incidence_near_deg=33.0, incidence_far_deg=47.0,
                            site={"lat_deg": 45.0, "lon_deg": -70.0}, swath_samples=2,
                            acquisitions={"start": "2026-01-01", "end": "2026-03-01", "step_days": 30}),
    "biomass_orbit": dict(site={"lat_deg": -10.0, "lon_deg": 20.0}, swath_samples=2,
                          acquisitions={"mode": "timeline", "phase": "tomographic"}),
    "iri_climatology": dict(solar="f107", f107_sfu=120.0, method="thin_shell", cache_dir="off"),
    "klobuchar_tec": dict(tec_variability=0.1),
    "user_tec": dict(vtec_tecu=12.0),
}


@pytest.mark.parametrize("kind, type_name", NEW)
def test_registered_round_trip_and_pickle(kind, type_name):
    cls = registry.lookup(kind, type_name)
    assert cls.kind == kind and cls.type_name == type_name and cls.summary
    module = cls(**CONFIGS[type_name])
    assert cls(**module.config) == module
    clone = pickle.loads(pickle.dumps(module))
    assert clone == module
    assert set(cls.provides) and all(isinstance(r, str) for r in cls.requires)


def test_orbit_timeline_geometry_deterministic():
    a = BiomassOrbit(**CONFIGS["biomass_orbit"]).geometry
    b = pickle.loads(pickle.dumps(BiomassOrbit(**CONFIGS["biomass_orbit"]))).geometry
    assert a.size == 7 * 2 * 2  # 7 tomographic passes x 2 passes x 2 swath positions
    assert set(a.phase) == {"tomographic"}
    assert np.array_equal(a.time_utc, b.time_utc) and np.array_equal(a.k_enu, b.k_enu)
