"""The RFI error term (issue 24, Build 4): the notched spectrum's impulse response against its closed forms, the
three sources it adds to the error model, the affected-fraction map, and bad inputs (exit status 2)."""

import math

import numpy as np
import pytest
import yaml

from e2esim import api
from e2esim.cli import main
from e2esim.error_terms.effects import FixedGain
from e2esim.error_terms.notch import BINS, OVERSAMPLE, impulse_power, notch_response, notched_spectrum
from e2esim.error_terms.rfi_modules import RFITerm
from e2esim.errors import ConfigError
from e2esim.testing import check_module


def test_unnotched_response_is_the_sinc_of_cumming_and_wong():
    """Rectangular spectrum: |sinc|^2 with PSLR -13.26 dB and ISLR -9.68 dB (Cumming & Wong 2005, Section 2.6; the
    sampled response is within 0.01 dB at 32x oversampling)."""
    r = notch_response(0.0, "centre")
    assert r.pslr_db == pytest.approx(-13.26, abs=0.01)
    assert r.islr_db == pytest.approx(-9.68, abs=0.01)
    assert (r.energy_ratio, r.looks_factor, r.peak_loss_db, r.resolution_ratio) == (1.0, 1.0, 0.0, 1.0)


@pytest.mark.parametrize("fraction", [0.05, 0.1, 0.2])
def test_centre_notch_response_is_the_difference_of_two_sincs(fraction):
    """A notch of width fB at the centre: h(t) = B sinc(Bt) - fB sinc(fBt) (the band minus the notch), sampled at
    t = k / (OVERSAMPLE B); the DFT response agrees to 1e-6 of its peak (the spectrum is sampled on BINS bins)."""
    power = impulse_power(notched_spectrum(fraction, "centre"))
    t = (np.arange(power.size) - power.size // 2) / OVERSAMPLE  # in units of 1/B
    h = np.sinc(t) - fraction * np.sinc(fraction * t)
    near = np.abs(t) < 40
    scale = BINS  # the inverse DFT's normalisation: h(0) = (1 - f) BINS / (BINS OVERSAMPLE)
    np.testing.assert_allclose(power[near] * (scale * OVERSAMPLE) ** 2 / BINS ** 2, (h * h)[near], atol=1e-6)


@pytest.mark.parametrize("fraction", [0.025, 0.1, 0.2])
@pytest.mark.parametrize("position", ["centre", "edge"])
def test_notch_energy_looks_and_peak_follow_the_closed_forms(fraction, position):
    """A binary notch of a rectangular spectrum: energy ratio and looks factor 1 - f wherever it sits (Parseval;
    Goodman 2007, Chapter 4), peak loss 20 log10(1 - f); at the edge the band is narrower: resolution 1/(1 - f);
    at the centre the main lobe narrows and the sidelobes rise (PSLR above -13.26 dB)."""
    r = notch_response(fraction, position)
    assert r.energy_ratio == pytest.approx(1.0 - fraction, rel=1e-12)
    assert r.looks_factor == pytest.approx(1.0 - fraction, rel=1e-12)
    assert r.peak_loss_db == pytest.approx(20.0 * math.log10(1.0 - fraction), abs=1e-9)
    if position == "edge":
        assert r.resolution_ratio == pytest.approx(1.0 / (1.0 - fraction), rel=2e-3)
        assert r.pslr_db == pytest.approx(-13.26, abs=0.05)
    else:
        assert r.resolution_ratio < 1.0 and r.pslr_db > -13.0


def test_fixed_gain_moments():
    """g = 1 - level with no spread: E[e'] = m g - sigma level, Var[e'] = g^2 Var[e]."""
    effect = FixedGain("notch", 0.1)
    mean, cov = effect.joint(np.array([0.01]), np.array([[4e-4]]), np.array([1.0]), 0.1)
    assert mean[0] == pytest.approx(0.01 * 0.9 - 0.1, rel=1e-14)
    assert cov[0, 0] == pytest.approx(0.81 * 4e-4, rel=1e-14)
    x = effect.draw(np.random.default_rng(1), (3, 2, 1)).sampled(np.zeros((3, 2, 1)), np.array([1.0]))
    np.testing.assert_allclose(x, -0.1)


SCENARIO = {
    "name": "rfi_test",
    "scene": {"type": "table1_forest", "forest": "boreal_200"},
    "instrument": {"type": "biomass"},
    "ionosphere": {"type": "gaussian_faraday", "mean_deg": 60.0, "sd_deg": 5.0},
    "error_terms": [{"type": "rfi", "band_fraction_percent": 10.0, "time_fraction_percent": 5.0,
                     "residual_power_db": -35.0, "looks": 92}],
    "requirements": [{"type": "agb_error_bound", "sources": "systematic", "bound_percent": 20,
                      "confidence_percent": 99.865}],
    "simulation": {"seed": 3, "looks": 2000, "mode": "analytic"},
    "sweep": {"parameters": {"error_terms.0.compensated": [False, True]}},
}


def test_rfi_term_adds_three_attributed_sources_with_their_equations():
    """One term, three sources: the uncompensated notch a gain 1 - g with g = (1 - f_b)(1 - f_t), the lost looks
    r^2 = 1/L' - 1/L with L' = L (1 - f_b)(1 - f_t), the residual a power N in the L' looks; compensated, the gain
    goes and the rest stays. Both engines agree."""
    runs = [api.run(SCENARIO, engine=engine) for engine in ("batched", "per_case")]
    for k in runs[0].scalars:
        np.testing.assert_array_equal(runs[0].scalars[k], runs[1].scalars[k], err_msg=k)
    s, details = runs[0].scalars, runs[0].details[0]
    kept = 0.9 * 0.95
    np.testing.assert_allclose(s["error_term.rfi.energy_ratio"], kept, rtol=1e-12)
    np.testing.assert_allclose(s["error_term.rfi.looks_factor"], kept, rtol=1e-12)
    notch = np.asarray(details["contribution.rfi_notch_percent"], float)
    assert notch[0] != 0.0 and notch[1] == 0.0  # compensated: nothing to attribute
    assert np.all(np.asarray(details["contribution.rfi_looks_percent"], float) > 0)
    residual = np.asarray(details["contribution.rfi_residual_percent"], float)
    assert residual[1] > 0 and residual[0] < 0  # uncompensated, its positive bias offsets part of the gain loss
    assert all(f"rfi_{p}" in runs[0].coverage[0, 0] for p in ("notch", "looks", "residual"))
    # the mean error: sigma (g - 1) of the gain, plus the residual power (not subtracted)
    sigma = s["scene.sigma_hv"][0]
    base = s["analytic.mean"][0]
    expected = base * kept + sigma * (kept - 1.0) + 10 ** -3.5
    assert s["analytic.with_error_terms_mean"][0] == pytest.approx(expected, rel=1e-9)
    assert s["analytic.with_error_terms_mean"][1] == pytest.approx(base + 10 ** -3.5, rel=1e-9)


def test_rfi_term_conforms():
    check_module(RFITerm, {"band_fraction_percent": 5.0, "residual_power_db": -40.0})


def _fraction_map(path, values, lat=(-10.0, 10.0), lon=(0.0, 20.0), name="band_fraction"):
    import xarray as xr

    xr.Dataset({name: (("lat", "lon"), np.asarray(values, float))},
               coords={"lat": list(lat), "lon": list(lon)}).to_netcdf(path)
    return path


def test_fraction_map_is_read_at_the_terms_point(tmp_path):
    path = _fraction_map(tmp_path / "rfi.nc", [[0.0, 0.1], [0.2, 0.05]])
    scenario = dict(SCENARIO, sweep={"parameters": {"error_terms.0.lat_deg": [-10.0, 10.0]}},
                    error_terms=[{"type": "rfi", "fraction_map": str(path), "lat_deg": 0.0, "lon_deg": 19.0}])
    run = api.run(scenario)
    np.testing.assert_array_equal(run.scalars["error_term.rfi.band_fraction"], [0.1, 0.05])


@pytest.mark.parametrize("setting, message", [
    ({"band_fraction_percent": 120.0}, r"error_terms\[0\]\.band_fraction_percent: 120"),
    ({"band_fraction_percent": -1.0}, r"error_terms\[0\]\.band_fraction_percent: -1"),
    ({"time_fraction_percent": 100.0}, r"error_terms\[0\]\.time_fraction_percent: 100"),
    ({"fraction_map": "missing.nc", "lat_deg": 0.0, "lon_deg": 0.0}, r"cannot read the RFI fraction map"),
])
def test_bad_rfi_inputs_are_config_errors(setting, message):
    scenario = dict(SCENARIO, sweep={}, error_terms=[{"type": "rfi", **setting}])
    scenario.pop("sweep")
    with pytest.raises(ConfigError, match=message):
        api.load_scenario(scenario).resolve()


@pytest.mark.parametrize("layout", ["no_variable", "three_d", "over_one", "negative"])
def test_bad_fraction_maps_exit_with_status_2(tmp_path, capsys, layout):
    """A map without the variable, with three dimensions, or with a fraction over 1 or negative: a message naming
    the file and the problem, exit status 2 (issue 24, Done when)."""
    import xarray as xr

    path = tmp_path / "rfi.nc"
    if layout == "no_variable":
        _fraction_map(path, [[0.0, 0.1], [0.2, 0.05]], name="other")
        expected = "has no variable 'band_fraction'"
    elif layout == "three_d":
        xr.Dataset({"band_fraction": (("t", "lat", "lon"), np.zeros((2, 2, 2)))},
                   coords={"lat": [0.0, 1.0], "lon": [0.0, 1.0]}).to_netcdf(path)
        expected = "expected two: latitude and longitude"
    else:
        _fraction_map(path, [[0.0, 1.5 if layout == "over_one" else -0.2], [0.2, 0.05]])
        expected = "expected values from 0 to 1"
    scenario = {k: v for k, v in SCENARIO.items() if k != "sweep"}
    scenario["error_terms"] = [{"type": "rfi", "fraction_map": str(path), "lat_deg": 0.0, "lon_deg": 0.0}]
    file = tmp_path / "s.yaml"
    file.write_text(yaml.safe_dump(scenario))
    assert main(["validate", str(file)]) == 2
    err = capsys.readouterr().err
    assert "error_terms[0].fraction_map" in err and str(path) in err and expected in err


@pytest.mark.parametrize("value", [120.0, -5.0])
def test_an_affected_fraction_over_1_or_negative_exits_with_status_2(tmp_path, capsys, value):
    """Issue 24, Done when: an affected fraction over 1 (100 %) or negative: a message naming the file, the key and
    the value, exit status 2."""
    scenario = {k: v for k, v in SCENARIO.items() if k != "sweep"}
    scenario["error_terms"] = [{"type": "rfi", "band_fraction_percent": value}]
    file = tmp_path / "s.yaml"
    file.write_text(yaml.safe_dump(scenario))
    assert main(["validate", str(file)]) == 2
    err = capsys.readouterr().err
    assert f"{file}" in err and f"error_terms[0].band_fraction_percent: {value:g}" in err
