"""PyIRI is imported without its plotting module (matplotlib): climatology workers stay light."""

import subprocess
import sys

CLIMATOLOGY_IN_A_FRESH_PROCESS = """
import sys
from e2esim.faraday.global_climatology import global_climatology
from e2esim.ionosphere.slant import SlantSettings
from e2esim.orbit.sunsync import SunSynchronousOrbit

clim = global_climatology(SunSynchronousOrbit(666e3), 10.0, months=(6,), f107=(100.0,), incidence_deg=(28.0,),
                          settings=SlantSettings("thin_shell"), lat_range=(40.0, 50.0))
assert clim.faraday.size > 0
print("matplotlib" in sys.modules, "PyIRI" in sys.modules)
import PyIRI
print(callable(PyIRI.plotting.PyIRI_EDP_sample), "matplotlib" in sys.modules)
"""


def test_climatology_worker_does_not_import_matplotlib_and_pyiri_plotting_still_works():
    out = subprocess.run([sys.executable, "-c", CLIMATOLOGY_IN_A_FRESH_PROCESS], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["False", "True", "True", "True"]
