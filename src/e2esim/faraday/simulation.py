"""Pixel-level reference simulation of the Bickel-Bates estimate (Quegan et al. 2018, eqs. 1-2 and 4-6).

A distributed target seen through ``M = F S F + N`` (no system errors), pixel by pixel, and the estimate of
``e2esim.faraday.estimators.BickelBates`` over each window: the brute-force check of the variance formulas
in ``e2esim.faraday.theory`` (tests/test_bickel_bates.py).
"""

from __future__ import annotations

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.faraday.estimators import BickelBates
from e2esim.polarimetry.system_model import faraday_matrix

_CHUNK_PIXELS = 250_000  # pixels simulated at once (memory about 100 MB)


def simulate_bickel_bates(omega: float, snr, looks: int, trials: int, rng: np.random.Generator,
                          hhvv_correlation: complex = 0.0, cross_ratio: float = 0.2) -> np.ndarray:
    """Omega_hat (rad) of ``trials`` independent windows of ``looks`` pixels of a reciprocal,
    reflection-symmetric distributed target seen through ``M = F S F + N`` (Quegan et al. 2018, eqs. 1-2).

    The target has <|S_hh|^2> = <|S_vv|^2> = 1, <S_hh S_vv*> = ``hhvv_correlation``,
    <|S_hv|^2> = ``cross_ratio``, and the noise power in each of the four channels is sigma_n / 4 with
    sigma_n = <|S_hh + S_vv|^2> / SNR (eq. 6). Returns an array (trials,).
    """
    snr = float(snr)
    if snr <= 0 or looks < 1 or trials < 1:
        raise PhysicsInputError("need SNR > 0, looks >= 1, trials >= 1")
    per_chunk = max(1, _CHUNK_PIXELS // looks)
    return np.concatenate([
        _simulate_chunk(omega, snr, looks, min(per_chunk, trials - start), rng, hhvv_correlation, cross_ratio)
        for start in range(0, trials, per_chunk)
    ])


def _simulate_chunk(omega, snr, looks, trials, rng, hhvv_correlation, cross_ratio):
    shape = (trials, looks)
    cov = np.array([[1.0, hhvv_correlation], [np.conj(hhvv_correlation), 1.0]])
    chol = np.linalg.cholesky(cov)
    w = (rng.standard_normal((*shape, 2)) + 1j * rng.standard_normal((*shape, 2))) / np.sqrt(2)
    hh, vv = np.moveaxis(w @ chol.T, -1, 0)
    hv = np.sqrt(cross_ratio) * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)
    s = np.stack([np.stack([hh, hv], -1), np.stack([hv, vv], -1)], -2)
    sigma_n = (2 + 2 * np.real(hhvv_correlation)) / snr  # <|S_hh + S_vv|^2> / SNR
    noise = np.sqrt(sigma_n / 4) * (rng.standard_normal((*shape, 2, 2)) + 1j * rng.standard_normal((*shape, 2, 2)))
    noise /= np.sqrt(2)
    rot = faraday_matrix(omega)
    m = rot @ s @ rot + noise  # M = F S F + N (eq. 1, no system errors)
    return BickelBates().from_matrices(m, axis=-1).omega
