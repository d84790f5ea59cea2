"""NISAR product-driven scenarios (issue 26, item 5; e2esim.product_inputs.nisar_modules): the noise, crosstalk,
Faraday rotation and RFI of a NISAR GCOV, GSLC or RSLC at a site or its scene centre. A product holding a
climatology's values gives that climatology's numbers; the values read are the product's at the chosen pixel; bad
inputs end with exit status 2, one line and no output."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from hostile_files import refused_scenario
from product_writers import write_gcov, write_slc

from e2esim.product_inputs.nisar_modules import NisarProductFaraday, NisarProductInstrument, NisarProductRFI
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario
from e2esim.units import level_db_from_variance, variance_from_level_db

CROSSTALK = np.complex64(0.012 + 0.005j)
V_DELTA = abs(complex(CROSSTALK)) ** 2  # the tables' |delta|^2, as read (complex64 widened)
NES0 = np.float32(10 ** -2.6)
NISAR_HZ, PRESET_HZ = 1257.5e6, 1257e6  # the product's L-band centre; the nisar preset's


def test_the_values_are_the_products_at_the_chosen_pixel(tmp_path):
    """A GCOV: the site's pixel on the UTM grid (row 3, column 7), the scene centre without a site; nes0 rising
    across the swath (bilinear, as the uncertainty product reads it); zero tables keep the preset's crosstalk."""
    nes0 = np.broadcast_to(np.linspace(0.001, 0.004, 4), (3, 4)).astype(np.float32)
    gcov = write_gcov(tmp_path / "g.h5", crosstalk=CROSSTALK, faraday=0.004, nes0=nes0,
                      rfi={"HH": 0.02, "HV": 0.05, "VV": np.nan})
    site = {"product_file": str(gcov), "lat_deg": 59.98679, "lon_deg": 93.00251}  # x 500140, y 6649940 m
    made = NisarProductInstrument(**site)
    made.setup()
    x = 500000.0 + 20.0 * 7  # column 7; nes0's x axis 499000 to 501000 m
    assert made.pixel.pixel == (3, 7)
    assert made.model.noise_power == pytest.approx(np.interp(x, np.linspace(499000.0, 501000.0, 4),
                                                             nes0[0].astype(np.float64)), rel=1e-12)
    assert made.model.crosstalk_level == pytest.approx(V_DELTA, rel=1e-15)
    assert made.description.nesz_db == pytest.approx(10 * np.log10(made.model.noise_power), rel=1e-15)
    centre = NisarProductInstrument(product_file=str(gcov))
    centre.setup()
    assert centre.pixel.pixel == (7, 10)
    preset = NisarProductInstrument(product_file=str(write_gcov(tmp_path / "zero.h5", crosstalk=0.0)))
    preset.setup()
    assert preset.model.crosstalk_level == pytest.approx(variance_from_level_db(-30.0, "three_sigma_amplitude"))
    faraday = NisarProductFaraday(product_file=str(gcov), sd_deg=0.5)
    faraday.setup()
    fr = faraday.forward({})["faraday.geophysical"]
    assert fr.mean == 0.004 and fr.sd == pytest.approx(np.radians(0.5), rel=1e-15)
    rfi = NisarProductRFI(product_file=str(gcov), looks=50)
    rfi.setup()
    assert rfi.time_fraction(None) == 0.05  # the largest finite rfiLikelihood (VV's detection skipped)


def test_an_rslcs_crosstalk_is_read_at_its_scene_centres_slant_range(tmp_path):
    """Column 10 of the RSLC lies at 850.1 km: between the tables' 0.01 (850.06 km) and 0.012 (860 km)."""
    rslc = write_slc(tmp_path / "r.h5", "RSLC", crosstalk=[0, 0, 0.01, 0.012],
                     crosstalk_axis=[840e3, 850.05e3, 850.06e3, 860e3])
    made = NisarProductInstrument(product_file=str(rslc))
    made.setup()
    delta = np.interp(850.1e3, [850.06e3, 860e3], [np.float32(0.01), np.float32(0.012)])
    assert made.pixel.pixel == (7, 10)
    assert made.model.crosstalk_level == pytest.approx(delta**2, rel=1e-12)


def _scenario(tmp_path, product: bool) -> Scenario:
    """A small NISAR chain, its noise, crosstalk, Faraday rotation and RFI from the preset and a climatology, or from
    a GCOV holding their values."""
    if product:
        write_gcov(tmp_path / "gcov.h5", crosstalk=CROSSTALK, faraday=0.004, nes0=NES0, rfi=0.05)
        instrument = {"type": "nisar_product_instrument", "product_file": "gcov.h5",
                      "crosstalk": {"level_db": -30.0}}
        ionosphere = {"type": "nisar_product_faraday", "product_file": "gcov.h5", "sd_deg": 0.5}
        rfi = {"type": "rfi_from_nisar_product", "product_file": "gcov.h5"}
    else:
        instrument = {"type": "nisar", "nesz_db": float(10 * np.log10(float(NES0))),
                      "crosstalk": {"level_db": float(level_db_from_variance(V_DELTA, "three_sigma_amplitude"))}}
        k = (NISAR_HZ / PRESET_HZ) ** 2  # from the product's frequency to the preset's
        ionosphere = {"type": "gaussian_faraday", "mean_deg": float(np.degrees(k * 0.004)), "sd_deg": k * 0.5}
        rfi = {"type": "rfi", "time_fraction_percent": 5.0}
    scenario = {
        "name": "product" if product else "climatology", "scene": {"type": "table1_forest"},
        "instrument": instrument, "ionosphere": ionosphere,
        "propagation": [{"type": "hv_backscatter_error"}],
        "error_terms": [{**rfi, "residual_power_db": -35.0, "looks": 50}],
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_error_bound"}],
        "simulation": {"mode": "analytic", "seed": 1},
    }
    path = tmp_path / f"{scenario['name']}.yaml"
    path.write_text(yaml.safe_dump(scenario))
    return Scenario.load(path)


def test_a_product_holding_the_climatologys_values_gives_its_numbers(tmp_path):
    """Every scalar equal to 1e-12, or to 1e-18 absolute (the product's values are the climatology's up to the dB
    and degree round trips, 1e-16; the crosstalk terms are equal, as the preset's at 0 dB offsets). The absolute
    tolerance is for ``analytic.var_faraday_spread``, about 1e-15 (m^2/m^2)^2 found as a difference of squares near
    1e-6: a rounding of the rotation moves it by 5e-9 of itself, 1e-23 absolute."""
    climatology = run_scenario(_scenario(tmp_path, False).resolve(), progress=False)
    product = run_scenario(_scenario(tmp_path, True).resolve(), progress=False)
    for a, b in zip(climatology.cases, product.cases, strict=True):
        numbers = {k for k, v in a.scalars.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}
        assert len(numbers) > 20 and numbers <= set(b.scalars)
        for key in sorted(numbers):
            assert b.scalars[key] == pytest.approx(a.scalars[key], rel=1e-12, abs=1e-18), key
        assert b.scalars["error_term.rfi.time_fraction"] == 0.05


def _refused(tmp_path, capsys, section: str, module: dict, product) -> str:
    scenario = {"scene": {"type": "table1_forest"}, "instrument": {"type": "nisar"},
                "ionosphere": {"type": "gaussian_faraday", "sd_deg": 0.5},
                "propagation": [{"type": "hv_backscatter_error"}], "retrieval": {"type": "power_law"},
                "requirements": [{"type": "agb_error_bound"}], "simulation": {"mode": "analytic"}}
    module = {**module, "product_file": str(product)}
    scenario[section] = [module] if section == "error_terms" else module
    return refused_scenario(tmp_path, capsys, scenario)


@pytest.mark.parametrize(("section", "module", "write", "expected"), [
    ("ionosphere", {"type": "nisar_product_faraday"}, lambda p: write_gcov(p),
     ["ionosphere.product_file", "faradayRotation is 0.0", "not applied"]),
    ("error_terms", {"type": "rfi_from_nisar_product"}, lambda p: write_gcov(p, rfi=np.nan),
     ["error_terms[0].product_file", "every rfiLikelihood is NaN"]),
    ("instrument", {"type": "nisar_product_instrument", "lat_deg": 10.0, "lon_deg": 20.0}, lambda p: write_gcov(p),
     ["instrument.lat_deg", "latitude 10, longitude 20 deg", "lies outside the product"]),
    ("instrument", {"type": "nisar_product_instrument", "lat_deg": 60.0, "lon_deg": 93.0},
     lambda p: write_slc(p, "RSLC"), ["instrument.product_file", "RSLC's radar grid has no geolocation"]),
    ("instrument", {"type": "nisar_product_instrument"},
     lambda p: write_gcov(p, drop="/science/LSAR/GCOV/metadata/calibrationInformation/frequencyA/nes0"),
     ["instrument.product_file", "group", "frequencyA/nes0 is missing"]),
    ("instrument", {"type": "nisar_product_instrument"}, lambda p: write_gcov(p, truncate=0.5),
     ["instrument.product_file", "truncated"]),
])
def test_bad_nisar_inputs(tmp_path, capsys, section, module, write, expected):
    err = _refused(tmp_path, capsys, section, module, write(tmp_path / "p.h5"))
    for text in expected:
        assert text in err
