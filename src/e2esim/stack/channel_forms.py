"""Moments of the HH, HV and VV quadratic forms of the passes together, under per-pass system errors.

The multi-channel generalisation of ``e2esim.stack.quadratic_form`` (HV, one variance) to the three channels and
to the covariance between two quadratic forms (ground-cancellation.md, Section 3.2). Pass n's estimates of
(S_hh, S_hv, S_vv) are A_n s_n, with A_n the exact polynomial of issue 12 (co-pol eq. 2.3,
``e2esim.distortion.expansion``) at that pass's Faraday rotation Omega_n and, when the co-polarised channels are
corrected pass by pass before the passes are combined, at its estimate:

    A_n = a0_n + sum_i xi_n,i u_n,i + sum_(i in r, j in t) xi_n,i xi_n,3+j w_n,ij                    (eq. 20)

(xi_n = (delta1, delta2, eps1 | delta3, delta4, eps2) of pass n, E[xi_m xi_n^H] = r_mn Gamma, eq. 8 with
Gamma = V_delta Gamma_delta + V_eps Gamma_eps, ``channel_moments.unit_covariances``). The combined estimate of
channel p (eq. 5) averaged over speckle is the quadratic form q_p = alpha_p M alpha_p^H with
alpha_p = (row p of A_1, ..., row p of A_N) and M_nm = Q_mn E[eta_n eta_m] C_nm (eq. 9). Isserlis' theorem for
circular Gaussian xi gives, at every Faraday-rotation node:

* the passes' signal covariances exactly (eq. 21),
      Y_nm = E[A_n C_nm A_m^H] = a0_n C_nm a0_m^H + r_mn sum_ij Gamma_ij u_n,i C_nm u_m,j^H
             + r_mn^2 sum (Gamma_ik Gamma_3+j,3+l + Gamma_i,3+l Gamma_3+j,k) w_n,ij C_nm w_m,kl^H,
  and from them the mean of the combined covariance sum_nm Q_mn E[eta_n eta_m] Y_nm (its diagonal E q_p);
* the covariance of two channels' forms to O(V^2), as co-pol eq. (3.3) with pass-stacked indices (eq. 22):
      Cov(q_p, q_q) = 2 Re(G_p^H Gamma_big G_q) + tr(beta_p Gamma_big^T beta_q Gamma_big^T)
                      + Cov(2 Re P_p, 2 Re P_q) + Cov(T1_p, T3_q) + Cov(T3_p, T1_q),
  Gamma_big = r kron Gamma, G_p[(m, i)] = R0_p,m u_m,i,p^H, beta_p[(n, i), (m, j)] = u_n,i,p M_nm u_m,j,p^H,
  R0_p,m = sum_n a0_n,p M_nm; P_p = sum_m xi*_m,i xi*_m,3+j gamma_p[m, i, j], gamma_p[m, i, j] = R0_p,m w_m,ij,p^H;
  T3_q = 2 Re sum l_n,q M_nm h_m,q^H;
* for the population reference, the first-order E tr(Q dY^pp Q dY^pp) of the speckle of a combination of
  rank > 1 (eq. 16 for every channel; eq. 23).

Every term is a polynomial of degree <= 2 in (V_delta, V_eps): the kernel returns the coefficients of
``MONOMIALS`` at every node. For HV the rows are those of ``quadratic_form`` (the symmetrised HV row does not
depend on the correction), so the HV entries equal that kernel's to rounding (tested to 1e-12).
"""

from __future__ import annotations

import numpy as np

from e2esim.distortion.expansion import RECEIVE, TRANSMIT, expansion

MONOMIALS = ("1", "d", "e", "dd", "de", "ee")
"""Monomials of the levels (V_delta, V_epsilon), as ``quadratic_form.MONOMIALS``."""
_LIN, _QUAD = slice(1, 3), slice(3, 6)
_SELECT_T = np.eye(6)[:, 3:]  # [e, j] = 1 where e = 3 + j (the transmit term of a pair)
_SELECT_R = np.eye(6)[:, :3]  # [e, i] = 1 where e = i (the receive term)


def pair_structures(gammas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Xi, Xi') (2, 2, 9, 9): for the level pairs (a, b), Xi_ab[(ij), (kl)] = Gamma_a[i, k] Gamma_b[3+j, 3+l]
    + Gamma_a[i, 3+l] Gamma_b[3+j, k] (E[r_i t_j r_k* t_l*], eq. 21) and Xi'_ab[(ij), (kl)] = Gamma_a[k, i]
    Gamma_b[3+l, 3+j] + Gamma_a[k, 3+j] Gamma_b[3+l, i] (E[r_i* t_j* r_k t_l], co-pol eq. 3.5c)."""
    g_rr, g_tt = gammas[:, RECEIVE, RECEIVE], gammas[:, TRANSMIT, TRANSMIT]
    g_rt, g_tr = gammas[:, RECEIVE, TRANSMIT], gammas[:, TRANSMIT, RECEIVE]
    xi = (np.einsum("aik,bjl->abijkl", g_rr, g_tt) + np.einsum("ail,bjk->abijkl", g_rt, g_tr)).reshape(2, 2, 9, 9)
    xi_c = (np.einsum("aki,blj->abijkl", g_rr, g_tt) + np.einsum("akj,bli->abijkl", g_rt, g_tr)).reshape(2, 2, 9, 9)
    return xi, xi_c


def _symmetric_pairs(x: np.ndarray) -> np.ndarray:
    """(2, 2, ...) coefficients of V_a V_b -> (3, ...) of V_d^2, V_d V_e, V_e^2."""
    return np.stack([x[0, 0], x[0, 1] + x[1, 0], x[1, 1]])


def channel_node_polynomials(blocks: np.ndarray, q: np.ndarray, omega: np.ndarray, omega_hat: np.ndarray | None,
                             r: np.ndarray, gammas: np.ndarray, gain_pair: np.ndarray | None = None,
                             population_cross: bool = False) -> dict:
    """Coefficients of eqs. (21)-(23) at each Faraday-rotation node.

    blocks : C_nm (N, N, 3, 3). q : Q (N x N). omega : Faraday rotation of each pass at each node (G, N).
    omega_hat : the rotation each pass's co-polarised channels are corrected with (G, N), or None (no
    correction). r : pass correlation r_mn (N x N). gammas : unit error covariances (2, 6, 6) in the order of
    ``expansion.ERROR_TERMS``. gain_pair : E[eta_n eta_m] (N x N) or None for 1. population_cross : also return
    ``csys``.

    Returns complex ``y0`` (6, G, N, N, 3, 3) (coefficients of Y_nm, no gain factors) and ``mean`` (6, G, 3, 3)
    (of sum_nm Q_mn E[eta_n eta_m] Y_nm); real ``cov`` (6, G, 3, 3) (Cov(q_p, q_q), constant coefficient 0),
    ``trq2y`` (6, G, 3) (of tr(Q^2 Y^pp) with the gain factors) and ``csys`` (6, G, 3) (zeros unless asked).
    """
    n = q.shape[0]
    g = omega.shape[0]
    pair = np.ones((n, n)) if gain_pair is None else np.asarray(gain_pair, float)
    c = np.asarray(blocks, complex)
    exp = expansion(omega, omega_hat)
    a0, u = exp.a0, exp.u  # (G, N, p, c), (G, N, 6, p, c)
    w = exp.w.reshape(g, n, 9, 3, 3)  # (G, N, (ij), p, c)
    gm = np.asarray(gammas, complex)
    xi, xi_c = pair_structures(gm)

    # eq. (21): Y_nm per monomial
    y0 = np.zeros((6, g, n, n, 3, 3), complex)
    a0c = np.einsum("gnpc,nmcd->gnmpd", a0, c)
    y0[0] = np.einsum("gnmpd,gmqd->gnmpq", a0c, a0.conj())
    uc = np.einsum("gnipc,nmcd->gnmipd", u, c)
    ug = np.einsum("aij,gmjqd->agmiqd", gm, u.conj())  # sum_j Gamma_a[i, j] u_m,j^*
    y0[_LIN] = r[None, None, :, :, None, None] * np.einsum("gnmipd,agmiqd->agnmpq", uc, ug)
    wc = np.einsum("gnxpc,nmcd->gnmxpd", w, c)
    wg = np.einsum("abxy,gmyqd->abgmxqd", xi, w.conj())
    quad = np.einsum("gnmxpd,abgmxqd->abgnmpq", wc, wg)
    y0[_QUAD] = (r**2)[None, None, :, :, None, None] * _symmetric_pairs(quad)
    weight = q.T * pair  # Q_mn E[eta_n eta_m] at [n, m]
    mean = np.einsum("nm,kgnmpq->kgpq", weight, y0)
    trq2y = np.real(np.einsum("nm,kgnmpp->kgp", (q @ q).T * pair, y0))

    # eq. (22): Cov(q_p, q_q)
    mm = weight[:, :, None, None] * c  # M_nm
    r0 = np.einsum("gnpc,nmcd->gmpd", a0, mm)  # R0_p,m
    gvec = np.einsum("gmpd,gmipd->gmip", r0, u.conj()).reshape(g, 6 * n, 3)  # G_p[(m, i)]
    big = np.stack([np.kron(r, gm[0]), np.kron(r, gm[1])])  # Gamma_big per component (2, 6N, 6N)
    cov = np.zeros((6, g, 3, 3))
    cov[_LIN] = 2 * np.real(np.einsum("gxp,axy,gyq->agpq", gvec.conj(), big, gvec))
    um = np.einsum("gnipc,nmcd->gnmipd", u, mm)
    beta = np.einsum("gnmipd,gmjpd->gpnimj", um, u.conj()).reshape(g, 3, 6 * n, 6 * n)
    x = beta[:, None] @ np.swapaxes(big, -1, -2)[None, :, None]  # beta_p Gamma_a^T, (G, 2, 3, 6N, 6N)
    flat = x.reshape(g, 6, -1)
    q2 = np.real(flat @ np.swapaxes(np.swapaxes(x, -1, -2).reshape(g, 6, -1), -1, -2))  # tr(X_pa X_qb)
    q2 = q2.reshape(g, 2, 3, 2, 3).transpose(1, 3, 0, 2, 4)  # (a, b, G, p, q)
    gam = np.einsum("gmpd,gmxpd->gmxp", r0, w.conj()).reshape(g, 9 * n, 3)  # gamma_p[(m, ij)]
    xbig = np.einsum("mk,abxy->abmxky", r**2, xi_c).reshape(2, 2, 9 * n, 9 * n)
    p2 = 2 * np.real(np.einsum("gxp,abxy,gyq->abgpq", gam, xbig, gam.conj()))
    tau = np.einsum("gnmaqd,gmxqd->gqnamx", um, w.conj())  # u_n,a,q M_nm w_m,x,q^H
    hvec = np.einsum("gkcp,km,ace->agmep", gvec.reshape(g, n, 6, 3).conj(), r, gm)
    kvec = np.einsum("gqnamx,nm,bae->bgqmex", tau, r, gm).reshape(2, g, 3, n, 6, 3, 3)
    # Cov(T1_p, T3_q): sum conj(G_p[k, c]) tau_q[n, a; m, i, j] (r_km Gamma_c,i r_nm Gamma_a,3+j + r_km Gamma_c,3+j
    # r_nm Gamma_a,i), as H_p[m, e] = sum_kc conj(G_p[k, c]) r_km Gamma[c, e] and K_q[m, e, ij] = sum_na tau r_nm
    # Gamma[a, e] (co-pol eq. 3.5d with the passes)
    t13 = 2 * np.real(np.einsum("agmip,bgqmeij,ej->abgpq", hvec[:, :, :, :3], kvec, _SELECT_T)
                      + np.einsum("agmjp,bgqmeij,ei->abgpq", hvec[:, :, :, 3:], kvec, _SELECT_R))
    t13 = t13 + np.swapaxes(t13, -1, -2)
    cov[_QUAD] = _symmetric_pairs(q2 + p2 + t13)

    csys = np.zeros((6, g, 3))
    if population_cross:  # eq. (23): sum_abcd Q_ab Q_cd (x_bc^T P_ba y_da + x_da^T P_dc y_bc) per channel
        plin = np.einsum("ba,gbepi,cef,gafpj->cgbapij", r, u, gm, u.conj())  # E[l_b,p,i l_a,p,j*]
        xv = np.einsum("bcik,gcpk->gbcpi", c, a0.conj())  # C_bc a0_c,p^H
        yv = np.einsum("gdpk,dakj->gdapj", a0, c)  # a0_d,p C_da
        csys[_LIN] = np.real(np.einsum("ab,cd,gbcpi,kgbapij,gdapj->kgp", q, q, xv, plin, yv, optimize=True)
                             + np.einsum("ab,cd,gdapi,kgdcpij,gbcpj->kgp", q, q, xv, plin, yv, optimize=True))
    return {"y0": y0, "mean": mean, "cov": cov, "trq2y": trq2y, "csys": csys}
