"""Residual errors stated directly (issue 23, item 3): ``residual_system`` and ``residual_faraday`` calibration steps
set what calibration leaves; the propagation sees exactly the stated levels, and a stated level that changes
nothing in a chain is reported (e2esim.runner.no_effect)."""

import math

import numpy as np
import pytest

from e2esim.calibration.stated_steps import standard_draws
from e2esim.errors import UserError
from e2esim.runner.no_effect import no_effect
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario
from e2esim.units import THREE_SIGMA_AMPLITUDE, level_db_from_variance


def chain(calibration=None, propagation="hv_backscatter_error", **instrument):
    raw = {
        "name": "stated",
        "scene": {"type": "table1_forest", "forest": "boreal_200"},
        "instrument": {"type": "biomass", **instrument},
        "ionosphere": {"type": "gaussian_faraday", "mean_deg": 20.0, "sd_deg": 5.0},
        "propagation": {"type": propagation},
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_rmse", "max_percent": 20}],
        "simulation": {"mode": "analytic", "seed": 7, "looks": 2000, "realisations": 300},
    }
    if calibration is not None:
        raw["calibration"] = calibration
    return raw


def run(raw, *overrides):
    scenario = Scenario(raw, "test.yaml")
    for item in overrides:
        scenario.override(item)
    return run_scenario(scenario.resolve(), progress=False)


def value(result, j=0):
    return float(result.table.requirements[j].value[0])


def test_stated_residual_levels_equal_to_the_instruments_change_nothing():
    """residual_system at the instrument's own crosstalk, imbalance and NESZ gives the numbers of no calibration,
    to rounding (the same Gaussian model)."""
    plain = run(chain())
    stated = run(chain([{"type": "residual_system", "crosstalk_db": -30, "channel_imbalance_db": -34,
                         "nesz_db": -27}]))
    assert value(stated) == pytest.approx(value(plain), rel=1e-12)


def test_stated_residual_levels_replace_the_instruments():
    """A stated residual crosstalk of -25 dB after calibration gives the numbers of an instrument at -25 dB, and
    the residual model carries it (the case's system.residual, in the stated convention)."""
    stated = run(chain([{"type": "residual_system", "crosstalk_db": -25, "gain_sd_db": 0.3}]))
    raw = run(chain(crosstalk={"level_db": -25}, gain_sd_db=0.3))
    assert value(stated) == pytest.approx(value(raw), rel=1e-12)
    assert value(stated) > value(run(chain())) + 0.1
    residual = stated.cases[0].get("system.residual")
    assert level_db_from_variance(residual.crosstalk_level, THREE_SIGMA_AMPLITUDE) == pytest.approx(-25.0)
    assert residual.gain_sd_db == 0.3
    assert stated.cases[0].scalars["calibration.0.residual_system.gain_sd_db"] == 0.3


def test_stated_faraday_residual_has_exactly_the_stated_moments():
    """The rotation left by residual_faraday has the stated mean and SD exactly (standardised draws), and its sign
    is Omega - Omega_hat (CalibrationRecord.faraday_error)."""
    result = run(chain([{"type": "residual_faraday", "bias_deg": 1.5, "sd_deg": 4.0}], "polarimetric_error"))
    left = result.cases[0].get("calibration").faraday_error()
    samples = np.degrees(left.samples)
    assert samples.mean() == pytest.approx(1.5, abs=1e-9)
    assert samples.std() == pytest.approx(4.0, rel=1e-9)
    z = standard_draws(np.random.default_rng(1), 50)
    assert abs(z.mean()) < 1e-12 and z.std() == pytest.approx(1.0, rel=1e-12)


def test_the_co_polarised_channels_see_the_stated_faraday_residual():
    """HH after a correction that leaves 10 deg SD is worse than after one that leaves 1 deg; the HV-only chain
    cannot see it (the symmetrised HV is rotation invariant) and the override is reported as changing nothing."""
    def hh_rmse(sd):
        raw = chain([{"type": "residual_faraday", "sd_deg": sd}], "polarimetric_error")
        raw["retrieval"] = {"type": "multichannel_power_law", "estimator": "hh"}
        return value(run(raw))
    assert hh_rmse(10.0) > hh_rmse(1.0) + 0.05
    found = no_effect(run(chain([{"type": "residual_faraday", "sd_deg": 1.0}]), "calibration.0.sd_deg=10"))
    assert [f.key for f in found] == ["calibration.0.sd_deg"]
    assert "(M_hv + M_vh)/2" in found[0].reason


@pytest.mark.parametrize("step, message", [
    ({"type": "residual_faraday", "sd_deg": -1}, "sd_deg"),
    ({"type": "residual_system", "crosstalk_db": 3}, "crosstalk_db"),
    ({"type": "residual_system", "convention": "amplitude"}, "convention"),
])
def test_bad_stated_residuals_are_refused_by_name(step, message):
    with pytest.raises(UserError, match=message):
        Scenario(chain([step]), "test.yaml").resolve()


def test_stated_nesz_of_minus_infinity_is_no_noise():
    result = run(chain([{"type": "residual_system", "nesz_db": -200}]))
    assert math.isfinite(value(result))
