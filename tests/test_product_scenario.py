"""Product-driven scenarios (issue 26, item 5): the Faraday rotation, the noise and the RFI fraction of a BIOMASS L1
product at a site, its scene centre or a map sweep's cell (e2esim.product_inputs). A product that holds a
climatology's values gives that climatology's numbers; the values read are the product's at the chosen pixel; bad
inputs end with exit status 2, one line and no output."""

from __future__ import annotations

import importlib.util

import netCDF4
import numpy as np
import pytest
import yaml
from product_writers import write_biomass

from e2esim.case import Case
from e2esim.cli import main
from e2esim.error_terms.modules import MAP_CELL_KEYS
from e2esim.product_inputs.modules import BiomassProductNoise, ProductFaraday, ProductRFI
from e2esim.runner.no_effect import no_effect
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario
from e2esim.testing import SMALL, reference_case
from quick_runs import SCENARIOS

SHIPPED = SCENARIOS / "data" / "biomass_l1_siberia"
LUT, ANNOTATION = SHIPPED / "lut.nc", SHIPPED / "annotation.xml"
FARADAY32 = np.float32(np.radians(5.0))
FARADAY_SD32 = np.float32(np.radians(2.0))
NOISE32 = np.float32(10 ** -2.7)


def _lut_value(group: str, name: str, pixel) -> float:
    with netCDF4.Dataset(LUT) as ds:
        return float(ds[f"{group}/{name}"][pixel])


def _case(**inputs):
    instrument = reference_case(("instrument",)).products["instrument"]
    return Case(index=0, inputs=inputs, settings=SMALL, rng=np.random.default_rng(0)).adding(
        {"instrument": instrument})


def test_the_shipped_product_holds_the_generator_values():
    """scenarios/data/biomass_l1_siberia is what tools/make_product_scenario_data.py writes (float32 layers)."""
    tool_file = SCENARIOS.parent / "tools" / "make_product_scenario_data.py"
    spec = importlib.util.spec_from_file_location("make_product_scenario_data", tool_file)
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    SHAPE, faraday_deg, noise_db = tool.SHAPE, tool.faraday_deg, tool.noise_db
    with netCDF4.Dataset(LUT) as ds:
        fr = np.asarray(ds["ionosphereCorrection/faradayRotation"][:], dtype=float)
        noise = np.asarray(ds["denoising/denoisingHV"][:], dtype=float)
    assert fr.shape == SHAPE
    np.testing.assert_array_equal(fr, np.radians(faraday_deg()).astype(np.float32))
    np.testing.assert_array_equal(noise, (10 ** (noise_db() / 10)).astype(np.float32))
    assert LUT.stat().st_size + ANNOTATION.stat().st_size < 200_000


def test_the_values_are_the_products_at_the_chosen_pixel():
    """Site (60.03 N, 92.07 E) is pixel (row 3, column 7) of the grid (60 + 0.01 row, 92 + 0.01 column); without a
    site, the scene centre (8, 10); in a map sweep, the cell's pixel."""
    site = {"lut_file": str(LUT), "lat_deg": 60.031, "lon_deg": 92.069}
    fr = ProductFaraday(**site).forward(_case())["faraday.geophysical"]
    assert fr.mean == _lut_value("ionosphereCorrection", "faradayRotation", (3, 7))
    assert fr.mean == pytest.approx(np.radians(4.0 + 0.3 + 0.35), rel=1e-7)  # the generator's plane
    assert fr.sd == 0.0  # faradayRotationStd is the no-data fill (as the BPS writes it): sd_deg, 0 by default
    centre = ProductFaraday(lut_file=str(LUT), sd_deg=3.0).forward(_case())["faraday.geophysical"]
    assert centre.mean == _lut_value("ionosphereCorrection", "faradayRotation", (8, 10))
    assert centre.sd == pytest.approx(np.radians(3.0), rel=1e-15)
    cell = ProductFaraday(lut_file=str(LUT)).forward(
        _case(**{MAP_CELL_KEYS["lat"]: 60.12, MAP_CELL_KEYS["lon"]: 92.01}))["faraday.geophysical"]
    assert cell.mean == _lut_value("ionosphereCorrection", "faradayRotation", (12, 1))
    made = BiomassProductNoise(**site).forward(_case())
    expected = np.mean([_lut_value("denoising", f"denoising{p}", (3, 7)) for p in ("HH", "HV", "VV")])
    assert made["system"].noise_power == expected
    assert made["system"].noise_power == pytest.approx(10 ** (np.linspace(-28, -26, 20)[7] / 10), rel=1e-7)
    assert made["instrument"].nesz_db == pytest.approx(10 * np.log10(expected), rel=1e-15)
    rfi = ProductRFI(annotation_file=str(ANNOTATION), looks=92)
    assert rfi.time_fraction(None) == 0.035  # the largest percentageAffectedLines (HV 3.5 %)


def _scenarios(tmp_path, product: bool) -> Scenario:
    """A small chain, its Faraday rotation, noise and RFI from the climatology or from a product holding its values."""
    if product:
        write_biomass(tmp_path / "product", shape=(6, 8), faraday=np.full((6, 8), FARADAY32),
                      faraday_std=np.full((6, 8), FARADAY_SD32), noise=NOISE32, rfi_percent={"HH": 1.0, "HV": 3.5})
        ionosphere = {"type": "biomass_product_faraday", "lut_file": "product/lut.nc", "sd_deg": 9.0}
        instrument = {"type": "biomass_product_noise", "lut_file": "product/lut.nc"}
        rfi = {"type": "rfi_from_product", "annotation_file": "product/annotation.xml"}
    else:
        ionosphere = {"type": "gaussian_faraday", "mean_deg": float(np.degrees(float(FARADAY32))),
                      "sd_deg": float(np.degrees(float(FARADAY_SD32)))}
        instrument = {"type": "biomass", "nesz_db": float(10 * np.log10(float(NOISE32)))}
        rfi = {"type": "rfi", "time_fraction_percent": 3.5}
    scenario = {
        "name": "product" if product else "climatology", "scene": {"type": "table1_forest"},
        "instrument": instrument, "ionosphere": ionosphere,
        "calibration": [{"type": "faraday_correction"}],
        "propagation": [{"type": "hv_backscatter_error"},
                        {"type": "backscatter_error_budget", "preset": "biomass_200m"}],
        "error_terms": [{**rfi, "band_fraction_percent": 2.0, "residual_power_db": -35.0, "looks": 92}],
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_error_bound", "level_margins": True}, {"type": "agb_rmse", "max_percent": 20}],
        "simulation": {"mode": "analytic", "seed": 1},
        "sweep": {"parameters": {"scene.forest": ["boreal_50", "boreal_350"]}},
    }
    path = tmp_path / f"{scenario['name']}.yaml"
    path.write_text(yaml.safe_dump(scenario))
    return Scenario.load(path)


def test_a_product_holding_the_climatologys_values_gives_its_numbers(tmp_path):
    """Every scalar of every case equal to 1e-12 (the float32 layers hold the values the climatology is given as,
    in radians and linear power: only the degree and dB round trips differ, at 1e-16)."""
    climatology = run_scenario(_scenarios(tmp_path, False).resolve(), progress=False)
    product = run_scenario(_scenarios(tmp_path, True).resolve(), progress=False)
    for a, b in zip(climatology.cases, product.cases, strict=True):
        numbers = {k for k, v in a.scalars.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}
        assert len(numbers) > 30 and numbers <= set(b.scalars)
        for key in sorted(numbers):
            assert b.scalars[key] == pytest.approx(a.scalars[key], rel=1e-12, abs=1e-300), key
        assert b.scalars["error_term.rfi.time_fraction"] == 0.035
    # the product's faradayRotationStd holds values at every pixel read: the sd_deg the scenario file gives changes
    # nothing, and the run says so (a setting no module read); the climatology's sd_deg is read
    assert [f.message() for f in no_effect(product)] == [
        "ionosphere.sd_deg changes nothing: ionosphere type 'biomass_product_faraday' ignores it (it never reads "
        "sd_deg in this run)"]
    assert no_effect(climatology) == []


def test_sd_deg_is_read_where_the_products_sd_layer_is_empty(tmp_path):
    """Where faradayRotationStd is the no-data fill (as the BPS writes it), sd_deg is the SD: not reported."""
    write_biomass(tmp_path / "p", shape=(6, 8), faraday=np.full((6, 8), FARADAY32), rfi_percent={"HV": 1.0})
    scenario = {"name": "empty_sd", "scene": {"type": "table1_forest"}, "instrument": {"type": "biomass"},
                "ionosphere": {"type": "biomass_product_faraday", "lut_file": "p/lut.nc", "sd_deg": 2.0},
                "propagation": [{"type": "hv_backscatter_error"}], "simulation": {"mode": "analytic", "seed": 1}}
    path = tmp_path / "empty_sd.yaml"
    path.write_text(yaml.safe_dump(scenario))
    result = run_scenario(Scenario.load(path).resolve(), progress=False)
    assert result.cases[0].get("faraday.geophysical").sd == pytest.approx(np.radians(2.0), rel=1e-15)
    assert no_effect(result) == []


def _bad(tmp_path, capsys, *sets, product=None):
    scenario = yaml.safe_load((SCENARIOS / "biomass_default_from_product.yaml").read_text())
    del scenario["sweep"]
    for section in (scenario["instrument"], scenario["ionosphere"], scenario["propagation"][1]):
        section["lut_file"] = str((product or SHIPPED) / "lut.nc")
    scenario["error_terms"][0]["annotation_file"] = str((product or SHIPPED) / "annotation.xml")
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(scenario))
    out = tmp_path / "out"
    args = [a for s in ("simulation.mode=analytic", *sets) for a in ("--set", s)]
    assert main(["run", str(path), "-o", str(out), "--no-progress", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("e2esim: error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()
    return err


def test_a_site_outside_the_product(tmp_path, capsys):
    err = _bad(tmp_path, capsys, "ionosphere.lat_deg=5.27", "ionosphere.lon_deg=-52.92")
    assert "ionosphere.lat_deg" in err and "latitude 5.27, longitude -52.92 deg lies outside the product" in err
    assert "the product covers latitude 60 to 60.15" in err


def test_a_missing_layer(tmp_path, capsys):
    product = write_biomass(tmp_path / "p", faraday=None, rfi_percent={"HV": 1.0})
    err = _bad(tmp_path, capsys, product=product)
    assert "ionosphere.lut_file" in err and "group 'ionosphereCorrection' is missing" in err


def test_wrong_units(tmp_path, capsys):
    product = write_biomass(tmp_path / "p", faraday=np.zeros((12, 20)), rfi_percent={"HV": 1.0},
                            units={("ionosphereCorrection", "faradayRotation"): "deg"})
    err = _bad(tmp_path, capsys, product=product)
    assert "ionosphereCorrection/faradayRotation: units 'deg'; the layout has units 'rad'" in err


def test_an_annotation_without_rfi_reports(tmp_path, capsys):
    product = write_biomass(tmp_path / "p", faraday=np.zeros((12, 20)))
    err = _bad(tmp_path, capsys, product=product)
    assert "error_terms[0].annotation_file" in err and "no RFI report" in err


def test_a_latitude_without_longitude(tmp_path, capsys):
    err = _bad(tmp_path, capsys, "instrument.lat_deg=60.05")
    assert "instrument.lon_deg" in err and "lat_deg and lon_deg go together" in err


@pytest.mark.parametrize("slope_deg", [None, 0.0, 7.5])
def test_the_budget_at_the_products_incidence_slant_range_and_slope(tmp_path, slope_deg):
    """backscatter_error_budget_from_product at pixel (3, 7) is backscatter_error_budget given that pixel's incidence
    (LUT geometry/incidenceAngle), slant range (c tau / 2 of its slantRangeTimeRGC) and cross-track slope (its
    geometry/terrainSlope; None: slope_range_from_product false, the preset's 3 deg stays)."""
    from e2esim.budget.modules import BackscatterErrorBudget
    from e2esim.product_inputs.modules import ProductIncidenceBudget

    lut = LUT if slope_deg in (None, 0.0) else write_biomass(tmp_path / "p", terrain_slope=slope_deg) / "lut.nc"
    with netCDF4.Dataset(lut) as ds:
        incidence = float(ds["geometry/incidenceAngle"][3, 7])
        slant_km = 299792458.0 * float(ds["slantRangeTimeRGC"][7]) / 2 / 1e3
        assert float(ds["geometry/terrainSlope"][3, 7]) == (slope_deg or 0.0)
    case = reference_case(("scene.covariance", "instrument"))
    made = ProductIncidenceBudget(lut_file=str(lut), lat_deg=60.03, lon_deg=92.07,
                                  slope_range_from_product=slope_deg is not None).forward(case)["backscatter.budget"]
    observation = {"incidence_deg": incidence, "slant_range_km": slant_km}
    if slope_deg is not None:
        observation["slope_range_deg"] = slope_deg
    given = BackscatterErrorBudget(observation=observation).forward(case)["backscatter.budget"]
    preset = BackscatterErrorBudget().forward(case)["backscatter.budget"]  # mid-swath 28.4 deg, 666 km orbit
    for name in ("looks", "area_error", "dem_pointing_error_rad", "slope_error_rad"):
        np.testing.assert_allclose(getattr(made, name), getattr(given, name), rtol=1e-12, err_msg=name)
    for term, value in given.relative_sd.items():
        np.testing.assert_allclose(made.relative_sd[term], value, rtol=1e-12, err_msg=term)
    assert not np.allclose(made.looks, preset.looks, rtol=1e-3)  # pixel (3, 7) is at 26.96 deg, not mid-swath


def test_a_slope_given_twice(tmp_path, capsys):
    err = _bad(tmp_path, capsys, "propagation.1.slope_range_from_product=true",
               "propagation.1.observation.slope_range_deg=2.0")
    assert "propagation" in err
    assert "observation.slope_range_deg is given, but the cross-track slope comes from the product" in err
    assert "slope_range_from_product: false" in err
