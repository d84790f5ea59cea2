"""Radiometric calibration errors: point targets in clutter, antenna pattern and pointing (seed 003 Sect. 4,
seed 004 eqs. 30-35)."""

from __future__ import annotations

import numpy as np
import pytest

from cal_helpers import Z_ACCEPT, z_mean
from e2esim.calibration.radiometric import (
    DB_PER_NEPER_POWER,
    UNIFORM_ARRAY_BEAM_SHAPING,
    absolute_gain_error_db,
    ahmed_azimuth_gain_error,
    ahmed_range_gain_error,
    dem_pointing_error,
    pattern_gain_error,
    point_target_power_bias,
    point_target_power_sd,
    sinc_pattern,
    swath_pointing_gain_sd_db,
)
from e2esim.errors import PhysicsInputError


@pytest.mark.parametrize("scr_db", [10.0, 30.0])
def test_point_target_power_statistics(rng, scr_db):
    """|a + c|^2 with c ~ CN(0, 1/SCR): mean 1 + 1/SCR, relative variance 2/SCR + 1/SCR^2."""
    scr = 10 ** (scr_db / 10)
    n = 200_000
    c = np.sqrt(1 / (2 * scr)) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    p = np.abs(1 + c) ** 2
    assert abs(z_mean(p, 1 + float(point_target_power_bias(scr)))) < Z_ACCEPT
    assert abs(z_mean((p - 1 - 1 / scr) ** 2, float(point_target_power_sd(scr)) ** 2)) < Z_ACCEPT
    assert point_target_power_sd(scr, 4) == pytest.approx(point_target_power_sd(scr) / 2)


def test_sinc_pattern_half_power_at_half_beamwidth():
    """k = 1/0.88 (uniform array, seed 004 Table III): G = 1/2 at theta_half/2 to within 1 %."""
    bw = np.radians(5.0)
    assert sinc_pattern(0.0, bw) == pytest.approx(1.0)
    assert sinc_pattern(bw / 2, bw, UNIFORM_ARRAY_BEAM_SHAPING) == pytest.approx(0.5, rel=0.01)


def test_ahmed_eq33_is_the_mean_slope_of_ln_g_over_half_the_beam():
    bw = np.radians(8.0)
    dtheta = np.radians(0.01)
    slope = (np.log(sinc_pattern(bw / 2, bw)) - np.log(sinc_pattern(0.0, bw))) / (bw / 2)
    assert ahmed_range_gain_error(dtheta, bw) == pytest.approx(slope * dtheta, rel=1e-12)
    # the exact error at the swath edge, one way, first order in dtheta, has the local slope instead
    edge = pattern_gain_error(bw / 2, dtheta, bw, ways=1)
    assert edge < 0 and abs(edge) > abs(ahmed_range_gain_error(dtheta, bw))


def test_eq34_as_printed_and_eq35():
    """Eq. (34) has no beamwidth: it is linear in dtheta with the constant printed (kept for reference);
    eq. (35) with seed 004 Table IV (3 m DEM error, 16322 m range) gives 0.184 mrad."""
    k = UNIFORM_ARRAY_BEAM_SHAPING
    assert ahmed_azimuth_gain_error(2e-3, k) == pytest.approx(2 * ahmed_azimuth_gain_error(1e-3, k))
    assert dem_pointing_error(3.0, 16322.0) * 1e3 == pytest.approx(0.1838, abs=1e-4)


def test_swath_pointing_gain_sd_matches_simulation(rng):
    bw, sd = np.radians(5.0), np.radians(0.2)
    n = 200_000
    theta = rng.uniform(-bw / 2, bw / 2, n)
    err_db = DB_PER_NEPER_POWER * np.log1p(pattern_gain_error(theta, sd * rng.standard_normal(n), bw))
    expected = swath_pointing_gain_sd_db(sd, bw) ** 2
    assert abs(z_mean(err_db**2, expected)) < Z_ACCEPT
    assert swath_pointing_gain_sd_db(0.0, bw) == 0.0


def test_absolute_gain_error_budget():
    mean, sd = absolute_gain_error_db(1000.0, 1, background_subtraction=False, pointing_sd_db=0.3)
    assert mean == pytest.approx(10 * np.log10(1.001))
    assert sd == pytest.approx(np.hypot(DB_PER_NEPER_POWER * np.sqrt(2e-3 + 1e-6), 0.3))
    assert absolute_gain_error_db(1000.0, 1)[0] == 0.0


def test_bad_inputs_are_named():
    with pytest.raises(PhysicsInputError, match="need SCR > 0 and at least one target"):
        point_target_power_sd(-1.0)
    with pytest.raises(PhysicsInputError, match="swath_fraction must be in"):
        swath_pointing_gain_sd_db(0.01, 0.1, swath_fraction=2.0)
