"""The mean and variance of the errors of sigma_hh, sigma_hv and sigma_vv for many scenes and Gaussian Faraday
rotations at one system (one set of distortion levels): the numbers ``polarimetric_error_moments`` gives case by
case (no Faraday-rotation correction, ``reference="scene"``), at a few microseconds a case instead of milliseconds.

Why it can be fast (docs/theory/co-pol-error.md, co-pol eqs. 3.2-3.6 and 4.2): at a fixed rotation Omega and fixed
errors, the estimated powers ``q_p = a_p C a_p^H`` are linear in the scene covariance C. So the conditional mean
powers are linear in C and their conditional covariance (every order in the levels) is a quadratic form in C. With
a reflection-symmetric scene, C is a real combination ``C = sum_b c_b B_b`` of five Hermitian matrices (``BASIS``:
sigma_hh, sigma_hv, sigma_vv, Re and Im of <S_hh S_vv*>). The levels are the same for every case, so they are
contracted in once: ``PolarimetricPixelModel.build`` evaluates the exact conditional polynomials
(``channel_moments.conditional_polynomials``, ``higher_order.covariance_coefficients``) at the five basis matrices
and their ten pairwise sums (polarisation identity) at the 17 fixed nodes of ``FaradayDistribution.quadrature``.
A case then only needs its weights at those nodes (``w_g = (1/G)(1 + 2 Re sum_k phi_k exp(-i k Omega_g))``,
phi_k = exp(i k mean - k^2 sd^2 / 2) for a Gaussian Omega, Men et al. 2021 eq. 10) and a few small contractions;
the law of total covariance (co-pol eq. 4.2) is applied with those weights as ``ErrorPolynomial.build`` does.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from e2esim.distortion.channel_moments import conditional_polynomials, monomials, unit_covariances
from e2esim.distortion.expansion import expansion_at
from e2esim.distortion.higher_order import covariance_coefficients, higher_monomials
from e2esim.distortion.polarimetric_moments import NOISE_FACTORS
from e2esim.faraday.distribution import QUADRATURE_DEGREE, quadrature_nodes


def _basis() -> np.ndarray:
    b = np.zeros((5, 3, 3), dtype=complex)
    b[0, 0, 0] = b[1, 1, 1] = b[2, 2, 2] = 1.0
    b[3, 0, 2] = b[3, 2, 0] = 1.0
    b[4, 0, 2], b[4, 2, 0] = 1j, -1j
    return b


BASIS = _basis()
"""C = sigma_hh B_0 + sigma_hv B_1 + sigma_vv B_2 + Re<S_hh S_vv*> B_3 + Im<S_hh S_vv*> B_4."""
PAIRS = tuple(itertools.combinations(range(5), 2))
TRUE_POWER = np.eye(5, 3)
"""sigma_p = sum_b c_b TRUE_POWER[b, p]: the true powers are the first three coefficients."""
FEW_ROTATIONS = 8
"""Pixels per distinct rotation (mean, SD) from which they are grouped by rotation (``_by_rotation``)."""


@dataclass(frozen=True)
class PolarimetricPixelModel:
    """The conditional moments at the quadrature nodes as functions of the scene coefficients, levels contracted.

    mean : (G, 5, 3): the conditional mean signal power of channel p at node g is ``sum_b c_b mean[g, b, p]``.
    cov : (G, 25, 3): its conditional variance is ``sum_bb' c_b c_b' cov[g, 5 b + b', p]``. gain_moments :
    (E|A|^2, E|A|^4) of the absolute gain error.
    """

    mean: np.ndarray
    cov: np.ndarray
    gain_moments: tuple

    @classmethod
    def build(cls, system, higher_order: bool = True) -> PolarimetricPixelModel:
        """For a ``SystemErrorModel`` at its own levels (``higher_order`` as ``polarimetric_error_moments``)."""
        exp = expansion_at(quadrature_nodes(QUADRATURE_DEGREE))
        gammas = unit_covariances(system)
        scenes = np.concatenate([BASIS, [BASIS[a] + BASIS[b] for a, b in PAIRS]])  # (15, 3, 3)
        cond = conditional_polynomials(exp, scenes, gammas)
        x = monomials(system.crosstalk_level, system.imbalance_level)  # (6,)

        def diag(m):  # (..., 3, 3) -> (..., 3)
            return np.real(np.diagonal(m, axis1=-2, axis2=-1))

        mean = np.einsum("k,sgkp->sgp", x, diag(cond.mean))  # (15, G, 3), linear in C: the first 5 suffice
        var = np.einsum("k,sgkp->sgp", x, diag(cond.cov))
        if higher_order:
            xh = higher_monomials(system.crosstalk_level, system.imbalance_level)
            var = var + np.einsum("k,sgkp->sgp", xh, diag(covariance_coefficients(exp, scenes, gammas)))
        quad = np.zeros((5, 5) + var.shape[1:])
        for b in range(5):
            quad[b, b] = var[b]
        for i, (a, b) in enumerate(PAIRS):  # polarisation: Q(B_a + B_b) = Q_aa + Q_bb + 2 Q_ab
            quad[a, b] = quad[b, a] = 0.5 * (var[5 + i] - var[a] - var[b])
        return cls(np.moveaxis(mean[:5], 0, 1), np.moveaxis(quad.reshape((25,) + var.shape[1:]), 0, 1),
                   system.gain_power_moments)

    def moments(self, scene, fr_mean, fr_sd, noise_power, looks=None) -> tuple:
        """(mean (n, 3), variance (n, 3)) of the errors of (sigma_hh, sigma_hv, sigma_vv) for n cases.

        scene : (n, 5) coefficients of ``BASIS``. fr_mean, fr_sd : (n,) Gaussian Omega (rad). noise_power : (n,)
        sigma_n. looks : (n,) or None, the noise over a window of looks (``reference="scene"``, co-pol sec. 5).
        """
        c = np.asarray(scene, float)
        fr = np.stack([np.asarray(fr_mean, float), np.asarray(fr_sd, float)], axis=-1)
        if (fr == fr[:1]).all():
            rotations, which = fr[:1], None
        else:
            rotations, which = np.unique(fr[:, 0] + 1j * fr[:, 1], return_inverse=True)
            rotations = np.stack([rotations.real, rotations.imag], axis=-1)
        if len(rotations) * FEW_ROTATIONS <= len(c):
            q1, signal_var = self._by_rotation(c, rotations, which)
        else:
            q1, signal_var = self._by_pixel(c, fr)
        g1, g2 = self.gain_moments
        noise = np.asarray(noise_power, float)[:, None] * NOISE_FACTORS
        var = g2 * signal_var + (g2 - g1**2) * q1**2
        if looks is not None:
            var = var + (noise**2 + 2 * noise * g1 * q1) / np.asarray(looks, float)[:, None]
        return g1 * q1 + noise - c[:, :3], var

    def _by_pixel(self, c, fr) -> tuple:
        """(q1, Var of the signal powers) (n, 3) with each pixel's weights at the nodes."""
        n, n_nodes = len(c), self.mean.shape[0]
        w = gaussian_weights(fr[:, 0], fr[:, 1])  # (n, G)
        m = (c @ np.moveaxis(self.mean, 1, 0).reshape(5, -1)).reshape(n, n_nodes, 3)  # conditional powers
        q1 = (w[:, :, None] * m).sum(1)
        err = m - c[:, None, :3]  # conditional mean errors (the true power out first: less cancellation)
        spread = (w[:, :, None] * err * err).sum(1) - (q1 - c[:, :3]) ** 2  # Cov over Omega (co-pol eq. 4.2)
        cc = (c[:, :, None] * c[:, None, :]).reshape(n, 25, 1)
        within = (cc * (w @ self.cov.reshape(n_nodes, -1)).reshape(n, 25, 3)).sum(1)
        return q1, within + spread

    def _by_rotation(self, c, rotations, which) -> tuple:
        """``_by_pixel`` for pixels that share a few rotations (the scenario's, a constant correction): the
        averages over the nodes are taken once per rotation, leaving a linear and a quadratic form of the scene
        per pixel (the true power taken out of the coefficients: E[(m_g - sigma)^2] = c^T S c)."""
        n_nodes = self.mean.shape[0]
        w = gaussian_weights(rotations[:, 0], rotations[:, 1])  # (u, G)
        linear = (w @ self.mean.reshape(n_nodes, -1)).reshape(len(w), 5, 3)
        err = self.mean - TRUE_POWER  # (G, 5, 3)
        square = (err[:, :, None, :] * err[:, None, :, :]).reshape(n_nodes, -1)
        quadratic = (w @ (square + self.cov.reshape(n_nodes, -1))).reshape(len(w), 25, 3)
        if which is None:  # one rotation for all: matrix products
            q1 = c @ linear[0]
            square = ((c @ quadratic[0].reshape(5, 15)).reshape(len(c), 5, 3) * c[:, :, None]).sum(1)
        else:
            q1 = (c[:, :, None] * linear[which.ravel()]).sum(1)
            cc = (c[:, :, None] * c[:, None, :]).reshape(len(c), 25, 1)
            square = (cc * quadratic[which.ravel()]).sum(1)
        return q1, square - (q1 - c[:, :3]) ** 2


def gaussian_weights(mean, sd, degree: int = QUADRATURE_DEGREE) -> np.ndarray:
    """(n, G) weights of ``FaradayDistribution.quadrature`` for Gaussian rotations (mean, sd) (rad)."""
    nodes = quadrature_nodes(degree)
    k = np.arange(1, degree + 1)
    phi = np.exp(1j * k * mean[:, None] - 0.5 * (k * sd[:, None]) ** 2)  # (n, K)
    return (1 + 2 * np.real(phi @ np.exp(-1j * np.outer(k, nodes)))) / nodes.size


PIXEL_MODELS_KEPT = 4
"""Pixel models a memo keeps (``pixel_model_for``): every block of a product has the same one or two systems."""


def pixel_model_for(system, memo, higher_order: bool = True) -> PolarimetricPixelModel:
    """``PolarimetricPixelModel.build``, found again in ``memo`` (an ``e2esim.case.KernelMemo``, the caller's) by
    the values it reads: the system's unit covariances, levels and gain moments, and ``higher_order``."""
    key = ("pixel model", unit_covariances(system).tobytes(), float(system.crosstalk_level),
           float(system.imbalance_level), tuple(system.gain_power_moments), higher_order)
    return memo.recall(key, lambda: PolarimetricPixelModel.build(system, higher_order), keep=PIXEL_MODELS_KEPT)
