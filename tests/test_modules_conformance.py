"""Every registered module passes the conformance check (e2esim.testing)."""

import itertools
from pathlib import Path

import pytest

from e2esim import products as P
from e2esim import registry
from e2esim.module import Stage
from e2esim.params import Param
from e2esim.testing import check_declaration, check_module

_ORBITS = Path(__file__).resolve().parents[1] / "scenarios" / "orbits"
_PRODUCT = Path(__file__).resolve().parents[1] / "scenarios" / "data" / "biomass_l1_siberia"

# Configurations for modules whose defaults alone are not a complete configuration.
CONFIGS = {
    ("instrument", "gaussian_errors"): {"crosstalk": {"level_db": -30}, "channel_imbalance": {"level_db": -34},
                                        "nesz_db": -27, "centre_frequency_mhz": 435, "bandwidth_mhz": 6},
    ("ionosphere", "faraday_samples"): {"samples_deg": [55.0, 60.0, 65.0]},
    ("requirement", "agb_error_bound"): {"level_margins": True, "tradeoff_curve": True, "curve_points": 9},
    ("orbit", "sun_synchronous"): {"altitude_km": 747.0, "ltan_hours": 18.0, "incidence_near_deg": 33.0,
                                   "incidence_far_deg": 47.0, "site": {"lat_deg": -0.2, "lon_deg": 11.6}},
    ("orbit", "biomass_orbit"): {"site": {"lat_deg": 60.0, "lon_deg": 92.0}, "acquisitions": {"step_days": 90}},
    ("orbit", "biomass_orbit_file"): {"file": str(_ORBITS / "biomass_circular_siberia.EOF"),
                                      "site": {"lat_deg": 60.0, "lon_deg": 92.0}},
    ("orbit", "orbit_file"): {"file": str(_ORBITS / "biomass_like.tle"), "incidence_near_deg": 23.0,
                              "incidence_far_deg": 34.0, "site": {"lat_deg": 60.0, "lon_deg": 92.0}},
    ("ionosphere", "user_tec"): {"vtec_tecu": 20.0},
    ("ionosphere", "iri_climatology"): {"cache_dir": "off", "method": "thin_shell", "variability_nodes": 3},
    ("ionosphere", "global_climatology"): {"lat_deg": 5.0, "lon_deg": 15.0, "month": 3, "grid_step_deg": 10.0,
                                           "table_lat_range_deg": [-10, 20], "table_lon_range_deg": [0, 30],
                                           "variability_nodes": 3, "cache_dir": "off"},
    ("scene", "agb_map"): {"lat_deg": 60.5, "lon_deg": 92.5},
    ("error_terms", "added_noise"): {"power_db": -30.0},
    ("error_terms", "gain_error"): {"sd_db": 0.2},
    ("error_terms", "extra_variance"): {"relative_sd_percent": 1.0},
    ("ionosphere", "biomass_product_faraday"): {"lut_file": str(_PRODUCT / "lut.nc")},
    ("ionosphere", "biomass_product_tec"): {"lut_file": str(_PRODUCT / "lut.nc"), "variability_nodes": 3},
    ("instrument", "biomass_product_noise"): {"lut_file": str(_PRODUCT / "lut.nc")},
    # the shipped annotation's distortion lists are zeros (as the BPS writes them unconfigured): the scenario's kept
    ("instrument", "biomass_product_distortion"): {"annotation_file": str(_PRODUCT / "annotation.xml"),
                                                   "crosstalk_from_product": False,
                                                   "channel_imbalance_from_product": False},
    ("instrument", "biomass_product_instrument"): {"lut_file": str(_PRODUCT / "lut.nc"),
                                                   "annotation_file": str(_PRODUCT / "annotation.xml"),
                                                   "crosstalk_from_product": False,
                                                   "channel_imbalance_from_product": False},
    ("propagation", "backscatter_error_budget_from_product"): {"lut_file": str(_PRODUCT / "lut.nc")},
    ("error_terms", "rfi_from_product"): {"annotation_file": str(_PRODUCT / "annotation.xml"), "looks": 92},
}

BUILTIN = [r for r in registry.available() if r.distribution.lower() == "e2esim"]


def _multichannel_case():
    """The reference case with a multi-channel backscatter.error (the default chain's is HV only)."""
    from e2esim.distortion.polarimetric_modules import PolarimetricErrorPropagation
    from e2esim.testing import reference_case

    stage = PolarimetricErrorPropagation()
    case = reference_case(stage.needs)
    return case.adding(stage.forward(case))


def _stack_case(with_model: bool, channels: str = "hv", budget: bool = False):
    """A reference case with the multi-pass scene (and the stack error model of ``channels``, and its error
    budget) that the default chain lacks."""
    from e2esim.stack.modules import RVoGStackScene, StackBackscatterError, StackErrorBudget
    from e2esim.testing import reference_case

    case = reference_case(("scene.covariance", "system.residual", "faraday.residual", "instrument"))
    case = case.adding({"scene.stack": RVoGStackScene().forward(case)["scene.stack"]})
    if with_model:
        case = case.adding(StackBackscatterError(system_error_correlation=0.5, channels=channels).forward(case))
    if budget:
        case = case.adding(StackErrorBudget().forward(case))
    return case


CASES = {
    ("retrieval", "multichannel_power_law"): _multichannel_case,
    ("propagation", "stack_backscatter_error"): lambda: _stack_case(False),
    ("propagation", "stack_error_budget"): lambda: _stack_case(True),
    ("retrieval", "stack_power_law"): lambda: _stack_case(True),
    ("retrieval", "stack_multichannel_power_law"): lambda: _stack_case(True, "all", budget=True),
}
"""Reference cases for modules that need products the default chain does not make."""


NISAR_PRODUCT_CONFIGS = {
    ("instrument", "nisar_product_instrument"): {},
    ("ionosphere", "nisar_product_faraday"): {"sd_deg": 0.5},
    ("error_terms", "rfi_from_nisar_product"): {"looks": 50},
}
"""Modules that read a NISAR product: given the generated GCOV of ``nisar_gcov`` as their product_file."""


@pytest.fixture(scope="module")
def nisar_gcov(tmp_path_factory) -> str:
    """A generated NISAR GCOV (tests/product_writers.py) whose processor removed a rotation and measured crosstalk."""
    from product_writers import write_gcov

    return str(write_gcov(tmp_path_factory.mktemp("nisar") / "gcov.h5", crosstalk=0.01, faraday=0.004))


@pytest.mark.parametrize("reg", BUILTIN, ids=lambda r: f"{r.kind}.{r.type_name}")
def test_builtin_module_conforms(reg, request):
    key = (reg.kind, reg.type_name)
    make_case = CASES.get(key)
    config = CONFIGS.get(key)
    if key in NISAR_PRODUCT_CONFIGS:
        config = {**NISAR_PRODUCT_CONFIGS[key], "product_file": request.getfixturevalue("nisar_gcov")}
    check_module(reg.cls, config, make_case() if make_case else None)


class Broken(Stage):
    kind = "scene"
    type_name = "broken"
    summary = "claims a scene but provides nothing"
    params = (Param("size_km", "float", "a size", default=1.0),)  # unit missing
    provides = (P.SCENE,)

    def forward(self, case):
        return {}


class WrongType(Stage):
    kind = "scene"
    type_name = "wrong_type"
    summary = "provides a scene that is not a covariance"
    provides = (P.SCENE,)

    def forward(self, case):
        return {"scene.covariance": [[1.0]]}


_CALLS = itertools.count()  # a new seed at every call: what a module drawing outside the case's generator does


class Random(Stage):
    kind = "scene"
    type_name = "random"
    summary = "draws from a generator of its own"
    provides = (P.SCENE,)

    def forward(self, case):
        import numpy as np

        from e2esim.scene.covariance import ScatteringCovariance

        power = np.random.default_rng(next(_CALLS)).uniform(0.01, 0.1)  # not the case's generator: differs per call
        return {"scene.covariance": ScatteringCovariance.from_powers(1.0, power, 0.5, 0.1, 0.0)}


def test_the_checker_catches_a_broken_module():
    with pytest.raises(AssertionError, match="unit in the name"):
        check_declaration(Broken)
    Broken.params = (Param("size_km", "float", "a size", default=1.0, unit="km"),)
    try:
        with pytest.raises(AssertionError, match=r"scene type 'broken' returned nothing; it declares scene.covariance"):
            check_module(Broken)
    finally:
        Broken.params = (Param("size_km", "float", "a size", default=1.0),)
    with pytest.raises(AssertionError, match=r"returned a list for product 'scene.covariance', which must be a "
                       r"ScatteringCovariance"):
        check_module(WrongType)
    with pytest.raises(AssertionError, match="forward is not deterministic"):
        check_module(Random)
