"""Calibration modules in the runner: what the propagation sees after each strategy, and bad input."""

from __future__ import annotations

import copy
import pickle
from pathlib import Path

import numpy as np
import pytest

from cal_helpers import Z_ACCEPT
from e2esim.calibration.modules import FaradayCorrection, RadiometricCalibration, TransponderCalibration
from e2esim.calibration.pipeline import ResidualSystemErrorModel
from e2esim.calibration.record import CalibrationRecord
from e2esim.errors import ConfigError
from e2esim.faraday.distribution import ConstantFaraday
from e2esim.runner.run import run_case, run_scenario
from e2esim.runner.scenario import Scenario

ROOT = Path(__file__).resolve().parents[2]

BASE = {
    "scene": {"type": "table1_forest", "forest": "boreal_200"},
    "instrument": {"type": "biomass"},
    "ionosphere": {"type": "gaussian_faraday", "mean_deg": 60.0, "sd_deg": 5.0},
    "propagation": {"type": "hv_backscatter_error"},
    "retrieval": {"type": "power_law"},
    "simulation": {"mode": "both", "seed": 7, "looks": 10_000, "realisations": 2000},
}


def _run(calibration, **changes):
    data = copy.deepcopy(BASE)
    if calibration is not None:
        data["calibration"] = calibration
    data.update(changes)
    resolved = Scenario(data, "<test>").resolve()
    return [run_case(spec) for spec in resolved.cases]


def test_faraday_correction_alone_leaves_the_sigma_hv_error_exactly_unchanged():
    raw = _run(None)[0]
    fr = _run([{"type": "faraday_correction"}])[0]
    assert fr.get("system.residual") == raw.get("system.residual") == raw.get("system")
    assert fr.get("faraday.residual") == raw.get("faraday.residual") == raw.get("faraday.geophysical")
    moments, raw_moments = fr.get("backscatter.error").current(), raw.get("backscatter.error").current()
    assert float(moments.mean) == float(raw_moments.mean)
    assert float(moments.variance) == float(raw_moments.variance)
    rec = fr.get("calibration")
    assert isinstance(rec, CalibrationRecord) and rec.representation == "rotation_invariant"
    left = rec.faraday_error()  # the rotation the correction leaves: Omega - Omega_hat
    assert left.sd_rad < np.radians(1.0) and abs(left.mean_rad) < np.radians(0.2)
    assert fr.scalars["calibration.0.faraday_correction.omega_error_rms_deg"] < 1.0
    assert fr.scalars["calibration.0.faraday_correction.ambiguity_error_fraction"] == 0.0


def test_full_calibration_leaves_smaller_errors_than_the_raw_instrument():
    """Transponders then Faraday-rotation correction: residual crosstalk and imbalance below the raw ones,
    no Faraday rotation left, and a smaller sigma_hv error SD (analytic and Monte Carlo)."""
    raw = _run(None)[0]
    cal = _run([{"type": "transponder_calibration", "scr_db": 40.0}, {"type": "faraday_correction"}])[0]
    residual, left = cal.get("system.residual"), cal.get("faraday.residual")
    assert isinstance(residual, ResidualSystemErrorModel) and isinstance(left, ConstantFaraday)
    # calibration adds the residual products beside the raw ones, which stay as the instrument and ionosphere made them
    assert cal.get("system") == raw.get("system") and cal.get("faraday.geophysical") == raw.get("faraday.geophysical")
    assert residual.crosstalk_level < 0.2 * raw.get("system").crosstalk_level
    assert residual.imbalance_level < 0.5 * raw.get("system").imbalance_level
    assert cal.scalars["analytic.sd"] < 0.7 * raw.scalars["analytic.sd"]
    assert cal.scalars["montecarlo.sd"] < 0.7 * raw.scalars["montecarlo.sd"]
    assert cal.scalars["calibration.residual.crosstalk_level_db"] < -40
    # the whitened least-squares residual of 4 calibrators is chi-square with 8 K - 14 = 18 degrees of
    # freedom (e2esim.calibration.transponder): its mean over the 2000 pilot realisations
    chi2 = cal.scalars["calibration.0.transponder_calibration.chi2_mean"]
    assert abs(chi2 - 18.0) < Z_ACCEPT * np.sqrt(2 * 18.0 / 2000)


def test_distributed_target_calibration_needs_faraday_correction_far_from_the_equator():
    """At 60 deg of Faraday rotation Quegan (1994) alone fails; after Faraday-rotation correction it works."""
    alone = _run([{"type": "distributed_target_calibration"}])[0].get("system.residual")
    after = _run([{"type": "faraday_correction"}, {"type": "distributed_target_calibration"}])[0].get("system.residual")
    raw = _run(None)[0].get("system.residual")
    assert alone.crosstalk_level > 10 * raw.crosstalk_level
    assert after.crosstalk_level < 0.3 * raw.crosstalk_level


def test_chirp_slope_and_radiometric_modules_run():
    """Near the magnetic equator the slope estimate's scatter is the predicted noise term: its crosstalk
    error is a fraction of Omega0 (at 60 deg it adds about 0.17 deg at the BIOMASS specification)."""
    equator = {"type": "gaussian_faraday", "mean_deg": 0.0, "sd_deg": 2.0}
    chirp = _run([{"type": "faraday_correction", "estimator": {"type": "chirp_slope", "subbands": 4}, "looks": 400_000},
                  {"type": "radiometric_calibration", "scr_db": 35.0, "targets": 3, "pointing_sd_deg": 0.05}],
                 ionosphere=equator)[0]
    sd = chirp.scalars["calibration.0.faraday_correction.omega_error_sd_deg"]
    predicted = chirp.scalars["calibration.0.faraday_correction.predicted_noise_sd_deg"]
    assert sd == pytest.approx(predicted, rel=0.1)
    # the residual gain: the radiometric calibration's predicted error (3 targets at 35 dB SCR, pointing
    # 0.05 deg in a 5 deg beam), drawn over the 2000 pilot realisations
    module = RadiometricCalibration(scr_db=35.0, targets=3, pointing_sd_deg=0.05)
    mean_db, sd_db = module.gain_error_db()
    assert sd_db > 0.01
    residual = chirp.get("system.residual")
    assert abs(residual.gain_sd_db - sd_db) < Z_ACCEPT * sd_db / np.sqrt(2 * 2000)
    assert abs(residual.gain_offset_db + mean_db) < Z_ACCEPT * sd_db / np.sqrt(2000)  # residual = -error
    assert chirp.scalars["calibration.residual.gain_sd_db"] == residual.gain_sd_db


def test_none_module_and_determinism():
    a = _run([{"type": "none"}, {"type": "faraday_correction"}])[0]
    b = _run([{"type": "none"}, {"type": "faraday_correction"}])[0]
    assert a.scalars == b.scalars
    module = TransponderCalibration(scr_db=35.0)
    assert pickle.loads(pickle.dumps(module)) == module


@pytest.mark.parametrize("calibration, key, message", [
    ([{"type": "faraday_corection"}], "calibration[0].type", "did you mean|unknown calibration type"),
    ([{"type": "faraday_correction", "estimator": {"type": "chirp_slope", "subbands": 4}, "looks": 2}],
     "calibration[0]", "cannot be shared among subbands = 4"),
    ([{"type": "faraday_correction", "estimator": {"type": "chirp_slope", "subband": 4}}],
     "calibration[0].estimator.subband", "unknown key 'subband'"),
    ([{"type": "transponder_calibration", "calibrators": ["trihedral", "dihedral_0"]}], "calibration[0]",
     "2 calibrators cannot determine the system errors"),
    ([{"type": "transponder_calibration", "calibrators": ["trihedral", "dihedral_7"]}], "calibration[0].calibrators[1]",
     "'dihedral_7' is not allowed"),
    ([{"type": "transponder_calibration", "calibrators": ["trihedral", "trihedral", "dihedral_0"]}], "calibration[0]",
     "span only 2 independent scattering matrices"),
    ([{"type": "faraday_correction", "looks": 0}], "calibration[0].looks", "0 is out of range"),
])
def test_bad_input_names_the_key(calibration, key, message):
    with pytest.raises(ConfigError, match=message) as info:
        _run(calibration)
    assert key in str(info.value)


def test_python_api_rejects_bad_values():
    with pytest.raises(ConfigError, match="estimator: unknown faraday_estimator type 'bb'; registered "
                                          "faraday_estimator types: bickel_bates, chirp_slope, freeman"):
        FaradayCorrection(estimator="bb")


def test_calibration_scenario_file_runs_fast_variant(quick_run):
    """scenarios/biomass_calibration.yaml with small Monte Carlo sizes: every case runs and full
    calibration lowers the 99.865 % AGB error quantile below the raw one for both forests."""
    result = quick_run("biomass_calibration")[0]
    assert len(result.cases) == 8
    by = {(c.inputs["scene.forest"], c.inputs["calibration.0.type"], c.inputs["calibration.1.type"]): c.scalars
          for c in result.cases}
    for forest in ("boreal_200", "tropical_338"):
        raw = by[(forest, "none", "none")]["agb.analytic.q99865_percent"]
        fr = by[(forest, "faraday_correction", "none")]["agb.analytic.q99865_percent"]
        full = by[(forest, "transponder_calibration", "faraday_correction")]["agb.analytic.q99865_percent"]
        assert fr == raw
        assert full < 0.8 * raw


@pytest.mark.slow
def test_calibration_scenario_file_full_size(tmp_path):
    sc = Scenario.load(ROOT / "scenarios" / "biomass_calibration.yaml")
    result = run_scenario(sc.resolve(), progress=False)
    for c in result.cases:
        if c.inputs["calibration.0.type"] == "transponder_calibration":
            assert abs(c.scalars["comparison.var_rel_diff"]) < 0.15  # analytic residual model vs exact draws
    assert np.isfinite([c.scalars["agb.montecarlo.rmse_percent"] for c in result.cases]).all()
