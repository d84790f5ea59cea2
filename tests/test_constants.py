"""The physical constants written out in e2esim.ionosphere.constants are scipy.constants' CODATA values."""

from scipy import constants

from e2esim.ionosphere import constants as ours


def test_constants_equal_scipy_codata():
    assert ours.ELECTRON_CHARGE == constants.e
    assert ours.ELECTRON_MASS == constants.m_e
    assert ours.SPEED_OF_LIGHT == constants.c
    assert ours.VACUUM_PERMITTIVITY == constants.epsilon_0
    assert ours.CLASSICAL_ELECTRON_RADIUS == constants.physical_constants["classical electron radius"][0]


def test_derived_constants():
    # Quegan et al. (2018): A of eq. (3) about 2.365e4, the 40.3 of eq. (7b), e/(m_e c) = 586.68 of eq. (8)
    assert abs(ours.FARADAY_CONSTANT - 2.3648e4) < 1.0
    assert abs(ours.RANGE_DELAY_CONSTANT - 40.308) < 1e-3
    assert abs(ours.CHARGE_TO_MASS_OVER_C - 586.679) < 1e-3
