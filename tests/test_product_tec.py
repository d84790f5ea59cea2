"""The slant TEC of a BIOMASS L1 product as a scenario's ionosphere (issue 26, item 5;
e2esim.product_inputs.tec_modules): a product holding the TEC a climatology gives yields that climatology's
numbers; the mapping to the vertical; bad inputs end with exit status 2 and a message naming the file and layer."""

from __future__ import annotations

import netCDF4
import numpy as np
import pytest
import yaml
from product_writers import write_biomass

from e2esim.cli import main
from e2esim.product_inputs.tec_modules import vertical_from_slant
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario

STEC32 = np.float32(31.7)  # TECU, held exactly by the float32 layer
HEIGHT_M = 850.0
SHELL_KM = 350.0
R = 6371.0088e3


def test_the_vertical_of_a_slant_tec():
    """sin z' = (R + h) sin theta / (R + H): at nadir the slant TEC is the vertical; at theta = 30 deg from sea
    level, z' = asin(R sin 30 deg / (R + 350 km)) = 28.29 deg."""
    assert vertical_from_slant(20.0, 0.0, 0.0, 350e3) == 20.0
    z = np.arcsin(R * 0.5 / (R + 350e3))
    assert np.degrees(z) == pytest.approx(28.29, abs=0.005)
    assert vertical_from_slant(20.0, np.radians(30.0), 0.0, 350e3) == pytest.approx(20.0 * np.cos(z), rel=1e-15)
    # a pixel above sea level sees the shell at a larger zenith angle
    assert vertical_from_slant(20.0, np.radians(30.0), 2000.0, 350e3) < vertical_from_slant(
        20.0, np.radians(30.0), 0.0, 350e3)


def _scenario(tmp_path, ionosphere: dict, name: str) -> Scenario:
    scenario = {
        "name": name, "scene": {"type": "table1_forest"}, "instrument": {"type": "biomass"},
        "orbit": {"type": "biomass_orbit", "swath_samples": 2, "site": {"lat_deg": 60.03, "lon_deg": 92.07},
                  "acquisitions": {"step_days": 120}},
        "ionosphere": {**ionosphere, "shell_height_km": SHELL_KM, "tec_variability": 0.2, "variability_nodes": 3,
                       "field": {"model": "dipole"}},
        "calibration": [{"type": "faraday_correction"}],
        "propagation": [{"type": "hv_backscatter_error"}],
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_error_bound", "level_margins": False}],
        "simulation": {"mode": "analytic", "seed": 1},
        "sweep": {"parameters": {"scene.forest": ["boreal_50", "boreal_350"]}},
    }
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(scenario))
    return Scenario.load(path)


def test_a_product_holding_the_climatologys_tec_gives_its_numbers(tmp_path):
    """user_tec given the vertical TEC of the product's slant TEC at the site's pixel (its incidence and height)
    and biomass_product_tec reading that product: every scalar of every case equal to 1e-12 (only the order of
    the TECU and cos z' products differs)."""
    product = write_biomass(tmp_path / "p", faraday=np.zeros((12, 20)), tec=STEC32, height=HEIGHT_M)
    with netCDF4.Dataset(product / "lut.nc") as ds:
        incidence = float(ds["geometry/incidenceAngle"][3, 7])  # the pixel of (60.03 N, 92.07 E)
    vtec = float(vertical_from_slant(float(STEC32), np.radians(incidence), HEIGHT_M, SHELL_KM * 1e3))
    climatology = run_scenario(_scenario(tmp_path, {"type": "user_tec", "vtec_tecu": vtec}, "climatology").resolve(),
                               progress=False)
    from_product = run_scenario(_scenario(tmp_path, {"type": "biomass_product_tec", "lut_file": "p/lut.nc",
                                                     "lat_deg": 60.03, "lon_deg": 92.07}, "product").resolve(),
                                progress=False)
    assert vtec == pytest.approx(31.7 * 0.9029, rel=1e-4)  # z' = 25.46 deg at 26.96 deg incidence, 850 m
    for a, b in zip(climatology.cases, from_product.cases, strict=True):
        numbers = {k for k, v in a.scalars.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}
        assert len(numbers) > 20 and numbers <= set(b.scalars)
        for key in sorted(numbers):
            assert b.scalars[key] == pytest.approx(a.scalars[key], rel=1e-12, abs=1e-300, nan_ok=True), key
        assert b.scalars["faraday.vtec_mean_tecu"] == pytest.approx(vtec, rel=1e-14)
        assert b.scalars["faraday.stec_mean_tecu"] == pytest.approx(31.7, rel=0.03)  # the passes' lines of sight


def test_cases_interleaved_on_one_module_keep_their_own_tec(tmp_path, monkeypatch):
    """Nothing of a case is kept on the module: a second case, at another pixel, run on the same module in the
    middle of the first one's forward (as two threads would interleave them) leaves the first case's numbers as
    they are alone. On a module that stored the case's VTEC on itself, the first case took the second's TEC."""
    import dataclasses

    from e2esim.error_terms.modules import MAP_CELL_KEYS
    from e2esim.product_inputs.tec_modules import ProductTEC

    tec = np.full((12, 20), 20.0, dtype=np.float32)  # the scene centre, pixel (6, 10): 20 TECU
    tec[3, 7] = 45.0  # the pixel of (60.03 N, 92.07 E)
    write_biomass(tmp_path / "p", faraday=np.zeros((12, 20)), tec=tec, height=HEIGHT_M)

    def vtec_of_first_case():
        result = run_scenario(_scenario(tmp_path, {"type": "biomass_product_tec", "lut_file": "p/lut.nc"},
                                        "centre").resolve(), progress=False)
        return result.cases[0].scalars["faraday.vtec_mean_tecu"]

    alone = vtec_of_first_case()
    seen, inner = [], []
    values_at, field_model = ProductTEC.values_at, ProductTEC.field_model

    def recording_values_at(self, case, names):
        seen.append(case)
        return values_at(self, case, names)

    def interleaving_field_model(self, geometry):
        if len(seen) == 1:  # within the first case's forward: another case at another pixel
            other = dataclasses.replace(seen[0], inputs={**seen[0].inputs, MAP_CELL_KEYS["lat"]: 60.03,
                                                         MAP_CELL_KEYS["lon"]: 92.07})
            inner.append(self.forward(other)["faraday.geophysical"])
        return field_model(self, geometry)

    monkeypatch.setattr(ProductTEC, "values_at", recording_values_at)
    monkeypatch.setattr(ProductTEC, "field_model", interleaving_field_model)
    interleaved = vtec_of_first_case()
    assert len(inner) == 1
    with netCDF4.Dataset(tmp_path / "p" / "lut.nc") as ds:
        incidence = float(ds["geometry/incidenceAngle"][6, 10])
    assert alone == pytest.approx(vertical_from_slant(20.0, np.radians(incidence), HEIGHT_M, SHELL_KM * 1e3),
                                  rel=1e-14)  # the centre's TEC, not the other pixel's
    assert interleaved == alone  # bit for bit


def _refused(tmp_path, capsys, product, **settings) -> str:
    scenario = _scenario(tmp_path, {"type": "biomass_product_tec", "lut_file": str(product / "lut.nc"),
                                    **settings}, "bad")
    out = tmp_path / "out"
    assert main(["run", str(scenario.source), "-o", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("e2esim: error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()  # an error met while the cases run leaves no folder either
    return err


def test_a_product_without_tec(tmp_path, capsys):
    product = write_biomass(tmp_path / "p", faraday=np.zeros((12, 20)), drop=("ionosphereCorrection", "tec"))
    err = _refused(tmp_path, capsys, product)
    assert "ionosphere.lut_file" in err and "lut.nc" in err
    assert "variable ionosphereCorrection/tec is missing" in err and "relativeAzimuthTimeSLC" in err


def test_tec_in_other_units(tmp_path, capsys):
    product = write_biomass(tmp_path / "p", faraday=np.zeros((12, 20)),
                            units={("ionosphereCorrection", "tec"): "el/m2"})
    err = _refused(tmp_path, capsys, product)
    assert "lut.nc: ionosphereCorrection/tec: units 'el/m2'; the layout has units 'TECU'" in err


def test_no_tec_at_the_pixel(tmp_path, capsys):
    tec = np.full((12, 20), 20.0)
    tec[3, 7] = -9999.0  # the no-data fill
    err = _refused(tmp_path, capsys, write_biomass(tmp_path / "p", faraday=np.zeros((12, 20)), tec=tec),
                   lat_deg=60.03, lon_deg=92.07)
    assert "ionosphereCorrection/tec holds no data at pixel (row 3, column 7)" in err
