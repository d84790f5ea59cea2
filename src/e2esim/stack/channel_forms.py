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

from e2esim.distortion.expansion import RECEIVE, TRANSMIT, expansion_at

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
                             population_cross: bool = False, mean_only: bool = False, expansions=None) -> dict:
    """Coefficients of eqs. (21)-(23) at each Faraday-rotation node.

    blocks : C_nm (N, N, 3, 3). q : Q (N x N). omega : Faraday rotation of each pass at each node (G, N).
    omega_hat : the rotation each pass's co-polarised channels are corrected with (G, N), or None (no
    correction). r : pass correlation r_mn (N x N). gammas : unit error covariances (2, 6, 6) in the order of
    ``expansion.ERROR_TERMS``. gain_pair : E[eta_n eta_m] (N x N) or None for 1. population_cross : also return
    ``csys``. mean_only : ``cov`` and ``csys`` left zero, for a caller that reads the means alone (the ground an
    estimator leaves, ``StackJointErrorModel.cancellation``); the rest is the same, bit for bit. expansions : the
    ``KernelMemo`` that keeps issue 12's expansion at the nodes (``expansion_at``: the variants of a case share
    their Faraday-rotation nodes), or None.

    Returns complex ``y0`` (6, G, N, N, 3, 3) (coefficients of Y_nm, no gain factors) and ``mean`` (6, G, 3, 3)
    (of sum_nm Q_mn E[eta_n eta_m] Y_nm); real ``cov`` (6, G, 3, 3) (Cov(q_p, q_q), constant coefficient 0),
    ``trq2y`` (6, G, 3) (of tr(Q^2 Y^pp) with the gain factors) and ``csys`` (6, G, 3) (zeros unless asked).

    Every product is a batch of small matrix products (sides of at most 9N), so that a threaded BLAS never
    takes over: on a shared machine its threads cost far more than the work.
    """
    n = q.shape[0]
    g = omega.shape[0]
    pair = np.ones((n, n)) if gain_pair is None else np.asarray(gain_pair, float)
    c = np.asarray(blocks, complex)
    exp = expansion_at(omega, omega_hat, expansions)
    a0, u = exp.a0, exp.u  # (G, N, p, c), (G, N, 6, p, c)
    w = exp.w.reshape(g, n, 9, 3, 3)  # (G, N, (ij), p, c)
    gm = np.asarray(gammas, complex)
    xi, xi_c = pair_structures(gm)
    weight = q.T * pair  # Q_mn E[eta_n eta_m] at [n, m]
    rows = c.transpose(0, 2, 1, 3).reshape(n, 3, 3 * n)  # C_n. as (c, (m, d)) per n
    mflat = (weight[:, :, None, None] * c).transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)  # M[(n, c), (m, d)]

    # eq. (21): Y_nm per monomial
    y0 = np.zeros((6, g, n, n, 3, 3), complex)
    a0c = (a0 @ rows[None]).reshape(g, n, 3, n, 3)  # a0_n C_nm [g, n, p, m, d]
    y0[0] = np.einsum("gnpmd,gmqd->gnmpq", a0c, a0.conj())
    uc = (u.reshape(g, n, 18, 3) @ rows[None]).reshape(g, n, 6, 3, n, 3)  # u_n,i C_nm [g, n, i, p, m, d]
    uc = uc.transpose(0, 4, 1, 3, 2, 5).reshape(g, n, 3 * n, 18)  # [g, m, (n, p), (i, d)]
    ug = (gm[None, None] @ u.conj().reshape(g, n, 1, 6, 9)).reshape(g, n, 2, 6, 3, 3)  # [g, m, a, i, q, d]
    ug = ug.transpose(0, 1, 3, 5, 2, 4).reshape(g, n, 18, 6)  # sum_j Gamma_a[i, j] u_m,j^* per (a, q)
    lin = (uc @ ug).reshape(g, n, n, 3, 2, 3).transpose(4, 0, 2, 1, 3, 5)  # [a, g, n, m, p, q]
    y0[_LIN] = r[None, None, :, :, None, None] * lin
    wc = (w.reshape(g, n, 27, 3) @ rows[None]).reshape(g, n, 9, 3, n, 3)
    wc = wc.transpose(0, 4, 1, 3, 2, 5).reshape(g, n, 3 * n, 27)  # [g, m, (n, p), (x, d)]
    wg = (_symmetric_pairs(xi)[None, None] @ w.conj().reshape(g, n, 1, 9, 9))  # [g, m, k, x, (q, d)]
    wg = wg.reshape(g, n, 3, 9, 3, 3).transpose(0, 1, 3, 5, 2, 4).reshape(g, n, 27, 9)
    quad = (wc @ wg).reshape(g, n, n, 3, 3, 3).transpose(4, 0, 2, 1, 3, 5)  # [k, g, n, m, p, q]
    y0[_QUAD] = (r**2)[None, None, :, :, None, None] * quad
    mean = np.einsum("nm,kgnmpq->kgpq", weight, y0)
    trq2y = np.real(np.einsum("nm,kgnmpp->kgp", (q @ q).T * pair, y0))

    if mean_only:
        return {"y0": y0, "mean": mean, "cov": np.zeros((6, g, 3, 3)), "trq2y": trq2y, "csys": np.zeros((6, g, 3))}

    # eq. (22): Cov(q_p, q_q)
    cov = np.zeros((6, g, 3, 3))
    r0 = (a0.transpose(0, 2, 1, 3).reshape(g, 3, 3 * n) @ mflat).reshape(g, 3, n, 3)  # R0_p,m [g, p, m, d]
    gvec = np.einsum("gpmd,gmipd->gmip", r0, u.conj())  # G_p[(m, i)]
    gg = (r @ (gm[:, None, None] @ gvec[None]).reshape(2, g, n, 18)).reshape(2, g, n, 6, 3)  # Gamma_big G
    cov[_LIN] = 2 * np.real(np.einsum("gmip,agmiq->agpq", gvec.conj(), gg))
    # tr(beta_p Gamma_a^T beta_q Gamma_b^T) = tr(M F_pq^a M F_qp^b), F_pq^a = U_p^H Gamma_big,a^T U_q (3N x 3N)
    # built in the layout [a, g, p, q, (n, c), (m, d)]: U_p^H [g, p, (n, c), i] times Gamma_a^T U_q [a, g, q, i, (m, d)]
    uh = u.conj().transpose(0, 3, 1, 4, 2).reshape(1, g, 3, 1, 3 * n, 6)
    gtu = np.swapaxes(gm, 1, 2)[:, None, None] @ u.transpose(0, 3, 2, 1, 4).reshape(1, g, 3, 6, 3 * n)
    if np.all(r == 1.0):  # stable system errors: the same trace through 6 x 6 products (_stable_trace_pairs)
        q2 = _stable_trace_pairs(uh[0, :, :, 0], gtu, mflat)
    else:
        x = mflat @ ((uh @ gtu[:, :, None]) * np.kron(r, np.ones((3, 3))))  # M F_pq^a
        xt = x.transpose(1, 2, 3, 0, 4, 5).reshape(g, 9, 2, 9 * n * n)  # [g, (p, q), a, (x, y)]
        xs = x.transpose(1, 3, 2, 5, 4, 0).reshape(g, 9, 9 * n * n, 2)  # M F_qp^b at [g, (p, q), (y, x), b]
        q2 = np.real(xt @ xs).reshape(g, 3, 3, 2, 2).transpose(3, 4, 0, 1, 2)
    # Cov(2 Re P_p, 2 Re P_q) (co-pol eq. 3.5c with the passes, r^2 between them)
    gam = (w.conj().transpose(0, 1, 3, 2, 4) @ r0.transpose(0, 2, 1, 3)[..., None])[..., 0]  # [g, m, p, x]
    gam = gam.transpose(0, 1, 3, 2)  # gamma_p[m, (ij)] at [g, m, x, p]
    s = ((r**2) @ gam.conj().reshape(g, n, 27)).reshape(g, n, 9, 3)
    p2 = 2 * np.real(gam.transpose(0, 3, 1, 2).reshape(g, 3, 9 * n) @ (xi_c[:, :, None, None] @ s).reshape(
        2, 2, g, 9 * n, 3))
    # Cov(T1_p, T3_q) + Cov(T3_p, T1_q) (co-pol eq. 3.5d): with H_p[m, e] = sum_kc conj(G_p[k, c]) r_km
    # Gamma_a[c, e] and K_q[m, e, (ij)] = sum_n r_nm (Gamma_b^T u_n)_e,q M_nm w_m,ij,q^H
    hvec = np.einsum("km,agkep->agmep", r, np.einsum("ace,gkcp->agkep", gm, gvec.conj()))
    ut = gtu.transpose(0, 1, 3, 2, 4).reshape(-1, 3 * n)  # (Gamma_a^T u_n)_e,q as [(a, g, e, q), (n, c)]
    ut = (ut @ (np.kron(r, np.ones((3, 3))) * mflat)).reshape(2, g, 6, 3, n, 3)  # one matrix product
    w4 = w.conj().reshape(g, n, 3, 3, 3, 3)  # [g, m, i, j, q, d]
    # only the parts of K read: sum_j K[m, 3 + j, i, j] and sum_i K[m, i, i, j], as [b, g, q, m, e]
    k_te = np.einsum("bgjqmd,gmijqd->bgqmi", ut[:, :, 3:], w4)
    k_re = np.einsum("bgiqmd,gmijqd->bgqmj", ut[:, :, :3], w4)
    kk = np.concatenate([k_te, k_re], -1).reshape(2, g, 3, 6 * n)  # [b, g, q, (m, e)]
    t13 = hvec.transpose(1, 0, 4, 2, 3).reshape(g, 6, 6 * n) @ kk.transpose(1, 3, 0, 2).reshape(g, 6 * n, 6)
    t13 = 2 * np.real(t13).reshape(g, 2, 3, 2, 3).transpose(1, 3, 0, 2, 4)
    t13 = t13 + np.swapaxes(t13, -1, -2)
    cov[_QUAD] = _symmetric_pairs(q2 + p2 + t13)

    csys = np.zeros((6, g, 3))
    if population_cross:  # eq. (23): 2 Re sum_abcd Q_ab Q_cd x_bc^T P_ba y_da per channel (the two terms are equal)
        ub = u.transpose(0, 3, 1, 4, 2).reshape(g, 3, 3 * n, 6)  # [g, p, (b, i), e]
        ua = np.einsum("cef,gafpj->cgpeaj", gm, u.conj()).reshape(2, g, 3, 6, 3 * n)
        plin = (ub[None] @ ua) * np.kron(r, np.ones((3, 3)))  # E[l_b,p,i l_a,p,j^*], [c, g, p, (b, i), (a, j)]
        xv = np.einsum("bcik,gcpk->gpbic", c, a0.conj()).reshape(g, 3, 3 * n, n)  # C_bc a0_c,p^H
        ycd = np.einsum("cd,gdpaj->gpcaj", q, a0c.transpose(0, 1, 2, 3, 4)).reshape(g, 3, n, 3 * n)
        z = xv @ ycd  # sum_c x_bc Q_cd y_da, [g, p, (b, i), (a, j)]
        qb = np.kron(q.T, np.ones((3, 3)))  # Q_ab at [(b, i), (a, j)]
        csys[_LIN] = 2 * np.real(np.einsum("xy,cgpxy,gpxy->cgp", qb, plin, z))
    return {"y0": y0, "mean": mean, "cov": cov, "trq2y": trq2y, "csys": csys}


def _stable_trace_pairs(uh: np.ndarray, gtu: np.ndarray, mflat: np.ndarray) -> np.ndarray:
    """Re tr(M F_pq^a M F_qp^b) (2, 2, G, 3, 3) [a, b, g, p, q] of eq. (22) for r_mn = 1 (stable system errors),
    where F_pq^a = U_p G_q^a (U_p = ``uh`` (G, 3, 3N, 6), G_q^a = ``gtu`` (2, G, 3, 6, 3N)) has rank 6: by the cyclic
    property of the trace it is tr(Z^b_p Z^a_q) with the 6 x 6 Z^a_s = G_s^a M U_s, without the 3N x 3N products
    (equal to them to rounding, tested)."""
    g, side = uh.shape[0], mflat.shape[0]
    z = (gtu.reshape(-1, side) @ mflat).reshape(2, g, 3, 6, side) @ uh[None]  # Z^a_s [a, g, s, e, f]
    left = z.transpose(1, 0, 2, 3, 4).reshape(g, 6, 36)  # Z^b_p [g, (b, p), (e, f)]
    right = z.transpose(1, 0, 2, 4, 3).reshape(g, 6, 36)  # Z^a_q transposed [g, (a, q), (f, e)]
    return np.real(left @ np.swapaxes(right, 1, 2)).reshape(g, 2, 3, 2, 3).transpose(3, 1, 0, 2, 4)
