"""The scintillation error terms: their moments against their own draws, what a level of 0 and a homogeneous forest
do, a scenario through them, and bad input (exit status 2 with the key path)."""

import math

import numpy as np
import pytest
import yaml

from e2esim.cli import main
from e2esim.scintillation.effects import CKL_LEVEL, CalibratorFactor, DistributedTargetFactor, FaradayLeakage

PER_ACQUISITION = dict(weight=(0.5, 0.3, 0.2), shape=(2.0, 1.2, 0.8), scale=(0.01, 0.05, 0.3),
                       shift_sd_cells=(0.05, 0.2, 1.5), halo_share=(0.01, 0.03, 0.1))
FACTORS = {
    "distributed": DistributedTargetFactor("s", CKL_LEVEL, cell_fraction=8.3 / 200.0, contrast=0.7, **PER_ACQUISITION),
    "calibrator": CalibratorFactor("c", CKL_LEVEL, mean_log=0.05, var_log=0.01),
}


@pytest.mark.parametrize("name", list(FACTORS))
@pytest.mark.parametrize("level", [CKL_LEVEL, 2.5 * CKL_LEVEL])
def test_factor_moments_agree_with_the_factor_s_draws(name, level, rng):
    """E[g] and Var[g] of eq. S19/S20 (mixture over acquisitions, gamma Laplace transform, log-normal) against the
    sample moments of the term's own draws at that level: z-tests, any seed."""
    effect = FACTORS[name]
    effect = type(effect)(**{**effect.__dict__, "level": level, "draws": None})
    g = effect.factors(rng, (200_000,))
    mean, var = (float(v) for v in effect.factor_moments(level))
    z_mean = (g.mean() - mean) / math.sqrt(var / g.size)
    fourth = np.mean((g - g.mean()) ** 4)
    z_var = (g.var(ddof=1) - var) / math.sqrt((fourth - var * var) / g.size)
    assert abs(z_mean) < 4.5 and abs(z_var) < 4.5, (z_mean, z_var)


def test_no_irregularities_and_a_homogeneous_forest_change_nothing():
    """Level 0 (no C_kL): g = 1 exactly; contrast 0 (a homogeneous forest): the term is inactive, so the model
    without it is the model itself (energy conservation of a phase-only screen, eq. S19)."""
    for effect in FACTORS.values():
        mean, var = effect.factor_moments(0.0)
        assert float(mean) == 1.0 and float(var) == 0.0
    homogeneous = DistributedTargetFactor("s", CKL_LEVEL, cell_fraction=0.04, contrast=0.0, **PER_ACQUISITION)
    assert not homogeneous.active
    assert float(homogeneous.factor_moments(CKL_LEVEL)[0]) == 1.0


def test_faraday_leakage_is_the_expected_sine_square():
    """N = E[sin^2(2 delta)] / 4 (sigma_hh + sigma_vv + 2 Re C_hhvv) on HV only (eq. S21), with E[sin^2 2 delta] of
    a Gaussian delta checked by quadrature-free sampling (z-test) and the closed form (1 - exp(-8 s^2)) / 2."""
    s2 = (1e-4, 4e-3)
    effect = FaradayLeakage("f", CKL_LEVEL, scale=(0.0, 1.0, 0.0), looks=100, weight=(0.25, 0.75), window_variance=s2,
                            copol_power=0.3)
    power = effect._power(CKL_LEVEL, np.array([0.1, 0.02, 0.08]))
    closed = sum(w * 0.5 * (1.0 - math.exp(-8.0 * v)) for w, v in zip((0.25, 0.75), s2, strict=True)) / 4.0 * 0.3
    assert power[0] == 0.0 and power[2] == 0.0 and power[1] == pytest.approx(closed, rel=1e-12)
    rng = np.random.default_rng(7)
    delta = math.sqrt(s2[1]) * rng.standard_normal(400_000)
    sample = np.sin(2.0 * delta) ** 2
    assert abs(sample.mean() - 0.5 * (1 - math.exp(-8 * s2[1]))) < 4.5 * sample.std() / math.sqrt(sample.size)


def _scenario(tmp_path, **term):
    doc = {
        "name": "scint_small",
        "orbit": {"type": "biomass_orbit", "swath_samples": 1, "site": {"lat_deg": 72.0, "lon_deg": 100.0},
                  "acquisitions": {"step_days": 120}},
        "scene": {"type": "table1_forest", "forest": "boreal_200"},
        "instrument": {"type": "biomass"},
        "ionosphere": {"type": "gaussian_faraday", "mean_deg": 0.0, "sd_deg": 1.0},
        "propagation": {"type": "hv_backscatter_error"},
        "error_terms": [{"type": "scintillation_sigma0", **term}, {"type": "scintillation_calibration"},
                        {"type": "scintillation_faraday"}],
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_error_bound", "sources": "systematic", "bound_percent": 20}],
        "simulation": {"mode": "analytic", "seed": 3},
    }
    path = tmp_path / "scint.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


@pytest.mark.parametrize("term, key, text", [
    ({"c_kl": -1e24}, "error_terms[0].c_kl", ">= 0"),
    ({"spectral_index": 5.5}, "error_terms[0].spectral_index", "1 < value < 5"),
    ({"spectral_index": 1.0}, "error_terms[0].spectral_index", "1 < value < 5"),
    ({"screen_height_km": 700.0}, "error_terms[0].screen_height_km", "not below the orbit"),
])
def test_bad_screens_end_with_exit_status_2(tmp_path, capsys, term, key, text):
    """A negative C_kL, a spectral index outside 1 < p < 5, a screen above the 666 km orbit: a clear message naming
    the file and the key path, exit status 2, no traceback."""
    status = main(["run", str(_scenario(tmp_path, **term)), "-o", str(tmp_path / "out"), "--force"])
    err = capsys.readouterr().err
    assert status == 2, err
    assert "scint.yaml" in err and key in err and text in err and "Traceback" not in err


def test_a_scenario_with_the_three_terms_runs_and_attributes(tmp_path, capsys):
    """At 72 N (geomagnetic about 63 N) at solar maximum the terms are active: each is a source of the verdict's
    coverage with its own contribution, and the screen's scalars are in the results."""
    out = tmp_path / "out"
    assert main(["run", str(_scenario(tmp_path)), "-o", str(out), "--force"]) in (0, 1)
    summary = yaml.safe_load((out / "summary.json").read_text())
    results = summary["cases"][0]["results"]
    assert results["scintillation_sigma0.geomagnetic_latitude_deg"] == pytest.approx(63.0, abs=2.0)
    assert results["scintillation_sigma0.peak_loss_median_db"] > 0.0
    assert results["scintillation_calibration.calibrator_peak_loss_mean_db"] > 0.0
    covers = str(summary["requirements"])
    for source in ("scintillation sigma0", "scintillation calibration", "scintillation faraday"):
        assert source in covers


def test_the_scenario_report_says_whether_each_term_is_negligible(quick_run):
    """The report of scenarios/biomass_scintillation.yaml answers the seed's claim per term: one sentence per term
    derived from its attribution (the Faraday-rotation term is negligible everywhere on this meridian; the sigma0
    term is not at 75 N), and the IRF statistics of theory and Monte Carlo are in the results."""
    result, folder = quick_run("biomass_scintillation")
    report = (folder / "report.md").read_text()
    lines = [line for line in report.splitlines() if line.startswith("**Error term:**")]
    assert len(lines) == 3
    faraday = next(line for line in lines if "scintillation faraday" in line)
    assert "negligible" in faraday and f"in {len(result.cases)} of {len(result.cases)} cases" in faraday
    sigma0 = next(line for line in lines if "scintillation sigma0" in line)
    assert "lat_deg=75" in sigma0.partition("; not in ")[2]
    scalars = result.cases[0].scalars
    assert any(k.endswith("scintillation_sigma0.mc_peak_loss_median_db") for k in scalars)
    assert any(k.endswith("scintillation_sigma0.peak_loss_median_db") for k in scalars)


def test_a_map_cell_without_an_orbit_stage_gets_its_screen_from_its_parameters():
    """A map sweep's chain has no geometry product: the term builds the cell's acquisitions from lat_deg, lon_deg,
    month and pass (what a map sweep sets), and says what is missing when they are not given."""
    from e2esim.errors import ConfigError
    from e2esim.scintillation.modules import ScintillationSigma0
    from e2esim.testing import reference_case

    full = reference_case(("instrument",))

    class MapCase:  # what a map sweep's case holds: no geometry
        settings, rng = full.settings, full.rng

        @staticmethod
        def get(name, default=None):
            return full.get(name, default) if name != "geometry" else default

    case = MapCase()
    term = ScintillationSigma0(lat_deg=72.0, lon_deg=100.0, month=1, **{"pass": "dusk"})
    outputs = dict(term.effect(case, None).outputs)  # full output keys: <source>.<name>
    assert outputs["scintillation_sigma0.geomagnetic_latitude_deg"] == pytest.approx(63.0, abs=1.5)
    quiet = dict(ScintillationSigma0(lat_deg=10.0, lon_deg=100.0, month=1).effect(case, None).outputs)
    key = "scintillation_sigma0.peak_loss_median_db"
    assert outputs[key] > 5.0 * quiet[key] > 0.0
    with pytest.raises(ConfigError, match="names no map cell"):
        ScintillationSigma0().effect(case, None)


def test_the_map_cell_keys_of_error_terms_are_those_a_map_sweep_sets():
    """Error terms read a map cell by the sweep keys of e2esim.maps.grid: the two lists must not drift apart."""
    from e2esim.error_terms.modules import MAP_CELL_KEYS
    from e2esim.maps.grid import LAT_KEYS, LON_KEYS, MONTH_KEY, PASS_KEY, SOLAR_KEY

    assert MAP_CELL_KEYS == {"lat": LAT_KEYS[0], "lon": LON_KEYS[0], "month": MONTH_KEY, "pass": PASS_KEY,
                             "solar": SOLAR_KEY}


def test_a_map_sweeps_cell_drives_the_scintillation_term():
    """In a map sweep the term names no cell: it takes latitude, longitude, month, pass and solar level from the
    case's map keys (an auroral dusk cell at solar maximum scintillates more than the same cell at minimum, and
    more than an equatorial dawn cell), and its own parameters win where given."""
    from e2esim.error_terms.modules import MAP_CELL_KEYS
    from e2esim.scintillation.modules import ScintillationSigma0
    from e2esim.testing import reference_case

    full = reference_case(("instrument",))

    def cell(lat, month, pass_name, solar):
        inputs = {MAP_CELL_KEYS["lat"]: lat, MAP_CELL_KEYS["lon"]: 100.0, MAP_CELL_KEYS["month"]: month,
                  MAP_CELL_KEYS["pass"]: pass_name, MAP_CELL_KEYS["solar"]: solar}

        class MapCase:
            settings, rng = full.settings, full.rng

            @staticmethod
            def get(name, default=None):
                return full.get(name, default) if name != "geometry" else default

        MapCase.inputs = inputs
        return MapCase()

    key = "scintillation_sigma0.peak_loss_median_db"
    term = ScintillationSigma0()
    auroral_max = dict(term.effect(cell(72.0, 1, "dusk", "max"), None).outputs)[key]
    auroral_min = dict(term.effect(cell(72.0, 1, "dusk", "min"), None).outputs)[key]
    equatorial = dict(term.effect(cell(10.0, 1, "ascending", "max"), None).outputs)[key]
    assert auroral_max > auroral_min > 0.0
    assert auroral_max > 5.0 * equatorial > 0.0
    pinned = ScintillationSigma0(lat_deg=10.0, solar="max", **{"pass": "dawn"})
    assert dict(pinned.effect(cell(72.0, 1, "dusk", "min"), None).outputs)[key] == equatorial
