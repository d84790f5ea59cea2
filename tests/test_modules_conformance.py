"""Every registered module passes the conformance check (e2esim.testing)."""

import pytest

from e2esim import registry
from e2esim.module import Module
from e2esim.params import Param
from e2esim.testing import check_declaration, check_module

# Configurations for modules whose defaults alone are not a complete configuration.
CONFIGS = {
    ("instrument", "gaussian_errors"): {"crosstalk": {"level_db": -30}, "channel_imbalance": {"level_db": -34},
                                        "nesz_db": -27, "centre_frequency_mhz": 435, "bandwidth_mhz": 6},
    ("ionosphere", "faraday_samples"): {"samples_deg": [55.0, 60.0, 65.0]},
    ("requirement", "agb_error_bound"): {"level_margins": True, "tradeoff_curve": True, "curve_points": 9},
    ("orbit", "sun_synchronous"): {"altitude_km": 747.0, "ltan_hours": 18.0, "incidence_near_deg": 33.0,
                                   "incidence_far_deg": 47.0, "site": {"lat_deg": -0.2, "lon_deg": 11.6}},
    ("orbit", "biomass_orbit"): {"site": {"lat_deg": 60.0, "lon_deg": 92.0}, "acquisitions": {"step_days": 90}},
    ("ionosphere", "user_tec"): {"vtec_tecu": 20.0},
    ("ionosphere", "iri_climatology"): {"cache_dir": "off", "method": "thin_shell", "variability_nodes": 3},
}

BUILTIN = [r for r in registry.available() if r.distribution.lower() == "e2esim"]


@pytest.mark.parametrize("reg", BUILTIN, ids=lambda r: f"{r.kind}.{r.type_name}")
def test_builtin_module_conforms(reg):
    check_module(reg.cls, CONFIGS.get((reg.kind, reg.type_name)))


class Broken(Module):
    kind = "scene"
    type_name = "broken"
    summary = "claims a scene but provides nothing"
    params = (Param("size_km", "float", "a size", default=1.0),)  # unit missing
    provides = ("scene",)

    def forward(self, state):
        return state


def test_the_checker_catches_a_broken_module():
    with pytest.raises(AssertionError, match="unit in the name"):
        check_declaration(Broken)
    Broken.params = (Param("size_km", "float", "a size", default=1.0, unit="km"),)
    try:
        with pytest.raises(AssertionError, match="provides 'scene' but left it empty"):
            check_module(Broken)
    finally:
        Broken.params = (Param("size_km", "float", "a size", default=1.0),)
