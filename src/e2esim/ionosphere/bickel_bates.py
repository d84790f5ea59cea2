"""The Bickel-Bates Faraday-rotation estimator and its variance (Quegan et al. 2018, eqs. 4-6).

Bickel & Bates (1965); Freeman (2004), IEEE TGRS 42(8); Rogers & Quegan (2014), IEEE TGRS 52(8). In the
circular basis the Faraday matrix becomes diagonal: with ``P = [[1, j], [j, 1]]`` one has
``P F(Omega) = diag(e^{-j Omega}, e^{j Omega}) P`` and ``F(Omega) P = P diag(e^{j Omega}, e^{-j Omega})``, so
``Z = P M P`` of ``M = F S F`` has

    Z12 = M_vh - M_hv + j (M_hh + M_vv) = j (S_hh + S_vv) e^{-j 2 Omega}    (reciprocal S)
    Z21 = M_hv - M_vh + j (M_hh + M_vv) = j (S_hh + S_vv) e^{+j 2 Omega}

(matrix layout ``[[M_hh, M_vh], [M_hv, M_vv]]`` of e2esim.polarimetry.system_model). Hence, in this
sign convention,

    Omega_hat = -arg(<Z12 Z21*>) / 4 = arg(<Z21 Z12*>) / 4,

the opposite sign of the often-quoted ``arg(Z12 Z21*)/4``, which belongs to the transposed Faraday matrix
(tests/test_bickel_bates.py recovers +Omega through ``measured_matrix``). The estimate is ambiguous
modulo pi/2.

Variance. Z12 and Z21 are jointly circular Gaussian for a distributed target; with noise of equal power in
the four channels (sum sigma_n) their noises are uncorrelated and their coherence is
``gamma = 1 / (1 + sigma_n / <|S_hh + S_vv|^2>)`` (eq. 6). The phase of the L-look sample cross product has
the Cramer-Rao variance ``(1 - gamma^2) / (2 L gamma^2)``, which the estimator attains for large L
(Rodriguez & Martin 1992, IEE Proc. F 139(2); Tough, Blacknell & Quegan 1995, Proc. R. Soc. A 449), so

    var(Omega_hat) = (1/16) (1 - gamma^2) / (2 L gamma^2)        ("corrected").

Eq. (5) of Quegan et al. (2018) prints gamma instead of gamma^2 in the denominator ("printed"); simulation
confirms gamma^2 (docs/errata.md).
"""

from __future__ import annotations

import numpy as np

from e2esim.calibration.faraday_theory import bickel_bates_coherence
from e2esim.calibration.faraday_theory import bickel_bates_variance as _variance
from e2esim.errors import PhysicsInputError
from e2esim.polarimetry.system_model import faraday_matrix

VARIANCE_FORMS = ("corrected", "printed")


def circular_products(m) -> tuple:
    """(Z12, Z21) of measured matrices ``m`` (..., 2, 2) laid out ``[[hh, vh], [hv, vv]]``."""
    m = np.asarray(m)
    hh, vh, hv, vv = m[..., 0, 0], m[..., 0, 1], m[..., 1, 0], m[..., 1, 1]
    copol = 1j * (hh + vv)
    return vh - hv + copol, hv - vh + copol


def bickel_bates(m, axis: int = -1) -> np.ndarray:
    """Omega_hat (rad) from measured matrices (..., 2, 2), averaging Z21 Z12* over ``axis`` of the leading
    dimensions (the L looks). Sign convention of the module docstring; result in (-pi/4, pi/4]."""
    z12, z21 = circular_products(m)
    return np.angle(np.sum(z21 * np.conj(z12), axis=axis)) / 4


def coherence_from_snr(snr) -> np.ndarray:
    """gamma = 1 / (1 + 1/SNR), Quegan et al. (2018), eq. (6); SNR = <|S_hh + S_vv|^2> / sigma_n (linear).
    (The same function as ``e2esim.calibration.faraday_theory.bickel_bates_coherence``.)"""
    return bickel_bates_coherence(snr)


def bickel_bates_variance(snr, looks, form: str = "corrected") -> np.ndarray:
    """var(Omega_hat) (rad^2) for SNR (linear, eq. 6) and L looks: ``corrected`` (1/16)(1 - g^2)/(2 L g^2)
    or ``printed``, Quegan et al. (2018) eq. (5) as printed, (1/16)(1 - g^2)/(2 g L). One implementation:
    ``e2esim.calibration.faraday_theory.bickel_bates_variance`` (forms "asymptotic" and "printed")."""
    if form not in VARIANCE_FORMS:
        raise PhysicsInputError(f"variance form {form!r} is not one of {VARIANCE_FORMS}")
    return np.asarray(_variance(snr, looks, "asymptotic" if form == "corrected" else "printed"))


def simulate_bickel_bates(omega: float, snr, looks: int, trials: int, rng: np.random.Generator,
                          hhvv_correlation: complex = 0.0, cross_ratio: float = 0.2) -> np.ndarray:
    """Omega_hat of ``trials`` independent windows of ``looks`` pixels of a reciprocal, reflection-symmetric
    distributed target seen through ``M = F S F + N`` (Quegan et al. 2018, eqs. 1-2; no system errors).

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


_CHUNK_PIXELS = 250_000  # pixels simulated at once (memory about 100 MB)


def _simulate_chunk(omega, snr, looks, trials, rng, hhvv_correlation, cross_ratio):
    shape = (trials, looks)
    cov = np.array([[1.0, hhvv_correlation], [np.conj(hhvv_correlation), 1.0]])
    chol = np.linalg.cholesky(cov)
    w = (rng.standard_normal(shape + (2,)) + 1j * rng.standard_normal(shape + (2,))) / np.sqrt(2)
    hh, vv = np.moveaxis(w @ chol.T, -1, 0)
    hv = np.sqrt(cross_ratio) * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)
    s = np.stack([np.stack([hh, hv], -1), np.stack([hv, vv], -1)], -2)
    sigma_n = (2 + 2 * np.real(hhvv_correlation)) / snr  # <|S_hh + S_vv|^2> / SNR
    noise = np.sqrt(sigma_n / 4) * (rng.standard_normal(shape + (2, 2)) + 1j * rng.standard_normal(shape + (2, 2)))
    noise /= np.sqrt(2)
    rot = faraday_matrix(omega)
    m = np.einsum("ij,...jk,kl->...il", rot, s, rot) + noise  # M = F S F + N (eq. 1, no system errors)
    return bickel_bates(m, axis=-1)
