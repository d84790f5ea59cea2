"""Moments of the estimated covariance at fixed angles, as polynomials in the error levels (co-pol sec. 3).

With ``A = a0 + a1 + a2`` (``e2esim.distortion.expansion``; a1 linear, a2 bilinear in the errors xi) the
signal part of the estimated covariance is ``A C A^H`` and the estimated power of channel p is
``q_p = a_p C a_p^H``, with a_p the row p of A. Ordered by the power of xi (co-pol eq. 3.1):

    q_p = a0 C a0^H + T1_p + T2_p + T3_p + a2 C a2^H,
    T1_p = 2 Re(a0 C a1^H),  T2_p = a1 C a1^H + 2 Re(a0 C a2^H),  T3_p = 2 Re(a1 C a2^H)   (row p everywhere)

xi is zero-mean circular complex Gaussian with covariance Gamma = V_delta Gamma_delta + V_eps Gamma_eps
(Men et al. 2021, Section III: correlated only in the pairs (delta1, delta3), (delta2, delta4), (eps1, eps2);
here any Hermitian unit structures). Isserlis' theorem for circular Gaussians gives:

* the mean of the whole matrix exactly (co-pol eq. 3.2): ``E[A C A^H] = a0 C a0^H + E[a1 C a1^H]
  + E[a2 C a2^H]`` (odd moments and E[xi_i xi_j] vanish);
* the covariance of the powers to O(V^2) (co-pol eq. 3.3): ``Cov(q_p, q_q) = Cov(T1_p, T1_q)
  + Cov(T2_p, T2_q) + Cov(T1_p, T3_q) + Cov(T3_p, T1_q)``; the terms left out are O(V^3).

Everything is returned as coefficients of the monomials ``MONOMIALS`` of the levels, so that any level can
be evaluated afterwards without recomputing (margins, trade-off curves). For HV these are Men et al. (2021),
eqs. (11) and (12) = (A4) + (A5) + (A6), with the two O(V^2) terms errata E3 adds (co-pol sec. 6).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.distortion.expansion import RECEIVE, TRANSMIT, Expansion

MONOMIALS = ("1", "Vd", "Ve", "Vd^2", "Vd Ve", "Ve^2")
"""Monomials of the crosstalk level V_delta and the channel-imbalance level V_eps the coefficients multiply."""
CONSTANT, CROSSTALK, IMBALANCE, CROSSTALK2, MIXED, IMBALANCE2 = range(6)


@dataclass(frozen=True)
class ConditionalPolynomials:
    """Coefficients at fixed angles, node axis G after the scene's leading axes.

    mean : (..., G, 6, 3, 3) complex, of E[A C A^H] (co-pol eq. 3.2). cov : (..., G, 6, 3, 3) real, of
    Cov(q_p, q_q) (co-pol eq. 3.3; the constant coefficient is 0). Monomials as ``MONOMIALS``.
    """

    mean: np.ndarray
    cov: np.ndarray


def unit_covariances(system) -> np.ndarray:
    """Gamma_delta and Gamma_eps (2, 6, 6): the covariance of xi (order ``ERROR_TERMS``) at unit levels.

    From ``SystemErrorModel.unit_structure``: variances V_i, C_13 = <d1 d3*>, C_24 = <d2 d4*> (eq. 7) and
    V_eps_i, C_eps12 = <eps1 eps2*> (eq. 8); no other pair is correlated (Men et al. 2021, Section III).
    """
    v, c13, c24, ve, ce12 = system.unit_structure
    g = np.zeros((2, 6, 6), dtype=complex)
    d1, d2, e1, d3, d4, e2 = range(6)
    g[0, d1, d1], g[0, d2, d2], g[0, d3, d3], g[0, d4, d4] = v[0], v[1], v[2], v[3]
    g[0, d1, d3], g[0, d3, d1] = c13, np.conj(c13)
    g[0, d2, d4], g[0, d4, d2] = c24, np.conj(c24)
    g[1, e1, e1], g[1, e2, e2] = ve[0], ve[1]
    g[1, e1, e2], g[1, e2, e1] = ce12, np.conj(ce12)
    return g


def conditional_polynomials(exp: Expansion, scene, gammas: np.ndarray) -> ConditionalPolynomials:
    """Co-pol eqs. (3.2)-(3.3) at every node of ``exp``, for scene covariance ``scene`` (..., 3, 3) and unit
    error covariances ``gammas`` (2, 6, 6) [crosstalk, imbalance]."""
    c = np.asarray(scene, dtype=complex)[..., None, :, :]  # node axis before the matrix
    g = np.asarray(gammas, dtype=complex)
    a0, u, w = exp.a0, exp.u, exp.w
    uc, wc = u @ c[..., None, :, :], w @ c[..., None, None, :, :]  # u_i C, w_ij C
    a0c = a0 @ c
    ub, wb = u.conj(), w.conj()
    mean = np.zeros(np.broadcast_shapes(c.shape[:-2], a0.shape[:-2]) + (6, 3, 3), dtype=complex)
    mean[..., CONSTANT, :, :] = a0c @ np.swapaxes(a0.conj(), -1, -2)
    mean[..., CROSSTALK:IMBALANCE + 1, :, :] = np.einsum("aij,...ipd,...jqd->...apq", g, uc, ub, optimize=True)
    g_rr, g_tt, g_rt, g_tr = g[:, RECEIVE, RECEIVE], g[:, TRANSMIT, TRANSMIT], g[:, RECEIVE, TRANSMIT], g[:, TRANSMIT, RECEIVE]
    quad = (np.einsum("aik,bjl,...ijpd,...klqd->...abpq", g_rr, g_tt, wc, wb, optimize=True)
            + np.einsum("ail,bjk,...ijpd,...klqd->...abpq", g_rt, g_tr, wc, wb, optimize=True))
    mean[..., CROSSTALK2:, :, :] = _symmetric_pairs(quad)

    alpha = np.einsum("...pd,...ipd->...ip", a0c, ub)  # a0_p C u_ip^H (co-pol eq. 3.4)
    beta = np.einsum("...ipd,...jpd->...pij", uc, ub)  # u_ip C u_jp^H
    gamma = np.einsum("...pd,...ijpd->...pij", a0c, wb)  # a0_p C w_ijp^H
    tau = np.einsum("...mqd,...klqd->...qmkl", uc, wb)  # u_mq C w_klq^H
    cov = np.zeros(mean.shape)
    t1 = np.einsum("...ip,aij,...jq->...apq", alpha.conj(), g, alpha, optimize=True)
    cov[..., CROSSTALK:IMBALANCE + 1, :, :] = 2 * t1.real
    q2 = np.einsum("...pij,...qkl,ail,bkj->...abpq", beta, beta, g, g, optimize=True).real
    p2 = 2 * (np.einsum("...pij,...qkl,aki,blj->...abpq", gamma, gamma.conj(), g_rr, g_tt, optimize=True)
              + np.einsum("...pij,...qkl,akj,bli->...abpq", gamma, gamma.conj(), g_rt, g_tr, optimize=True)).real
    g_xr, g_xt = g[:, :, RECEIVE], g[:, :, TRANSMIT]
    t13 = 2 * (np.einsum("...np,...qmkl,ank,bml->...abpq", alpha.conj(), tau, g_xr, g_xt, optimize=True)
               + np.einsum("...np,...qmkl,anl,bmk->...abpq", alpha.conj(), tau, g_xt, g_xr, optimize=True)).real
    t13 = t13 + np.swapaxes(t13, -1, -2)  # Cov(T1_p, T3_q) + Cov(T3_p, T1_q)
    cov[..., CROSSTALK2:, :, :] = _symmetric_pairs(q2 + p2 + t13)
    return ConditionalPolynomials(mean, cov)


def _symmetric_pairs(x: np.ndarray) -> np.ndarray:
    """(..., 2, 2, 3, 3) bilinear coefficients [a, b] -> (..., 3, 3, 3) for V_d^2, V_d V_e, V_e^2."""
    return np.stack([x[..., 0, 0, :, :], x[..., 0, 1, :, :] + x[..., 1, 0, :, :], x[..., 1, 1, :, :]], axis=-3)


def monomials(crosstalk, imbalance) -> np.ndarray:
    """The values of ``MONOMIALS`` for levels V_delta, V_eps (broadcast), shape (..., 6)."""
    vd, ve = np.broadcast_arrays(np.asarray(crosstalk, float), np.asarray(imbalance, float))
    return np.stack([np.ones_like(vd), vd, ve, vd * vd, vd * ve, ve * ve], -1)
