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
    error covariances ``gammas`` (2, 6, 6) [crosstalk, imbalance]. Written as two-operand contractions and
    matrix products (a multi-operand einsum costs far more here)."""
    c = np.asarray(scene, dtype=complex)[..., None, :, :]  # node axis before the matrix
    g = np.asarray(gammas, dtype=complex)
    a0, u, w = exp.a0, exp.u, exp.w
    shape = np.broadcast_shapes(c.shape[:-2], a0.shape[:-2])
    uc = u @ c[..., None, :, :]  # u_i C: (..., 6, p, d)
    wc = w @ c[..., None, None, :, :]  # w_ij C: (..., 3, 3, p, d)
    a0c = a0 @ c
    ub, wb = np.broadcast_to(u.conj(), uc.shape), np.broadcast_to(w.conj(), wc.shape)
    n_e = u.shape[-3]
    # products over the scene index d, as matrices: (..., i p, d) @ (..., d, j q)
    beta = (uc.reshape(shape + (n_e * 3, 3)) @ _herm(ub.reshape(shape + (n_e * 3, 3)))).reshape(
        shape + (n_e, 3, n_e, 3))  # u_ip C u_jq^H [i, p, j, q]
    omega = (wc.reshape(shape + (27, 3)) @ _herm(wb.reshape(shape + (27, 3)))).reshape(
        shape + (3, 3, 3, 3, 3, 3))  # w_ijp C w_klq^H [i, j, p, k, l, q]
    mean = np.empty(shape + (6, 3, 3), dtype=complex)
    mean[..., CONSTANT, :, :] = a0c @ _herm(np.broadcast_to(a0, a0c.shape))
    mean[..., CROSSTALK:IMBALANCE + 1, :, :] = np.moveaxis(np.tensordot(beta, g, axes=([-4, -2], [1, 2])), -1, -3)
    g_rr, g_tt, g_rt, g_tr = (
        g[:, RECEIVE, RECEIVE],
        g[:, TRANSMIT, TRANSMIT],
        g[:, RECEIVE, TRANSMIT],
        g[:, TRANSMIT, RECEIVE],
    )
    # omega axes [..., i, j, p, k, l, q]; contract the transmit pair, then the receive pair -> [..., p, q, b, a]
    quad = np.tensordot(np.tensordot(omega, g_tt, axes=([-5, -2], [1, 2])), g_rr, axes=([-5, -3], [1, 2]))
    quad = quad + np.tensordot(np.tensordot(omega, g_tr, axes=([-5, -3], [1, 2])), g_rt, axes=([-5, -3], [1, 2]))
    mean[..., CROSSTALK2:, :, :] = _symmetric_pairs(np.moveaxis(quad, (-1, -2), (-4, -3)))

    idx = np.arange(3)
    alpha = (ub * a0c[..., None, :, :]).sum(-1)  # a0_p C u_ip^H [i, p] (co-pol eq. 3.4)
    beta_pp = np.moveaxis(beta[..., :, idx, :, idx], 0, -3)  # u_ip C u_jp^H [p, i, j]
    gamma = np.moveaxis((wb * a0c[..., None, None, :, :]).sum(-1), -1, -3)  # a0_p C w_ijp^H [p, i, j]
    tau = (np.moveaxis(uc, -3, -2) @ np.moveaxis(wb, (-4, -3), (-2, -1)).reshape(wb.shape[:-4] + (3, 3, 9))
           ).reshape(uc.shape[:-3] + (3, n_e, 3, 3))  # u_mq C w_klq^H [q, m, k, l]
    cov = np.zeros(mean.shape)
    t1 = np.einsum("...ip,aij->...apj", alpha.conj(), g) @ alpha[..., None, :, :]  # alpha_p^H Gamma alpha_q
    cov[..., CROSSTALK:IMBALANCE + 1, :, :] = 2 * t1.real
    # Cov(Q_p, Q_q) = tr(beta_p Gamma_a^T beta_q Gamma_b^T) for the pairs of level structures (a, b)
    x = beta_pp[..., None, :, :, :] @ np.swapaxes(g, -1, -2)[:, None, :, :]  # (..., a, p, i, j)
    flat = x.reshape(x.shape[:-4] + (6, n_e * n_e))
    q2 = (flat @ np.swapaxes(np.swapaxes(x, -1, -2).reshape(flat.shape), -1, -2)).real  # tr(X_pa X_qb)
    q2 = np.swapaxes(q2.reshape(q2.shape[:-2] + (2, 3, 2, 3)), -3, -2)
    p2 = 2 * _p2(gamma, gamma.conj(), g_rr, g_tt, g_rt, g_tr).real
    g_xr, g_xt = g[:, :, RECEIVE], g[:, :, TRANSMIT]
    va = np.moveaxis(np.tensordot(alpha.conj(), g_xr, axes=([-2], [1])), -2, -3)  # sum_n conj(alpha_np) Gamma_a[n, k]
    vt = np.moveaxis(np.tensordot(alpha.conj(), g_xt, axes=([-2], [1])), -2, -3)  # ... Gamma_a[n, 3 + l]
    tb_t = np.moveaxis(np.tensordot(tau, g_xt, axes=([-3, -1], [1, 2])), -1, -3)  # sum_ml tau_q[m,k,l] Gamma_b[m,3+l]
    tb_r = np.moveaxis(np.tensordot(tau, g_xr, axes=([-3, -2], [1, 2])), -1, -3)  # sum_mk tau_q[m,k,l] Gamma_b[m,k]
    t13 = 2 * (np.einsum("...apk,...bqk->...abpq", va, tb_t) + np.einsum("...apl,...bql->...abpq", vt, tb_r)).real
    t13 = t13 + np.swapaxes(t13, -1, -2)  # Cov(T1_p, T3_q) + Cov(T3_p, T1_q)
    cov[..., CROSSTALK2:, :, :] = _symmetric_pairs(q2 + p2 + t13)
    return ConditionalPolynomials(mean, cov)


def _p2(gamma, gb, g_rr, g_tt, g_rt, g_tr):
    """Cov(2 Re P_p, 2 Re P_q) / 2 before the real part: sum gamma_p[i,j] conj(gamma_q[k,l]) (Gamma_a[k,i]
    Gamma_b[3+l,3+j] + Gamma_a[k,3+j] Gamma_b[3+l,i]) for the pairs (a, b), shape (..., a, b, p, q)."""
    first = np.tensordot(np.tensordot(gb, g_rr, axes=([-2], [1])), g_tt, axes=([-3], [1]))  # [q, a, i, b, j]
    second = np.tensordot(np.tensordot(gb, g_rt, axes=([-2], [1])), g_tr, axes=([-3], [1]))  # [q, a, j, b, i]
    both = first + np.swapaxes(second, -3, -1)
    both = np.moveaxis(both, (-4, -2, -5), (-5, -4, -3)).reshape(both.shape[:-5] + (2, 2, 3, 9))  # [a, b, q, (i j)]
    flat = gamma.reshape(gamma.shape[:-2] + (9,))[..., None, None, :, :]  # [1, 1, p, (i j)]
    return flat @ np.swapaxes(both, -1, -2)


def _herm(x: np.ndarray) -> np.ndarray:
    return np.swapaxes(x.conj(), -1, -2)


def _symmetric_pairs(x: np.ndarray) -> np.ndarray:
    """(..., 2, 2, 3, 3) bilinear coefficients [a, b] -> (..., 3, 3, 3) for V_d^2, V_d V_e, V_e^2."""
    return np.stack([x[..., 0, 0, :, :], x[..., 0, 1, :, :] + x[..., 1, 0, :, :], x[..., 1, 1, :, :]], axis=-3)


def monomials(crosstalk, imbalance) -> np.ndarray:
    """The values of ``MONOMIALS`` for levels V_delta, V_eps (broadcast), shape (..., 6)."""
    vd, ve = np.broadcast_arrays(np.asarray(crosstalk, float), np.asarray(imbalance, float))
    return np.stack([np.ones_like(vd), vd, ve, vd * vd, vd * ve, ve * ve], -1)
