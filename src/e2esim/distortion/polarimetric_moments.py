"""Mean and covariance of the errors of sigma_hh, sigma_hv and sigma_vv together (docs/theory/co-pol-error.md).

``polarimetric_error_moments`` gives, for one scene, system-error model and Faraday-rotation distribution,
the mean vector and covariance matrix of ``e_p = sigma_hat_p - sigma_p`` for p in (hh, hv, vv), with their
parts by source, at any crosstalk, channel-imbalance and noise levels (broadcast, one call for a curve):

* at fixed angles, the exact mean and the exact covariance of the signal powers, as polynomials in the levels:
  to O(V^2) by ``e2esim.distortion.channel_moments`` (co-pol eqs. 3.2-3.3), the O(V^3) and O(V^4) rest by
  ``e2esim.distortion.higher_order`` (co-pol eq. 3.6);
* averaged exactly over Faraday rotation (and the residual rotation of a correction,
  ``e2esim.distortion.faraday_correction``) with the law of total covariance (co-pol eq. 4.2):
  ``Cov e = E_Omega[Cov(e | Omega)] + Cov_Omega[E(e | Omega)]``. The co-polarised channels are not
  invariant under rotation, so the second part (the spread of the rotation bias) can dominate;
* noise (``sigma_n`` in HH and VV, ``sigma_n / 2`` in HV, independent between channels also after a
  correction, which is an orthogonal rotation of the four noise terms), an absolute gain error and, for a
  window of L looks, the noise (``scene`` reference) or noise and speckle (``population``) over the window
  (co-pol sec. 5).

For HV its terms to O(V^2) equal ``e2esim.distortion.analytic.hv_error_moments(form="complete")`` (tested to 1e-12;
``higher_order=False`` leaves the rest out); the O(V^3) and O(V^4) terms that model leaves out are relative O(V)
of a first-order variance there (docs/theory/validity.md).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from e2esim.distortion.channel_moments import (
    CONSTANT,
    CROSSTALK,
    CROSSTALK2,
    IMBALANCE,
    IMBALANCE2,
    MIXED,
    conditional_polynomials,
    monomials,
    unit_covariances,
)
from e2esim.distortion.expansion import expansion_at
from e2esim.distortion.faraday_correction import CORRECTED_DEGREE, FaradayCorrection
from e2esim.distortion.higher_order import covariance_coefficients, higher_monomials, split_by_source
from e2esim.polarimetry.system_model import RECIPROCAL_CHANNELS, estimator_noise_factor

REFERENCES = ("scene", "population")
NOISE_FACTORS = np.array([estimator_noise_factor(ch) for ch in RECIPROCAL_CHANNELS])  # (1, 1/2, 1)


@dataclass(frozen=True)
class ErrorPolynomial:
    """The signal part of the moments averaged over the angles, as coefficients of ``MONOMIALS`` (co-pol 4.2).

    sigma : (..., 3) true powers. mean : (..., 6, 3, 3) complex, E[A C A^H]. cov : (..., 6, 3, 3), the average
    of the conditional covariance of the powers to O(V^2). cov_higher : (..., 9, 3, 3), its O(V^3) and O(V^4)
    terms (``higher_order.HIGHER_MONOMIALS``). spread : (..., 6, 6, 3, 3), Cov over the angles of the
    coefficients of the conditional mean powers: Cov_Omega(m_p, m_q) = sum_kl x_k x_l spread[k, l, p, q].
    """

    sigma: np.ndarray
    mean: np.ndarray
    cov: np.ndarray
    spread: np.ndarray
    cov_higher: np.ndarray

    @classmethod
    def build(cls, scene_matrix, gammas, omega, omega_hat, weights, nodes: tuple | None = None) -> ErrorPolynomial:
        """From the scene covariance (..., 3, 3), unit error covariances (2, 6, 6), nodes (G,) and weights (..., G).
        nodes : ``node_polynomials`` of the same scene, error covariances and nodes, if the caller has them."""
        cond_mean, cond_cov, cond_higher = nodes or node_polynomials(scene_matrix, gammas, omega, omega_hat)
        w = np.asarray(weights, float)
        mean = np.einsum("...g,...gkpq->...kpq", w, cond_mean)
        cov = np.einsum("...g,...gkpq->...kpq", w, cond_cov)
        higher = np.einsum("...g,...gkpq->...kpq", w, cond_higher)
        sigma = np.real(np.diagonal(np.asarray(scene_matrix), axis1=-2, axis2=-1))
        # conditional mean errors (the true power taken out of the constant term: less cancellation below)
        diag = np.real(np.diagonal(cond_mean, axis1=-2, axis2=-1)).copy()  # (..., G, 6, 3)
        diag[..., CONSTANT, :] -= sigma[..., None, :]
        mdiag = np.einsum("...g,...gkp->...kp", w, diag)
        spread = (np.einsum("...g,...gkp,...glq->...klpq", w, diag, diag)
                  - mdiag[..., :, None, :, None] * mdiag[..., None, :, None, :])
        return cls(sigma, mean, cov, spread, higher)


def node_polynomials(scene_matrix, gammas, omega, omega_hat, memo=None) -> tuple:
    """The conditional moments at each node, before they are averaged with the weights: (mean (..., G, 6, 3, 3)
    complex and cov (..., G, 6, 3, 3) of co-pol eqs. 3.2-3.3, the O(V^3) and O(V^4) covariance (..., G, 9, 3, 3)
    of eq. 3.6). Almost all the cost of ``ErrorPolynomial.build``; they do not depend on the weights. memo : the
    ``KernelMemo`` that keeps the expansion at the nodes (``expansion_at``), or None."""
    exp = expansion_at(omega, omega_hat, memo)
    cond = conditional_polynomials(exp, scene_matrix, gammas)
    return cond.mean, cond.cov, covariance_coefficients(exp, scene_matrix, gammas)


@dataclass(frozen=True)
class ChannelErrorMoments:
    """Mean and covariance of ``e = sigma_hat - sigma`` for (hh, hv, vv), split by source (co-pol sec. 5).

    Vectors (..., 3) and matrices (..., 3, 3) in m^2/m^2 and (m^2/m^2)^2, over the broadcast shape of the
    levels. Bias parts add up to ``mean``, covariance parts to ``covariance``.

    bias_faraday : what the rotation alone does (zero order in the system errors; 0 for HV).
    bias_crosstalk, bias_imbalance : first order in V_delta, V_eps (eq. 11 for HV). bias_higher_order :
    second order (Gaussian fourth moments). bias_noise : sigma_n (HH, VV), sigma_n / 2 (HV). bias_gain : the
    absolute gain error. cov_crosstalk, cov_imbalance : terms in V_delta alone and in V_eps alone;
    cov_interaction : in V_delta V_eps (for HV: (A5), (A4), (A6) and the E3 terms). cov_faraday_spread : Cov
    over the rotation of the conditional mean. cov_finite_looks : noise (and speckle) over the window.
    cov_gain : the gain error. expected_covariance : (..., 3, 3) the mean of the estimated covariance matrix
    (gain and noise included), whose off-diagonal gives the HH-VV correlation the data show.
    """

    mean: np.ndarray
    covariance: np.ndarray
    bias_faraday: np.ndarray
    bias_crosstalk: np.ndarray
    bias_imbalance: np.ndarray
    bias_higher_order: np.ndarray
    bias_noise: np.ndarray
    bias_gain: np.ndarray
    cov_crosstalk: np.ndarray
    cov_imbalance: np.ndarray
    cov_interaction: np.ndarray
    cov_faraday_spread: np.ndarray
    cov_finite_looks: np.ndarray
    cov_gain: np.ndarray
    expected_covariance: np.ndarray
    sigma: np.ndarray
    channels: tuple = RECIPROCAL_CHANNELS

    @property
    def variance(self) -> np.ndarray:
        return np.diagonal(self.covariance, axis1=-2, axis2=-1)

    @property
    def sd(self) -> np.ndarray:
        return np.sqrt(np.clip(self.variance, 0.0, None))

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def evaluate(poly: ErrorPolynomial, crosstalk, imbalance, noise_power, gain_moments=(1.0, 1.0),
             looks: int | None = None, reference: str = "scene", higher_order: bool = True) -> ChannelErrorMoments:
    """The moments at levels V_delta, V_eps, sigma_n (broadcast against each other; co-pol eqs. 4.2, 5.1-5.4).
    ``higher_order=False``: the covariance to O(V^2) only (co-pol eq. 3.3, as the HV model of Men et al.)."""
    if reference not in REFERENCES:
        raise ValueError(f"reference must be one of {REFERENCES}, got {reference!r}")
    x = monomials(crosstalk, imbalance)  # (..., 6)
    sn = np.asarray(noise_power, float)
    shape = np.broadcast_shapes(x.shape[:-1], sn.shape)
    x = np.broadcast_to(x, shape + (6,))
    sn = np.broadcast_to(sn, shape)
    ex = x[..., :, None, None]
    mean_parts = poly.mean * ex  # (..., 6, 3, 3)
    cov_parts = poly.cov * ex
    xx = (x[..., :, None] * x[..., None, :]).reshape(shape + (1, 36))
    spread = (xx @ poly.spread.reshape(poly.spread.shape[:-4] + (36, 9))).reshape(shape + (3, 3))

    def diag(m):
        return np.real(np.diagonal(m, axis1=-2, axis2=-1))

    bias_faraday = diag(mean_parts[..., CONSTANT, :, :]) - poly.sigma
    bias_crosstalk = diag(mean_parts[..., CROSSTALK, :, :])
    bias_imbalance = diag(mean_parts[..., IMBALANCE, :, :])
    bias_higher = diag(mean_parts[..., CROSSTALK2:, :, :].sum(-3))
    cov_crosstalk = cov_parts[..., CROSSTALK, :, :] + cov_parts[..., CROSSTALK2, :, :]
    cov_imbalance = cov_parts[..., IMBALANCE, :, :] + cov_parts[..., IMBALANCE2, :, :]
    cov_interaction = cov_parts[..., MIXED, :, :]
    if higher_order:  # O(V^3) and O(V^4), co-pol eq. (3.6)
        more = split_by_source(poly.cov_higher * higher_monomials(crosstalk, imbalance)[..., :, None, None])
        cov_crosstalk, cov_imbalance, cov_interaction = (
            a + b for a, b in zip((cov_crosstalk, cov_imbalance, cov_interaction), more))
    signal_matrix = mean_parts.sum(-3)  # E[A C A^H]
    q1 = diag(signal_matrix)  # mean signal powers
    signal_cov = cov_crosstalk + cov_imbalance + cov_interaction + spread

    g1, g2 = gain_moments
    bias_gain = (g1 - 1.0) * q1
    cov_gain = (g2 - 1.0) * signal_cov + (g2 - g1**2) * q1[..., :, None] * q1[..., None, :]
    noise = sn[..., None] * NOISE_FACTORS  # sigma_nu^2 per channel
    finite = np.zeros(signal_cov.shape)
    if looks is not None:
        idx = np.arange(3)
        if reference == "scene":  # noise over L looks given the signal (noncentral chi-square)
            finite[..., idx, idx] = (noise**2 + 2 * noise * g1 * q1) / looks
        else:  # fresh speckle and noise: |E[G A C A^H] + Sigma_nu|^2 / L, E[q^2] on the diagonal
            finite = g2 * np.abs(signal_matrix) ** 2 / looks
            finite[..., idx, idx] = (g2 * (np.diagonal(signal_cov, axis1=-2, axis2=-1) + q1**2)
                                     + 2 * noise * g1 * q1 + noise**2) / looks
    expected = g1 * signal_matrix + noise[..., :, None] * np.eye(3)
    mean = bias_faraday + bias_crosstalk + bias_imbalance + bias_higher + noise + bias_gain
    covariance = signal_cov + cov_gain + finite
    return ChannelErrorMoments(mean, covariance, bias_faraday, bias_crosstalk, bias_imbalance, bias_higher, noise,
                               bias_gain, cov_crosstalk, cov_imbalance, cov_interaction, spread, finite, cov_gain,
                               expected, poly.sigma)


def evaluate_totals(poly: ErrorPolynomial, crosstalk, imbalance, noise_power, gain_moments=(1.0, 1.0),
                    looks: int | None = None, reference: str = "scene", higher_order: bool = True) -> tuple:
    """(mean (..., 3), covariance (..., 3, 3)) of ``evaluate`` without the parts: a few matrix products, for the
    many evaluations of root finding (margins, trade-off curves)."""
    x = monomials(crosstalk, imbalance)
    sn = np.asarray(noise_power, float)
    shape = np.broadcast_shapes(x.shape[:-1], sn.shape, poly.sigma.shape[:-1])
    x = np.broadcast_to(x, shape + (6,))[..., None, :]  # (..., 1, 6)
    lead = poly.mean.shape[:-3]
    mean_m = poly.mean.reshape(lead + (6, 9))
    signal = (x @ mean_m).reshape(shape + (3, 3))  # E[A C A^H]
    q1 = np.real(np.diagonal(signal, axis1=-2, axis2=-1))
    xx = (x[..., 0, :, None] * x[..., 0, None, :]).reshape(shape + (1, 36))
    signal_cov = (x @ poly.cov.reshape(lead + (6, 9))) + xx @ poly.spread.reshape(lead + (36, 9))
    if higher_order:  # O(V^3) and O(V^4), co-pol eq. (3.6)
        xh = np.broadcast_to(higher_monomials(crosstalk, imbalance), shape + (9,))[..., None, :]
        signal_cov = signal_cov + xh @ poly.cov_higher.reshape(lead + (9, 9))
    signal_cov = signal_cov.reshape(shape + (3, 3))
    g1, g2 = gain_moments
    noise = np.broadcast_to(sn, shape)[..., None] * NOISE_FACTORS
    mean = g1 * q1 + noise - poly.sigma
    cov = g2 * signal_cov + (g2 - g1**2) * q1[..., :, None] * q1[..., None, :]
    if looks is not None:
        idx = np.arange(3)
        if reference == "scene":
            cov[..., idx, idx] += (noise**2 + 2 * noise * g1 * q1) / looks
        else:
            finite = g2 * np.abs(signal) ** 2 / looks
            finite[..., idx, idx] = (g2 * (np.diagonal(signal_cov, axis1=-2, axis2=-1) + q1**2)
                                     + 2 * noise * g1 * q1 + noise**2) / looks
            cov = cov + finite
    return mean, cov


def error_polynomial(scene, system, faraday, correction: FaradayCorrection | None = None,
                     memo=None) -> ErrorPolynomial:
    """``ErrorPolynomial`` for a ``ScatteringCovariance``, ``SystemErrorModel`` and ``FaradayDistribution``.
    ``memo`` (the process's ``KernelMemo``, ``case.services.memo``, or None) keeps the last ``POLYNOMIALS_KEPT``,
    for the sweep cases that share them (e.g. several retrievals of the same data, or the level searches of
    ``e2esim allocate``). Keyed by the values ``ErrorPolynomial.build`` reads (the quadrature nodes and weights,
    not the distribution objects: a case's residual rotation is a new ``EmpiricalFaraday`` of equal samples), so a
    hit is the same polynomial bit for bit."""
    correction = correction or FaradayCorrection()
    gammas = unit_covariances(system)
    omega, omega_hat, weights = correction.nodes(faraday, CORRECTED_DEGREE)
    if memo is None:
        return ErrorPolynomial.build(scene.matrix, gammas, omega, omega_hat, weights)
    inputs = tuple(None if a is None else (np.shape(a), np.ascontiguousarray(a).tobytes())
                   for a in (scene.matrix, gammas, omega, omega_hat, weights))

    def build():
        # the node work does not depend on the weights: the rotation distributions of one scene's cases (a residual
        # rotation per calibration) share their nodes and differ in their weights only (biomass_multichannel: 8
        # builds over 2 scenes)
        nodes = memo.recall(("error polynomial nodes", *inputs[:4]),
                            lambda: node_polynomials(scene.matrix, gammas, omega, omega_hat, memo), keep=NODE_SETS_KEPT)
        return ErrorPolynomial.build(scene.matrix, gammas, omega, omega_hat, weights, nodes)

    return memo.recall(("error polynomial", *inputs), build, keep=POLYNOMIALS_KEPT)


POLYNOMIALS_KEPT = 32
NODE_SETS_KEPT = 4  # a few MB per scene at a few hundred nodes


def polarimetric_error_moments(scene, system, faraday, correction: FaradayCorrection | None = None,
                               looks: int | None = None, reference: str = "scene", crosstalk_level=None,
                               imbalance_level=None, noise_power=None, higher_order: bool = True,
                               memo=None) -> ChannelErrorMoments:
    """Mean and covariance of the errors of (sigma_hh, sigma_hv, sigma_vv) (module docstring).

    scene, system, faraday : ``ScatteringCovariance`` (any Hermitian covariance: complex HH-VV correlation,
    no reflection symmetry needed), ``SystemErrorModel`` (any variances and pair correlations),
    ``FaradayDistribution`` of Omega. correction : how the co-polarised channels treat Faraday rotation
    (default: not corrected). looks, reference : as ``hv_error_moments``. crosstalk_level, imbalance_level,
    noise_power : replace V_delta, V_eps, sigma_n (broadcast). higher_order : False leaves out the O(V^3) and
    O(V^4) covariance terms (co-pol eq. 3.6), as the HV model of Men et al. (2021) does. memo : as
    ``error_polynomial``.
    """
    poly = error_polynomial(scene, system, faraday, correction, memo)
    return evaluate(poly, system.crosstalk_level if crosstalk_level is None else crosstalk_level,
                    system.imbalance_level if imbalance_level is None else imbalance_level,
                    system.noise_power if noise_power is None else noise_power,
                    system.gain_power_moments, looks, reference, higher_order)
