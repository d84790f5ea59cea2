"""Speckle, thermal and multiplicative noise, Ahmed et al. (2014), eqs. (21) and (26)-(29)."""

from __future__ import annotations

import numpy as np

_ISLR_POLY = (-46.965, 104.11, -112.59, 43.124)  # eq. (29): ISLR(eta) in dB, coefficients of eta^0..eta^3
_QNR_OFFSET_DB, _QNR_PER_BIT_DB = 2.0, 6.02  # eq. (28), after Curlander & McDonough (1991)


def islr_db(eta):
    """Integrated sidelobe ratio (dB) of a window with pedestal eta, eq. (29) (a polynomial fit).

    ``e2esim.budget.window.window_islr_db`` integrates the impulse response exactly: eq. (29) matches it
    within 0.6 dB for eta in [0.5, 1] when the main lobe is taken as +-2 resolution widths (uniform
    weighting: -12.3 dB from eq. 29, -12.6 dB exactly), and is 4-5 dB more optimistic near Hamming/Hann.
    """
    eta = np.asarray(eta, dtype=float)
    return _ISLR_POLY[0] + eta * (_ISLR_POLY[1] + eta * (_ISLR_POLY[2] + eta * _ISLR_POLY[3]))


def quantisation_noise_ratio_db(bits):
    """Signal to quantisation-noise ratio QNR ~ 2.0 + 6.02 b (dB), eq. (28). bits : b."""
    return _QNR_OFFSET_DB + _QNR_PER_BIT_DB * np.asarray(bits, dtype=float)


def inverse_mnr(islr_range, islr_azimuth, ambiguity_ratio, quantisation_ratio):
    """1 / MNR = ISLR_rho + ISLR_s + 1 / AMB_t + 1 / QNR, eq. (27), all as linear power ratios.

    (The printed eq. (27) calls the last term 1/ONR; eq. (28) defines it as the QNR.)
    """
    return (np.asarray(islr_range, float) + np.asarray(islr_azimuth, float) + 1.0 / np.asarray(ambiguity_ratio, float)
            + 1.0 / np.asarray(quantisation_ratio, float))


def snr(sigma, nesz):
    """Thermal signal-to-noise ratio sigma / sigma_0_bar, eq. (26) (linear)."""
    return np.asarray(sigma, dtype=float) / np.asarray(nesz, dtype=float)


def speckle_noise_terms(looks, obs_total, obs_diverse, snr_linear, inverse_mnr_linear):
    """The three parts of eq. (21) as relative standard deviations of sigma (dimensionless).

    ``Delta sigma_s / sigma = 1/sqrt(N) (1/sqrt(N_os) + 1/sqrt(N_ot) (1 + SNR/MNR)/SNR)``, split as
    speckle ``1/sqrt(N N_os)``, thermal noise ``1/(sqrt(N N_ot) SNR)`` and multiplicative noise
    ``1/(sqrt(N N_ot) MNR)`` (since (1 + SNR/MNR)/SNR = 1/SNR + 1/MNR). The three add *linearly* in
    eq. (21) (the scatterometer Kp of an intensity averaged over N looks, (1 + 1/SNR)/sqrt(N), is exact for
    speckled signal plus noise with the noise level subtracted). Returns (speckle, thermal, multiplicative).
    """
    n = np.asarray(looks, dtype=float)
    nos = np.asarray(obs_diverse, dtype=float)
    not_ = np.asarray(obs_total, dtype=float)
    speckle = 1.0 / np.sqrt(n * nos)
    common = 1.0 / np.sqrt(n * not_)
    thermal = common / np.asarray(snr_linear, dtype=float)
    multiplicative = common * np.asarray(inverse_mnr_linear, dtype=float)
    return speckle, thermal, multiplicative
