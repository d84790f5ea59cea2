"""Moments of a Hermitian quadratic form of the passes' HV estimates under per-pass system errors.

A general kernel (ground-cancellation.md, Section 3): the estimator y^H Q y of ``e2esim.stack.combination``
averaged over speckle is, given the system errors of every pass,

    q = alpha M alpha^H,   alpha = (a_1, ..., a_N),   M_nm = Q_mn C_nm                       (eq. 9)

with a_n the effective weights of pass n (S_hv_hat,n = a_n . s_n; ``effective_weights``) and C_nm the blocks
of the stack covariance. a_n is exactly quadratic in xi_n = (delta_1..delta_4, epsilon_1, epsilon_2) of pass n
(``e2esim.distortion.second_order``): a_n = e + l_n + h_n, e = (0, 1, 0),

    l_n = T1(Omega_n) (S13, S24, A, (eps2 - eps1)/2)^T,   h_n = T2(Omega_n) (U, W, D)^T            (eqs. 10-11)

(Men et al. 2021, eqs. 3-4; U, W, D of second_order). With xi circular Gaussian and
E[xi_m xi_n^H] = r_mn Sigma_1 (``e2esim.stack.system``), Isserlis' theorem gives, to the order of the
``complete`` single-pass form (mean to O(V^2), variance to O(V^2)):

    E q   = e M e + sum(M o P) + sum(M o P_h)                                                    (eq. 12)
    Var q = 2 v^T P v* + sum((M P^T) o (P M*)) + 2 v^T P_h v* + 2 E[q1 q3],   v = M e            (eq. 13)

with P = E[l^T l*] (blocks r_mn T1_m Phi T1_n^H), P_h = E[h^T h*] (blocks r_mn^2 T2_m Pi T2_n^H) and the cubic
term E[q1 q3] = 4 Re sum_n sum_j sum_k conj(T2_n,jk) beta_n M_k gamma_nj (eq. 14). Every term is a polynomial
of degree <= 2 in the crosstalk and channel-imbalance levels (Sigma_1 = V_d Sigma_d + V_e Sigma_e), so the
kernel returns the coefficients of the monomials (1, V_d, V_e, V_d^2, V_d V_e, V_e^2) at every Faraday-rotation
node, and levels are applied by the caller in one vectorised step. With identical errors on every pass
(r = 1, equal Omega_n) alpha = (a, ..., a) and the kernel equals the single-pass moments of Men et al. (2021) for
the combined covariance sum_mn Q_mn C_nm (tested to 1e-12).
"""

from __future__ import annotations

import numpy as np

MONOMIALS = ("1", "d", "e", "dd", "de", "ee")
"""Monomials of the levels (V_delta, V_epsilon) the coefficients multiply, in this order."""

_HV = 1

# v = (S13, S24, A, (eps2 - eps1)/2) = B xi
_B = np.array([[0.5, 0, 0.5, 0, 0, 0], [0, 0.5, 0, 0.5, 0, 0], [0, 0, 0, 0, 0.5, 0.5], [0, 0, 0, 0, -0.5, 0.5]])


def _sym(pairs) -> np.ndarray:
    m = np.zeros((6, 6))
    for (i, j), value in pairs.items():
        m[i, j] = m[j, i] = value / 2.0
    return m


# U = d1 d4 - d2 d3, W = d1 d4 + d2 d3, D = d2 eps2 + d4 eps1 as xi^T M xi with symmetric M
_PRODUCTS = np.stack([_sym({(0, 3): 1.0, (1, 2): -1.0}), _sym({(0, 3): 1.0, (1, 2): 1.0}),
                      _sym({(1, 5): 1.0, (3, 4): 1.0})])


def trig_matrices(omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(T1 (..., 3, 4), T2 (..., 3, 3)) of eqs. (10)-(11) at Faraday rotations ``omega`` (rad)."""
    c, s = np.cos(omega), np.sin(omega)
    c2, s2, cs = c * c, s * s, c * s
    z = np.zeros_like(c)
    one = np.ones_like(c)
    t1 = np.stack([np.stack([c2, -s2, z, cs], -1), np.stack([z, z, one, z], -1), np.stack([-s2, c2, z, cs], -1)], -2)
    t2 = np.stack([np.stack([cs / 2, z, -s2 / 2], -1), np.stack([z, one / 2, z], -1),
                   np.stack([cs / 2, z, c2 / 2], -1)], -2)
    return t1, t2


def product_covariance(sa: np.ndarray, sb: np.ndarray) -> np.ndarray:
    """Pi_ab[k, k'] = 2 sum(M_k o (Sigma_a M_k' Sigma_b^T)) (M real symmetric): the part of E[p_k p_k'*] bilinear
    in (Sigma_a, Sigma_b), p = (U, W, D)."""
    inner = np.einsum("ac,kcd,bd->kab", sa, _PRODUCTS, sb)
    return 2.0 * np.einsum("kab,lab->kl", _PRODUCTS, inner)


def node_polynomials(blocks: np.ndarray, q: np.ndarray, omega: np.ndarray, r: np.ndarray, sigmas: tuple,
                     gain_pair: np.ndarray | None = None, population_cross: bool = False) -> dict:
    """Coefficients of eqs. (12)-(14) at each Faraday-rotation node.

    blocks : C_nm, shape (N, N, 3, 3). q : Q (N x N). omega : Faraday rotation of each pass at each node (G, N).
    r : pass correlation r_mn (N x N). sigmas : (Sigma_delta, Sigma_epsilon) unit 6 x 6 covariances.
    gain_pair : E[eta_n eta_m] of the passes' own gain factors (N x N), or None for 1.
    population_cross : also return ``csys`` (6, G): the first-order E tr(Q dY Q dY) of the finite-look speckle
        term of a combination of rank > 1 (ground-cancellation.md, eq. 16).

    Returns ``mean`` (6, G) and ``var`` (6, G) real coefficients of ``MONOMIALS`` (the mean includes e M e),
    and ``y0`` (6, G, N, N): the coefficients of E[a_n C_nm a_m^H] (the passes' signal covariance without the
    gain factors), from which the caller forms kappa_nm = Q_mn y0_nm and the finite-look terms.
    """
    n = q.shape[0]
    g = omega.shape[0]
    mm = q.T[:, :, None, None] * blocks  # M_nm = Q_mn C_nm, (N, N, 3, 3)
    if gain_pair is not None:
        mm = mm * gain_pair[:, :, None, None]
    mflat = mm.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)
    v = mflat[:, _HV::3].sum(axis=1)  # M e^H
    t1, t2 = trig_matrices(omega)  # (G, N, 3, 4), (G, N, 3, 3)
    sd, se = sigmas
    comps = {"d": sd, "e": se}

    def flat(p):  # (G, N, 3, N, 3) -> (G, 3N, 3N)
        return p.reshape(g, 3 * n, 3 * n)

    p_lin, t1psi, csys = {}, {}, np.zeros((6, g))
    cx, cy = blocks[:, :, :, _HV], blocks[:, :, _HV, :]  # C_nm e^H and e C_nm
    for a, sa in comps.items():
        phi = _B @ sa @ _B.T
        p5 = r[None, :, None, :, None] * np.einsum("gmix,xy,gnjy->gminj", t1, phi, t1.conj())
        p_lin[a] = flat(p5)
        if population_cross:  # sum_abcd Q_ab Q_cd (x_bc^T P_ba y_da + x_da^T P_dc y_bc)
            csys[MONOMIALS.index(a)] = np.real(np.einsum("ab,cd,bci,gbiaj,daj->g", q, q, cx, p5, cy)
                                               + np.einsum("ab,cd,dai,gdicj,bcj->g", q, q, cx, p5, cy))
        t1psi[a] = np.einsum("gmix,xc->gmic", t1, _B @ sa)  # K blocks without r: T1_m Psi_a, (G, N, 3, 6)
    p_quad = {}
    for a, b in (("d", "d"), ("d", "e"), ("e", "d"), ("e", "e")):
        pi = product_covariance(comps[a], comps[b])
        p_quad[a + b] = flat((r**2)[None, :, None, :, None] * np.einsum("gmik,kl,gnjl->gminj", t2, pi, t2.conj()))

    mean = np.zeros((6, g))
    var = np.zeros((6, g))
    mean[0] = np.real(v[_HV::3].sum())  # e M e
    for a in ("d", "e"):
        k = MONOMIALS.index(a)
        mean[k] = np.real(np.einsum("ij,gij->g", mflat, p_lin[a]))
        var[k] = 2 * np.real(np.einsum("i,gij,j->g", v, p_lin[a], v.conj()))
    mp = {a: np.einsum("ij,gkj->gik", mflat, p_lin[a]) for a in ("d", "e")}  # M P^T
    pm = {a: p_lin[a] @ mflat.conj() for a in ("d", "e")}  # P M*
    # E[q1 q3] ingredients: beta_n = sum_m r_mn v_m^T T1_m Psi, gamma_nj = sum_m r_mn sum_i M_mn[i, j] (T1_m Psi)_i
    vb = v.reshape(n, 3)
    m4 = mm.transpose(0, 2, 1, 3)  # [m, i, n, j]
    beta = {a: np.einsum("mn,mi,gmic->gnc", r, vb, t1psi[a]) for a in ("d", "e")}
    gamma = {a: np.einsum("mn,minj,gmic->gnjc", r, m4, t1psi[a]) for a in ("d", "e")}
    for a, b, mono in (("d", "d", "dd"), ("d", "e", "de"), ("e", "d", "de"), ("e", "e", "ee")):
        k = MONOMIALS.index(mono)
        ab = a + b
        mean[k] += np.real(np.einsum("ij,gij->g", mflat, p_quad[ab]))
        var[k] += np.real(np.einsum("gik,gik->g", mp[a], pm[b]))  # sum((M P_a^T) o (P_b M*))
        var[k] += 2 * np.real(np.einsum("i,gij,j->g", v, p_quad[ab], v.conj()))
        bm = np.einsum("gnc,kcd->gnkd", beta[a], _PRODUCTS)
        x = np.einsum("gnkd,gnjd->gnjk", bm, gamma[b])
        var[k] += 2 * 4 * np.real(np.einsum("gnjk,gnjk->g", t2.conj(), x))  # 2 E[q1 q3]
    # signal covariance of the passes: y0_nm = C_nm[hv, hv] + sum(C_nm o P_nm) + sum(C_nm o Ph_nm)
    cflat = blocks.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)
    y0 = np.zeros((6, g, n, n), complex)
    y0[0] = blocks[:, :, _HV, _HV][None]
    for a in ("d", "e"):
        y0[MONOMIALS.index(a)] = _block_sums(cflat * p_lin[a], n)
    for ab, mono in (("dd", "dd"), ("de", "de"), ("ed", "de"), ("ee", "ee")):
        y0[MONOMIALS.index(mono)] += _block_sums(cflat * p_quad[ab], n)
    return {"mean": mean, "var": var, "y0": y0, "csys": csys}


def _block_sums(x: np.ndarray, n: int) -> np.ndarray:
    """(G, 3N, 3N) -> (G, N, N): the sum of every 3 x 3 block."""
    return x.reshape(x.shape[0], n, 3, n, 3).sum(axis=(2, 4))


def monomials(v_delta, v_eps) -> np.ndarray:
    """Values of ``MONOMIALS`` at levels (any broadcast shape S): shape (6,) + S."""
    d, e = np.broadcast_arrays(np.asarray(v_delta, float), np.asarray(v_eps, float))
    return np.stack([np.ones_like(d), d, e, d * d, d * e, e * e])
