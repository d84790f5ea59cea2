"""The orbit timeline geometry is deterministic and survives pickling (registration, round trip and the
generic conformance checks of all modules are in test_modules_conformance.py)."""

import pickle

import numpy as np

from e2esim.orbit.modules import BiomassOrbit

CONFIG = dict(site={"lat_deg": -10.0, "lon_deg": 20.0}, swath_samples=2,
              acquisitions={"mode": "timeline", "phase": "tomographic"})


def test_orbit_timeline_geometry_deterministic():
    a = BiomassOrbit(**CONFIG).geometry
    b = pickle.loads(pickle.dumps(BiomassOrbit(**CONFIG))).geometry
    assert a.size == 7 * 2 * 2  # 7 tomographic passes x 2 passes x 2 swath positions
    assert set(a.phase) == {"tomographic"}
    assert np.array_equal(a.time_utc, b.time_utc) and np.array_equal(a.k_enu, b.k_enu)
