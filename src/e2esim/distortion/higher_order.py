"""The third- and fourth-order part of the covariance of the estimated powers, exactly (co-pol eq. 3.6).

The estimated power of channel p at fixed angles is an exact polynomial in the error terms xi (co-pol eq. 2.3),

    q_p = sum_(k, l) m_k m_l^* H_p[k, l],   H_p[k, l] = b_k,p C b_l,p^H,

over the extended monomials m = (1 | xi_1 .. xi_6 | r_i t_j, i, j = 1..3) with coefficient rows
b_k,p = a0_p, u_i,p, w_ij,p (``e2esim.distortion.expansion``). For zero-mean circular complex Gaussian xi
(Men et al. 2021, Section III) Isserlis' theorem gives every moment E[prod_U xi prod_D xi^*] as the sum over
the bijections sigma from U to D of prod Gamma[a, sigma(a)] (the permanent of the covariance), so

    Cov(q_p, q_q) = sum_(k, l, m, n) H_p[k, l] H_q[m, n] kappa[k, l, m, n],                            (3.6)

with kappa the sum over the bijections from the unconjugated terms of (m_k, m_m) to the conjugated terms of
(m_l, m_n) that do not pair m_k with m_l and m_m with m_n (those make up E[q_p] E[q_q]). Gamma =
V_delta Gamma_delta + V_eps Gamma_eps, and the two structures have disjoint supports (crosstalk terms correlate
only with crosstalk terms), so every bijection contributes a single monomial V_delta^a V_eps^b, a + b the
number of unconjugated terms (the degree). Degrees 1 and 2 are co-pol eq. (3.3) (``channel_moments``; this
kernel reproduces them, tested to 1e-12); this module gives degrees 3 (Var T3, Cov(T2, a2 C a2^H)) and 4
(Var(a2 C a2^H)), the terms eq. (3.3) leaves out. With them the covariance at fixed angles is exact for Gaussian
errors at any level. They matter where a channel's variance has no first-order part (HH without Faraday
rotation: its leading variance is O(V^2), and the omitted terms are O(V^3), relative O(V); 11 % of the HH
variance at -10 dB, 3-sigma label, docs/theory/validity.md).
"""

from __future__ import annotations

import functools
import itertools

import numpy as np

HIGHER_MONOMIALS = ("Vd^3", "Vd^2 Ve", "Vd Ve^2", "Ve^3", "Vd^4", "Vd^3 Ve", "Vd^2 Ve^2", "Vd Ve^3", "Ve^4")
"""Monomials of the crosstalk and channel-imbalance levels of degrees 3 and 4, in the order of the kernel's
output (``monomial_index`` maps (a, b) of V_delta^a V_eps^b to it)."""

_TERMS = ((),) + tuple((i,) for i in range(6)) + tuple((i, 3 + j) for i in range(3) for j in range(3))
"""The error terms of each extended monomial: 1, the six xi_i, the nine r_i t_j."""
_CROSSTALK = frozenset((0, 1, 3, 4))  # delta1, delta2, delta3, delta4 in ERROR_TERMS
_PAIRED = frozenset({(0, 3), (3, 0), (1, 4), (4, 1), (2, 5), (5, 2)})  # the correlated pairs of Section III
_CHUNK = 1 << 21  # complex elements of the gathered forms held at once
_ONE = 6  # a padding index: the padded covariance has 1 there, so shorter products are unchanged


@functools.lru_cache(maxsize=4)
def pairing_terms(degrees: tuple = (3, 4)) -> dict:
    """The structurally non-zero terms of kappa (eq. 3.6) of the given degrees, enumerated once.

    Returns arrays over the bijections: ``a, b`` (T, 4) the error terms they pair (padded with ``_ONE``) and
    ``inverse``, the distinct (k, l, m, n, monomial) each belongs to; and over those: ``left`` = 16 k + l,
    ``right`` = 16 m + n (extended-monomial indices) and ``monomial``, the index of V_delta^a V_eps^b among the
    monomials of the requested degrees (each degree from V_delta^d to V_eps^d); ``count`` monomials.
    """
    corr = np.zeros((7, 7), dtype=bool)
    for a in range(6):
        corr[a, a] = True
    for a, b in _PAIRED:
        corr[a, b] = True
    sizes = np.array([len(t) for t in _TERMS])
    padded = np.array([t + (_ONE,) * (2 - len(t)) for t in _TERMS])  # (16, 2)
    order = {d: sum(e + 1 for e in degrees if e < d) for d in degrees}
    blocks = []
    for degree in degrees:
        for su, sd in itertools.product(range(degree + 1), repeat=2):  # sizes of m_k and m_l
            ks, ms, ls, ns = (np.flatnonzero(sizes == x) for x in (su, degree - su, sd, degree - sd))
            if min(len(ks), len(ms), len(ls), len(ns)) == 0:
                continue
            k, el, m, n = (x.ravel() for x in np.meshgrid(ks, ls, ms, ns, indexing="ij"))
            up = np.concatenate([padded[k, :su], padded[m, :degree - su]], 1)  # (C, degree)
            down = np.concatenate([padded[el, :sd], padded[n, :degree - sd]], 1)
            perms = np.array(list(itertools.permutations(range(degree))))  # (P, degree)
            # a pairing within (m_k, m_l) and within (m_m, m_n) is part of E[q_p] E[q_q]: left out
            keep = ~np.all((perms[:, :su] < sd), axis=1) if su == sd else np.ones(len(perms), bool)
            perms = perms[keep]
            paired = down[:, perms]  # (C, P, degree)
            ok = np.all(corr[up[:, None, :], paired], axis=-1)
            ci, pi = np.nonzero(ok)
            a = np.broadcast_to(up[:, None, :], paired.shape)[ci, pi]
            b = paired[ci, pi]
            crosstalk = np.isin(a, sorted(_CROSSTALK)).sum(1)
            pad = np.full((len(ci), 4 - degree), _ONE)
            blocks.append(np.column_stack([order[degree] + degree - crosstalk, k[ci], el[ci], m[ci], n[ci],
                                           a, pad, b, pad]))
    t = np.concatenate(blocks).astype(np.intp)
    # bijections with the same (k, l, m, n) and monomial are summed before the contraction
    keys, inverse = np.unique(t[:, :5], axis=0, return_inverse=True)
    return {"a": t[:, 5:9], "b": t[:, 9:13], "inverse": inverse.ravel(), "monomial": keys[:, 0],
            "left": keys[:, 1] * 16 + keys[:, 2], "right": keys[:, 3] * 16 + keys[:, 4],
            "count": sum(d + 1 for d in degrees)}


def coefficients(gammas: np.ndarray, degrees: tuple = (3, 4)) -> tuple[dict, np.ndarray]:
    """(terms, values): ``pairing_terms`` and kappa of each distinct (k, l, m, n, monomial): the sum of its
    bijections' products of unit covariances prod Gamma_unit[a, b] (Gamma_unit = Gamma_delta + Gamma_eps at unit
    levels: their supports are disjoint)."""
    terms = pairing_terms(tuple(degrees))
    g = np.zeros((7, 7), dtype=complex)
    g[:6, :6] = np.asarray(gammas, dtype=complex).sum(0)
    g[_ONE, _ONE] = 1.0
    products = np.prod(g[terms["a"], terms["b"]], axis=-1)
    size = terms["left"].size
    values = (np.bincount(terms["inverse"], products.real, size)
              + 1j * np.bincount(terms["inverse"], products.imag, size))
    return terms, values


def power_forms(exp, scene) -> np.ndarray:
    """H_p[k, l] = b_k,p C b_l,p^H (..., 3, 16, 16) at every node of ``exp`` (scene (..., 3, 3) before the
    node axis, as ``channel_moments.conditional_polynomials``)."""
    c = np.asarray(scene, dtype=complex)[..., None, :, :]
    u, w = exp.u, exp.w
    rows = np.concatenate([exp.a0[..., None, :, :], u, w.reshape(w.shape[:-4] + (9, 3, 3))], axis=-3)
    rows = np.swapaxes(rows, -3, -2)  # (..., p, k, c)
    return (rows @ c[..., None, :, :]) @ np.swapaxes(rows.conj(), -1, -2)


def covariance_coefficients(exp, scene, gammas, degrees: tuple = (3, 4)) -> np.ndarray:
    """Coefficients of Cov(q_p, q_q) of the given degrees (eq. 3.6): (..., G, n_monomials, 3, 3), real; for the
    default degrees in the order of ``HIGHER_MONOMIALS``."""
    terms, values = coefficients(gammas, degrees)
    h = power_forms(exp, scene)  # (..., G, 3, 16, 16)
    lead = h.shape[:-3]
    flat = h.reshape((-1, 3, 256))
    out = np.zeros((flat.shape[0], terms["count"], 3, 3))
    # each monomial's terms gathered on their own (not all terms, then each monomial's out of them: one copy less)
    groups = [np.flatnonzero(terms["monomial"] == i) for i in range(terms["count"])]
    groups = [(terms["left"][sel], values[sel], terms["right"][sel]) for sel in groups]
    step = max(1, _CHUNK // (3 * values.size))  # nodes at once: bounded memory for many scenes and nodes
    for start in range(0, flat.shape[0], step):
        part = flat[start:start + step]
        for i, (left, value, right) in enumerate(groups):  # (chunk, 3, terms of the monomial)
            out[start:start + step, i] = np.real((part[..., left] * value) @ np.swapaxes(part[..., right], -1, -2))
    return out.reshape(lead + (terms["count"], 3, 3))


def higher_monomials(crosstalk, imbalance) -> np.ndarray:
    """The values of ``HIGHER_MONOMIALS`` for levels V_delta, V_eps (broadcast), shape (..., 9)."""
    vd, ve = np.broadcast_arrays(np.asarray(crosstalk, float), np.asarray(imbalance, float))
    return np.stack([vd ** (d - b) * ve**b for d in (3, 4) for b in range(d + 1)], -1)


def split_by_source(parts: np.ndarray) -> tuple:
    """(crosstalk alone, channel imbalance alone, interaction) of terms (..., 9, 3, 3) already multiplied by
    ``higher_monomials``: V_delta^d, V_eps^d and the mixed monomials."""
    alone_d, alone_e = [0, 4], [3, 8]
    mixed = [1, 2, 5, 6, 7]
    return parts[..., alone_d, :, :].sum(-3), parts[..., alone_e, :, :].sum(-3), parts[..., mixed, :, :].sum(-3)
