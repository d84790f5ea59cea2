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
                     gain_pair: np.ndarray | None = None, population_cross: bool = False,
                     full_signal: bool = False) -> dict:
    """Coefficients of eqs. (12)-(14) at each Faraday-rotation node.

    blocks : C_nm, shape (N, N, 3, 3). q : Q (N x N). omega : Faraday rotation of each pass at each node (G, N).
    r : pass correlation r_mn (N x N). sigmas : (Sigma_delta, Sigma_epsilon) unit 6 x 6 covariances.
    gain_pair : E[eta_n eta_m] of the passes' own gain factors (N x N), or None for 1.
    population_cross : also return ``csys`` (6, G): the first-order E tr(Q dY Q dY) of the finite-look speckle
        term of a combination of rank > 1 (ground-cancellation.md, eq. 16).

    full_signal : also return ``y0``.

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
    m2vec = m2.transpose(0, 2, 1, 3).reshape(-1)
    v = mflat[:, _HV::3].sum(axis=1)  # M e^H
    t1, t2 = trig_matrices(omega)  # (G, N, 3, 4), (G, N, 3, 3)
    t1f, t2f = t1.reshape(g, 3 * n, 4), t2.reshape(g, 3 * n, 3)
    r3 = np.kron(r, np.ones((3, 3)))  # r_mn on every entry of block (m, n)
    rm = r3 * mflat  # r_mn M_mn: contracts the K blocks of E[q1 q3]
    comps = {"d": sigmas[0], "e": sigmas[1]}
    cflat = blocks.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n) if full_signal else None
    cx, cy = blocks[:, :, :, _HV], blocks[:, :, _HV, :]  # C_nm e^H and e C_nm

    p_lin, kmat, csys = {}, {}, np.zeros((6, g))
    t1t = np.swapaxes(t1f, 1, 2)  # T1 is real: real products throughout
    for a, sa in comps.items():
        p_lin[a] = r3 * _real_sandwich(t1f, _B @ sa @ _B.T, t1t)  # P_mn = r T1_m Phi T1_n^H
        kmat[a] = _real_left(t1f, _B @ sa)  # E[l_i xi_c*] without r_mn: T1_m Psi, (G, 3N, 6)
        if population_cross:  # sum_abcd Q_ab Q_cd (x_bc^T P_ba y_da + x_da^T P_dc y_bc)
            p5 = p_lin[a].reshape(g, n, 3, n, 3)
            csys[MONOMIALS.index(a)] = np.real(
                np.einsum("ab,cd,bci,gbiaj,daj->g", q, q, cx, p5, cy, optimize=True)
                + np.einsum("ab,cd,dai,gdicj,bcj->g", q, q, cx, p5, cy, optimize=True))
    p_quad = {}  # P_h, mn = r^2 T2_m Pi T2_n^H, by monomial (Pi_de + Pi_ed for V_d V_e)
    r3sq = r3**2
    t2t = np.swapaxes(t2f, 1, 2)
    for mono in ("dd", "de", "ee"):
        pi = product_covariance(comps[mono[0]], comps[mono[1]])
        if mono == "de":
            pi = pi + product_covariance(comps["e"], comps["d"])
        p_quad[mono] = r3sq * _real_sandwich(t2f, pi, t2t)

    mean, var, trq2y = np.zeros((6, g)), np.zeros((6, g)), np.zeros((6, g))
    y0 = np.zeros((6, g, n, n), complex) if full_signal else None
    mean[0] = np.real(v[_HV::3].sum())  # e M e
    trq2y[0] = np.real(m2[:, :, _HV, _HV].sum())
    if full_signal:
        y0[0] = blocks[:, :, _HV, _HV][None]
    mvec, vc = mflat.ravel(), v.conj()
    for a in ("d", "e"):
        k = MONOMIALS.index(a)
        flat_p = p_lin[a].reshape(g, -1)
        mean[k] = np.real(np.einsum("gk,k->g", flat_p, mvec))  # sum(M o P)
        trq2y[k] = np.real(np.einsum("gk,k->g", flat_p, m2vec))
        var[k] = 2 * np.real((p_lin[a] @ vc) @ v)  # 2 v^T P v*
        if full_signal:
            y0[k] = _block_sums(cflat * p_lin[a], n)
    mp = {a: mflat @ np.swapaxes(p_lin[a], 1, 2) for a in ("d", "e")}  # M P^T
    pm = {a: p_lin[a] @ mflat.conj() for a in ("d", "e")}  # P M*
    vb = v.reshape(n, 3)
    # E[q1 q3]: beta_n = sum_m r_mn v_m^T T1_m Psi, gamma_nj = sum_(m,i) r_mn M[(m,i),(n,j)] (T1_m Psi)_i
    vt = np.einsum("mi,gmix->gmx", vb, t1)  # v_m^T T1_m, (G, N, 4)
    beta = {a: np.einsum("mn,gmc->gnc", r, vt @ (_B @ comps[a])) for a in ("d", "e")}  # (G, N, 6)
    gamma = {a: (np.swapaxes(rm, 0, 1)[None] @ kmat[a]).reshape(g, n, 3, 6) for a in ("d", "e")}
    t2c = np.swapaxes(t2.conj(), -1, -2)  # [g, n, k, j]
    for mono in ("dd", "de", "ee"):
        k = MONOMIALS.index(mono)
        flat_p = p_quad[mono].reshape(g, -1)
        mean[k] += np.real(np.einsum("gk,k->g", flat_p, mvec))  # sum(M o P_h)
        trq2y[k] += np.real(np.einsum("gk,k->g", flat_p, m2vec))
        var[k] += 2 * np.real((p_quad[mono] @ vc) @ v)  # 2 v^T P_h v*
        if full_signal:
            y0[k] += _block_sums(cflat * p_quad[mono], n)
    bm = {a: _times_products(beta[a]) for a in ("d", "e")}  # beta_n M_k
    for a, b, mono in (("d", "d", "dd"), ("d", "e", "de"), ("e", "d", "de"), ("e", "e", "ee")):
        k = MONOMIALS.index(mono)
        var[k] += np.real(np.einsum("gik,gik->g", mp[a], pm[b]))  # sum((M P_a^T) o (P_b M*))
        x = bm[a] @ np.swapaxes(gamma[b], -1, -2)  # [g, n, k, j] = beta_n M_k gamma_nj^T
        var[k] += 8 * np.real(np.einsum("gnkj,gnkj->g", t2c, x))  # 2 E[q1 q3]
    return {"mean": mean, "var": var, "trq2y": trq2y, "y0": y0, "csys": csys}


_PRODUCT_ENTRIES = tuple(zip(*np.nonzero(_PRODUCTS)))


def _times_products(beta: np.ndarray) -> np.ndarray:
    """beta M_k for every k (the product matrices are sparse): (..., 6) -> (..., 3, 6)."""
    out = np.zeros(beta.shape[:-1] + (3, 6), complex)
    for k, c, d in _PRODUCT_ENTRIES:
        out[..., k, d] += _PRODUCTS[k, c, d] * beta[..., c]
    return out


def _real_sandwich(left: np.ndarray, middle: np.ndarray, right: np.ndarray) -> np.ndarray:
    """left @ middle @ right for real (G, a, b) ``left``, (b, b) complex ``middle`` and real (G, b, a) ``right``,
    with real products (a quarter of the work of complex ones)."""
    return (left @ middle.real @ right) + 1j * (left @ middle.imag @ right)


def _real_left(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Real (G, a, b) ``left`` times complex (b, c) ``right``."""
    return (left @ right.real) + 1j * (left @ right.imag)


def _block_sums(x: np.ndarray, n: int) -> np.ndarray:
    """(G, 3N, 3N) -> (G, N, N): the sum of every 3 x 3 block."""
    return np.einsum("gaibj->gab", x.reshape(x.shape[0], n, 3, n, 3))


def monomials(v_delta, v_eps) -> np.ndarray:
    """Values of ``MONOMIALS`` at levels (any broadcast shape S): shape (6,) + S."""
    d, e = np.broadcast_arrays(np.asarray(v_delta, float), np.asarray(v_eps, float))
    return np.stack([np.ones_like(d), d, e, d * d, d * e, e * e])
