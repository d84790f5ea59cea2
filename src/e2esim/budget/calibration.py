"""Calibration errors of the backscattering coefficient, Ahmed et al. (2014), eqs. (30)-(35).

Antenna patterns are modelled as one-way power patterns ``G = sinc^2(pi theta / (k theta_1/2))`` with
``sinc(x) = sin(x) / x`` and k the beam-shaping factor (1/0.88 for a uniformly illuminated aperture):
the half-power edge theta_1/2 / 2 maps to x = pi / (2k), where sinc^2 = 0.505 (-3 dB).
"""

from __future__ import annotations

import numpy as np

BEAM_SHAPING_UNIFORM = 1.0 / 0.88  # k for a uniformly weighted array (Ahmed et al. 2014, Table III)


def _ln_sinc(x):
    return np.log(np.sin(x) / x)


def sinc_squared_integral(upper):
    """``int_0^a sinc^2(x) dx = Si(2a) - sin^2(a) / a`` (closed form; the denominator of eq. 34)."""
    from scipy import special  # imported here: it costs a tenth of a second at start-up

    a = np.asarray(upper, dtype=float)
    si, _ = special.sici(2.0 * a)
    return si - np.sin(a) ** 2 / a


def random_calibration_error(residual_db):
    """Relative random calibration error ``Delta sigma_ran / sigma_t = 10^(dB/10) - 1``, eq. (31)."""
    return 10.0 ** (np.asarray(residual_db, dtype=float) / 10.0) - 1.0


def elevation_gain_error(pointing_error_rad, beamwidth_rad, beam_shaping=BEAM_SHAPING_UNIFORM):
    """Relative gain error in range (elevation), eq. (33): ``(4 dtheta / theta_1/2) ln sinc(pi / 2k)``.

    It is the swath average of ``dtheta d ln G / d theta`` over the half-power beam (derived: the mean of
    |d ln G/d theta| over [-theta_1/2/2, theta_1/2/2] is 2 |ln G(edge)| / theta_1/2 with G = sinc^2).
    Negative for a positive pointing error (ln sinc < 0). Any broadcastable shapes.
    """
    k = np.asarray(beam_shaping, dtype=float)
    return 4.0 * np.asarray(pointing_error_rad, float) / np.asarray(beamwidth_rad, float) * _ln_sinc(np.pi / (2.0 * k))


def azimuth_gain_error(pointing_error_rad, beamwidth_rad, beam_shaping=BEAM_SHAPING_UNIFORM):
    """Relative gain error in azimuth, eq. (34), with the pointing error in units of the azimuth beamwidth:

    ``(2k / pi) (dtheta / theta_1/2,s) ln[sinc(pi/2k)] / int_0^(pi/2k) sinc^2(x) dx``.

    The printed eq. (34) has ``2 k dtheta / pi`` without a beamwidth, which is not dimensionless
    (dtheta in radians) although Table III lists the azimuth beamwidth theta_1/2,s = 8 deg that no other
    equation uses; by analogy with eq. (33) the pointing error enters relative to the beamwidth
    (docs/errata.md).
    """
    k = np.asarray(beam_shaping, dtype=float)
    edge = np.pi / (2.0 * k)
    return (2.0 * k / np.pi) * np.asarray(pointing_error_rad, float) / np.asarray(beamwidth_rad, float) * (
        _ln_sinc(edge) / sinc_squared_integral(edge))


def pointing_calibration_error(pointing_error_rad, elevation_beamwidth_rad, azimuth_beamwidth_rad,
                               beam_shaping=BEAM_SHAPING_UNIFORM):
    """Relative calibration error from antenna pointing, eq. (32):
    ``Delta sigma_p / sigma = -(dG_r,rho/G + dG_r,s/G + dG_t,rho/G + dG_t,s/G)``, transmit and receive
    through the same antenna (the same pointing error), so each direction's term counts twice."""
    return -2.0 * (elevation_gain_error(pointing_error_rad, elevation_beamwidth_rad, beam_shaping)
                   + azimuth_gain_error(pointing_error_rad, azimuth_beamwidth_rad, beam_shaping))


def dem_pointing_error(dem_height_error_m, slant_range_m):
    """Pointing error from the DEM height error, ``dtheta = dh_dem / rho`` (rad), eq. (35)."""
    return np.asarray(dem_height_error_m, dtype=float) / np.asarray(slant_range_m, dtype=float)


def dem_calibration_error(dem_height_error_m, slant_range_m, elevation_beamwidth_rad,
                          beam_shaping=BEAM_SHAPING_UNIFORM):
    """Relative gain error from the DEM, ``Delta sigma_geo / sigma``: eq. (33) at the pointing error of
    eq. (35) (as a magnitude; the paper applies eq. 33 once)."""
    return np.abs(elevation_gain_error(dem_pointing_error(dem_height_error_m, slant_range_m),
                                       elevation_beamwidth_rad, beam_shaping))
