"""Radiometric calibration errors: absolute gain from point targets, antenna pattern and pointing.

Quegan et al. (2018), Section 4 (eqs. 9-10): the measured voltage carries ``sqrt(K_s)`` with
``K_s = alpha G_A^2(theta_el, theta_az) G_E G_P``; absolute calibration estimates K_s against reference
targets of known RCS with a large signal-to-clutter ratio (Section 4.2), and the antenna pattern G_A and
the pointing are characterised with transponders during the commissioning phase (Section 4.1). What is
left enters the error budget as the absolute gain error (``SystemErrorModel.gain_offset_db/gain_sd_db``).

* Point target in clutter: the peak power ``|a + c|^2`` with ``c ~ CN(0, sigma_t / SCR)`` has mean
  ``sigma_t (1 + 1/SCR)`` and relative variance ``(2/SCR + 1/SCR^2)``; N independent targets (or passes)
  average it down by N.
* Antenna pattern and pointing: a pointing error ``dtheta`` makes the processor compensate the pattern at
  the wrong angle. With the two-way sinc pattern of Ahmed et al. (2014), Section II-D.3, one-way power
  ``G(theta) = sinc^2(pi theta / (k theta_half))`` (``sinc x = sin x / x``; ``k`` the beam-shaping factor,
  1.136 for a uniformly weighted array, so that G = 1/2 at ``theta = theta_half / 2``), the exact
  relative error is ``G(theta + dtheta) / G(theta) - 1`` per way; Ahmed et al. (2014) eqs. (32)-(35) give
  its swath-averaged first-order form.
"""

from __future__ import annotations

import numpy as np

from e2esim.errors import PhysicsInputError

DB_PER_NEPER_POWER = 10 / np.log(10)  # d(10 log10 x)/d(ln x): 4.343 dB per unit relative power change
UNIFORM_ARRAY_BEAM_SHAPING = 1 / 0.88  # k of a uniformly weighted array, Ahmed et al. (2014), Table III


def point_target_power_bias(scr) -> np.ndarray:
    """Relative bias ``1/SCR`` of a point target's peak power in clutter (removed by background subtraction)."""
    return 1.0 / np.asarray(scr, dtype=float)


def point_target_power_sd(scr, count: int = 1) -> np.ndarray:
    """Relative SD of the peak-power estimate: ``sqrt((2/SCR + 1/SCR^2) / N)`` for N independent looks."""
    scr = np.asarray(scr, dtype=float)
    if np.any(scr <= 0) or count < 1:
        raise PhysicsInputError(f"need SCR > 0 and at least one target, got SCR {scr!r}, count {count!r}")
    return np.sqrt((2 / scr + 1 / scr**2) / count)


def sinc_pattern(theta, beamwidth, k: float = UNIFORM_ARRAY_BEAM_SHAPING) -> np.ndarray:
    """One-way power pattern ``sinc^2(pi theta / (k theta_half))`` (theta and beamwidth in rad)."""
    x = np.pi * np.asarray(theta, dtype=float) / (k * beamwidth)
    return np.sinc(x / np.pi) ** 2  # numpy's sinc is sin(pi x)/(pi x)


def pattern_gain_error(theta, dtheta, beamwidth, k: float = UNIFORM_ARRAY_BEAM_SHAPING, ways: int = 2) -> np.ndarray:
    """Exact relative gain error of the pattern compensation when the beam points ``dtheta`` off:
    ``(G(theta + dtheta) / G(theta))^ways - 1`` for a target at ``theta`` from the assumed boresight."""
    ratio = sinc_pattern(np.asarray(theta) + dtheta, beamwidth, k) / sinc_pattern(theta, beamwidth, k)
    return ratio**ways - 1


def ahmed_range_gain_error(dtheta, beamwidth, k: float = UNIFORM_ARRAY_BEAM_SHAPING) -> np.ndarray:
    """Ahmed et al. (2014), eq. (33): ``dG/G = (4 dtheta / theta_half) ln[sinc(pi / 2k)]`` (one way, range).

    It is the mean slope of ``ln G`` over half the beam: ``[ln G(theta_half/2) - ln G(0)] / (theta_half/2)``
    times dtheta (checked in the tests against ``sinc_pattern``).
    """
    return 4 * np.asarray(dtheta, dtype=float) / beamwidth * np.log(np.sinc(1 / (2 * k)))


def ahmed_azimuth_gain_error(dtheta, k: float = UNIFORM_ARRAY_BEAM_SHAPING) -> np.ndarray:
    """Ahmed et al. (2014), eq. (34) as printed: ``(2 k dtheta / pi) ln[sinc(pi/2k)] / int_0^{pi/2k} sinc^2``.

    As printed it has no azimuth beamwidth, unlike eq. (33), and its derivation is in Ahmed et al.'s
    reference [21], not in the paper; it is kept as printed for reference and not used by the modules, which
    use the exact pattern (``pattern_gain_error``, ``swath_pointing_gain_sd_db``).
    """
    u = np.pi / (2 * k)
    from scipy import integrate  # imported here: it costs a second at start-up

    area = integrate.quad(lambda x: np.sinc(x / np.pi) ** 2, 0, u)[0]
    return 2 * k * np.asarray(dtheta, dtype=float) / np.pi * np.log(np.sinc(1 / (2 * k))) / area


def dem_pointing_error(dem_height_error, slant_range) -> np.ndarray:
    """Ahmed et al. (2014), eq. (35): ``dtheta = dh_dem / rho`` (rad)."""
    return np.asarray(dem_height_error, dtype=float) / np.asarray(slant_range, dtype=float)


def swath_pointing_gain_sd_db(pointing_sd, beamwidth, k: float = UNIFORM_ARRAY_BEAM_SHAPING,
                              swath_fraction: float = 1.0, nodes: int = 32) -> float:
    """RMS two-way gain error (dB) over targets spread uniformly across ``swath_fraction`` of the
    half-power beam and a Gaussian elevation pointing error of SD ``pointing_sd`` (rad), exact pattern.

    Gauss-Hermite over the pointing error, Gauss-Legendre over the position in the swath.
    """
    if pointing_sd == 0:
        return 0.0
    if not 0 < swath_fraction <= 1:
        raise PhysicsInputError(f"swath_fraction must be in (0, 1], got {swath_fraction!r}")
    z, wz = np.polynomial.hermite_e.hermegauss(nodes)
    wz = wz / wz.sum()
    x, wx = np.polynomial.legendre.leggauss(nodes)
    theta = 0.5 * swath_fraction * beamwidth * x
    wx = wx / wx.sum()
    err = pattern_gain_error(theta[:, None], pointing_sd * z[None, :], beamwidth, k)
    db = DB_PER_NEPER_POWER * np.log(np.clip(1 + err, 1e-30, None))  # far-tail nodes may reach a pattern null
    return float(np.sqrt(np.sum(wx[:, None] * wz[None, :] * db**2)))


def absolute_gain_error_db(scr, count: int = 1, background_subtraction: bool = True, pointing_sd_db: float = 0.0,
                           drift_sd_db: float = 0.0) -> tuple[float, float]:
    """(mean, SD) in dB of the error of the estimated absolute gain |A|^2 from point targets.

    The power estimate's relative bias ``1/SCR`` (unless the background is subtracted) and relative SD
    (``point_target_power_sd``), plus independent pointing/pattern and stability terms in dB. The residual
    gain of the calibrated data is the true gain over the estimate: minus this error.
    """
    rel_sd = float(point_target_power_sd(scr, count))
    mean = 0.0 if background_subtraction else 10 * np.log10(1 + float(point_target_power_bias(scr)))
    sd = float(np.sqrt((DB_PER_NEPER_POWER * rel_sd) ** 2 + pointing_sd_db**2 + drift_sd_db**2))
    return mean, sd
