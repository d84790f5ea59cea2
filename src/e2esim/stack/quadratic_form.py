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


# T1 and T2 are linear in tau = (cos^2, sin^2, cos sin, 1): T = sum_k tau_k A_k
_A1 = np.zeros((4, 3, 4))
_A1[0, 0, 0] = _A1[0, 2, 1] = 1.0  # cos^2
_A1[1, 0, 1] = _A1[1, 2, 0] = -1.0  # sin^2
_A1[2, 0, 3] = _A1[2, 2, 3] = 1.0  # cos sin
_A1[3, 1, 2] = 1.0  # 1
_A2 = np.zeros((4, 3, 3))
_A2[0, 2, 2] = 0.5
_A2[1, 0, 2] = -0.5
_A2[2, 0, 0] = _A2[2, 2, 0] = 0.5
_A2[3, 1, 1] = 0.5


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


def error_structure(sigma_delta: np.ndarray, sigma_eps: np.ndarray) -> dict:
    """What the kernel needs of the unit covariances Sigma_delta, Sigma_epsilon: ``psi`` (2, 4, 6) = E[v xi^H] per
    component (V_d, V_e), v = B xi; ``pairs`` (2, 16, 45), the real and imaginary parts of A1_k Phi_c A1_l^T and
    A2_k Pi_m A2_l^T for every (k, l) (Phi = E[v v^H] per component, Pi = E[p p^H] per monomial dd, de, ee of
    p = (U, W, D)); ``psi_tau`` (2, 4, 36): of A1_k Psi_c."""
    phi = np.stack([_B @ s @ _B.T for s in (sigma_delta, sigma_eps)])
    psi = np.stack([_B @ s for s in (sigma_delta, sigma_eps)])
    pi = np.stack([product_covariance(sigma_delta, sigma_delta),
                   product_covariance(sigma_delta, sigma_eps) + product_covariance(sigma_eps, sigma_delta),
                   product_covariance(sigma_eps, sigma_eps)])
    consts = np.concatenate([np.einsum("kix,cxy,ljy->kcijl", _A1, phi, _A1).reshape(4, 2, 9, 4),
                             np.einsum("kix,cxy,ljy->kcijl", _A2, pi, _A2).reshape(4, 3, 9, 4)], axis=1)
    consts = consts.transpose(0, 3, 1, 2).reshape(16, 45)  # [(k, l), (component, i, j)]
    kconst = np.einsum("kix,cxd->kcid", _A1, psi).reshape(4, 36)
    return {"psi": psi, "pairs": np.ascontiguousarray(np.stack([consts.real, consts.imag])),
            "psi_tau": np.ascontiguousarray(np.stack([kconst.real, kconst.imag]))}


def node_polynomials(blocks: np.ndarray, q: np.ndarray, omega: np.ndarray, r: np.ndarray, structure: tuple,
                     gain_pair: np.ndarray | None = None, population_cross: bool = False,
                     full_signal: bool = False, mean_only: bool = False) -> dict:
    """Coefficients of eqs. (12)-(14) at each Faraday-rotation node.

    blocks : C_nm, shape (N, N, 3, 3). q : Q (N x N). omega : Faraday rotation of each pass at each node (G, N).
    r : pass correlation r_mn (N x N). structure : ``error_structure`` of the unit covariances.
    gain_pair : E[eta_n eta_m] of the passes' own gain factors (N x N), or None for 1.
    population_cross : also return ``csys`` (6, G): the first-order E tr(Q dY Q dY) of the finite-look speckle
        term of a combination of rank > 1 (ground-cancellation.md, eq. 16).

    full_signal : also return ``y0``. mean_only : ``var`` (and ``csys``) left zero: for a caller that reads the
        mean alone (the ground an estimator leaves, ``StackHVErrorModel.cancellation``); the rest is the same, bit for
        bit.

    Returns ``mean`` (6, G) and ``var`` (6, G) real coefficients of ``MONOMIALS`` (the mean includes e M e),
    ``trq2y`` (6, G): those of tr(Q^2 Y) with Y_nm = E[eta_n eta_m] E[a_n C_nm a_m^H] (the finite-look noise
    term), and, on request, ``y0`` (6, G, N, N): the coefficients of E[a_n C_nm a_m^H] (the passes' signal
    covariance without the gain factors), from which the caller forms kappa_nm = Q_mn y0_nm.
    """
    n = q.shape[0]
    g = omega.shape[0]
    pair = np.ones((n, n)) if gain_pair is None else gain_pair
    mm = (q.T * pair)[:, :, None, None] * blocks  # M_nm = Q_mn E[eta_n eta_m] C_nm, (N, N, 3, 3)
    mflat = mm.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)
    m2 = ((q @ q).T * pair)[:, :, None, None] * blocks  # the same for Q^2: tr(Q^2 Y)
    mvecs = np.stack([mflat.ravel(), m2.transpose(0, 2, 1, 3).ravel()])  # (2, 9N^2)
    v = mflat[:, _HV::3].sum(axis=1)  # M e^H
    t1, t2 = trig_matrices(omega)  # (G, N, 3, 4), (G, N, 3, 3)
    r3 = np.kron(r, np.ones((3, 3)))  # r_mn on every entry of block (m, n)
    psi = structure["psi"]
    # P_mn = r T1_m Phi T1_n^H (components V_d, V_e) and P_h,mn = r^2 T2_m Pi T2_n^H (monomials dd, de, ee, with
    # Pi_de + Pi_ed): with T = sum_k tau_k A_k both are tau_k(m) tau_l(n) times constant 3 x 3 matrices, so one
    # pair of real matrix products gives all five (the per-node 3 x 3 products would cost a numpy call each)
    c, s_ = np.cos(omega), np.sin(omega)
    tau = np.stack([c * c, s_ * s_, c * s_, np.ones_like(c)], -1)  # (G, N, 4)
    pairs = (tau[:, :, None, :, None] * tau[:, None, :, None, :]).reshape(g, n * n, 16)
    # batched products: one large matrix product would let a threaded BLAS take over for a few microseconds of work
    re, im = structure["pairs"]
    both = (pairs @ re[None] + 1j * (pairs @ im[None])).reshape(g, n, n, 5, 3, 3)
    re_psi, im_psi = structure["psi_tau"]
    both = both.transpose(3, 0, 1, 4, 2, 5).reshape(5, g, 3 * n, 3 * n)  # [component, g, (m, i), (n, j)]
    p_lin, p_quad = r3 * both[:2], r3**2 * both[2:]
    kmat = (tau @ re_psi[None] + 1j * (tau @ im_psi[None])).reshape(g, n, 2, 3, 6)  # T1_m Psi
    kmat = kmat.transpose(2, 0, 1, 3, 4).reshape(2, g, 3 * n, 6)  # E[l_i xi_c*] without r_mn

    mean, var, trq2y = np.zeros((6, g)), np.zeros((6, g)), np.zeros((6, g))
    lin, quad = slice(1, 3), slice(3, 6)  # rows of MONOMIALS
    mean[0] = np.real(v[_HV::3].sum())  # e M e
    trq2y[0] = np.real(m2[:, :, _HV, _HV].sum())
    both = np.real(np.einsum("cgk,tk->tcg", p_lin.reshape(2, g, -1), mvecs))  # sum(M o P), sum(M2 o P)
    mean[lin], trq2y[lin] = both[0], both[1]
    both = np.real(np.einsum("cgk,tk->tcg", p_quad.reshape(3, g, -1), mvecs))  # the same with P_h
    mean[quad], trq2y[quad] = both[0], both[1]
    if not mean_only:
        _add_variance(var, v, mflat, p_lin, p_quad, kmat, r, r3, psi, t1, t2)
    y0 = None
    if full_signal:  # the passes' signal covariance y0_nm = C_nm[hv, hv] + sum(C_nm o P_nm) + sum(C_nm o Ph_nm),
        # from the same tau products: sum_ij C_nm[i, j] P_nm[i, j] = r_mn sum_kl tau_k(m) tau_l(n) <C_nm, F_kl>
        f = (re + 1j * im).reshape(1, 80, 9)
        d = (blocks.reshape(n * n, 1, 9) * f).sum(-1).reshape(n * n, 16, 5)  # <C_nm, F_kl> per component
        pt = np.ascontiguousarray(pairs.transpose(1, 0, 2))  # (N^2, G, 16)
        sums = (pt @ d.real + 1j * (pt @ d.imag)).transpose(2, 1, 0).reshape(5, g, n, n)
        y0 = np.zeros((6, g, n, n), complex)
        y0[0] = blocks[:, :, _HV, _HV][None]
        y0[lin] = r * sums[:2]
        y0[quad] = r**2 * sums[2:]
    csys = np.zeros((6, g))
    if population_cross and not mean_only:  # sum_abcd Q_ab Q_cd (x_bc^T P_ba y_da + x_da^T P_dc y_bc)
        cx, cy = blocks[:, :, :, _HV], blocks[:, :, _HV, :]  # C_nm e^H and e C_nm
        p5 = p_lin.reshape(2, g, n, 3, n, 3)
        csys[lin] = np.real(np.einsum("ab,cd,bci,kgbiaj,daj->kg", q, q, cx, p5, cy, optimize=True)
                            + np.einsum("ab,cd,dai,kgdicj,bcj->kg", q, q, cx, p5, cy, optimize=True))
    return {"mean": mean, "var": var, "trq2y": trq2y, "y0": y0, "csys": csys}


def _add_variance(var, v, mflat, p_lin, p_quad, kmat, r, r3, psi, t1, t2) -> None:
    """The coefficients of the variance of eq. (13) into ``var`` (6, G), from ``node_polynomials``' node products."""
    n, g = r.shape[0], p_lin.shape[1]
    vc = v.conj()
    lin, quad = slice(1, 3), slice(3, 6)  # rows of MONOMIALS
    var[lin] = 2 * np.real((p_lin @ vc) @ v)  # 2 v^T P v*
    var[quad] = 2 * np.real((p_quad @ vc) @ v)  # 2 v^T P_h v*
    # sum((M P_a^T) o (P_b M*)) for the four (a, b)
    cross = np.real(np.einsum("agik,bgik->abg", mflat @ np.swapaxes(p_lin, -1, -2), p_lin @ mflat.conj()))
    # 2 E[q1 q3]: beta_n = sum_m r_mn v_m^T T1_m Psi, gamma_nj = sum_(m,i) r_mn M[(m,i),(n,j)] (T1_m Psi)_i
    vt = np.einsum("mi,gmix->gmx", v.reshape(n, 3), t1)  # v_m^T T1_m, (G, N, 4)
    beta = np.einsum("mn,cgmd->cgnd", r, np.stack([vt @ psi[0], vt @ psi[1]]))  # (2, G, N, 6)
    gamma = (np.swapaxes(r3 * mflat, 0, 1) @ kmat).reshape(2, g, n, 3, 6)
    x = _times_products(beta)[:, None] @ np.swapaxes(gamma, -1, -2)[None]  # beta_n M_k gamma_nj^T, (2, 2, G, N, k, j)
    q13 = 8 * np.real(np.einsum("gnjk,abgnkj->abg", t2.conj(), x))
    cross = cross + q13
    var[3] += cross[0, 0]
    var[4] += cross[0, 1] + cross[1, 0]
    var[5] += cross[1, 1]


_PRODUCT_ENTRIES = tuple(zip(*np.nonzero(_PRODUCTS)))


def _times_products(beta: np.ndarray) -> np.ndarray:
    """beta M_k for every k (the product matrices are sparse): (..., 6) -> (..., 3, 6)."""
    out = np.zeros(beta.shape[:-1] + (3, 6), complex)
    for k, c, d in _PRODUCT_ENTRIES:
        out[..., k, d] += _PRODUCTS[k, c, d] * beta[..., c]
    return out


def monomials(v_delta, v_eps) -> np.ndarray:
    """Values of ``MONOMIALS`` at levels (any broadcast shape S): shape (6,) + S."""
    d, e = np.broadcast_arrays(np.asarray(v_delta, float), np.asarray(v_eps, float))
    out = np.empty((6,) + d.shape)  # filled row by row (a root finding's step asks it for a few levels)
    out[0], out[1], out[2], out[3], out[4], out[5] = 1.0, d, e, d * d, d * e, e * e
    return out
