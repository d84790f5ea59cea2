"""The estimates of S_hh, S_hv, S_vv as polynomials in the system errors (docs/theory/co-pol-error.md, sec. 2).

Measured data ``M = R F(Omega) S F(Omega) T`` (gain and noise aside; Quegan et al. 2018, eq. 11; Men et al.
2021, eq. 1), optionally rotated back by an estimate ``W_hat`` of the Faraday rotation,
``S_hat = F(-W_hat) M F(-W_hat)`` (Quegan et al. 2018, eq. 4). The estimated reciprocal vector is
``(S_hat_hh, (S_hat_hv + S_hat_vh)/2, S_hat_vv)`` (Men et al. 2021, eq. 2 for HV). R and T are affine in the
six error terms

    xi = (delta1, delta2, eps1 | delta3, delta4, eps2)      receive side r = xi[:3], transmit side t = xi[3:]

so every estimate is ``A s`` with (co-pol eq. 2.3)

    A = A0 + sum_i xi_i U_i + sum_{i in r, j in t} r_i t_j W_ij

exactly: the operator is at most bilinear in the errors (one receive times one transmit term). The
coefficient matrices depend only on the angles, not on the scene or the error statistics, so they are
computed once per set of quadrature nodes (``expansion_at``, kept in the kernel memo handed in).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.polarimetry.system_model import faraday_matrix

ERROR_TERMS = ("delta1", "delta2", "eps1", "delta3", "delta4", "eps2")
"""Order of the error vector xi: receive side (delta1, delta2, eps1), then transmit side (delta3, delta4, eps2)."""

RECEIVE, TRANSMIT = slice(0, 3), slice(3, 6)

# Where each error term sits in R = [[1, d2], [d1, f1]] and T = [[1, d3], [d4, f2]] (conventions.md).
_RECEIVE_BASIS = np.zeros((3, 2, 2))
_RECEIVE_BASIS[0, 1, 0] = _RECEIVE_BASIS[1, 0, 1] = _RECEIVE_BASIS[2, 1, 1] = 1.0  # delta1, delta2, eps1
_TRANSMIT_BASIS = np.zeros((3, 2, 2))
_TRANSMIT_BASIS[0, 0, 1] = _TRANSMIT_BASIS[1, 1, 0] = _TRANSMIT_BASIS[2, 1, 1] = 1.0  # delta3, delta4, eps2
_RECEIVE_COLUMN = [int(np.nonzero(m)[1][0]) for m in _RECEIVE_BASIS]  # the column of each R_i's one entry
_TRANSMIT_ROW = [int(np.nonzero(m)[0][0]) for m in _TRANSMIT_BASIS]  # the row of each T_j's one entry

# Reciprocal scattering matrices of the basis vectors (hh, hv, vv), layout [[hh, vh], [hv, vv]].
_SCENE_BASIS = np.array([[[1, 0], [0, 0]], [[0, 1], [1, 0]], [[0, 0], [0, 1]]], dtype=float)


def estimate_channels(matrix: np.ndarray) -> np.ndarray:
    """``(M_hh, (M_hv + M_vh)/2, M_vv)`` of 2x2 matrices ``[[hh, vh], [hv, vv]]``, shape (..., 3)."""
    m = np.asarray(matrix)
    return np.stack([m[..., 0, 0], 0.5 * (m[..., 1, 0] + m[..., 0, 1]), m[..., 1, 1]], -1)


@dataclass(frozen=True)
class Expansion:
    """``A = a0 + sum xi_i u_i + sum r_i t_j w_ij`` at each angle (arrays over leading node axes).

    a0 : (..., 3, 3) [channel p, scene component c]. u : (..., 6, 3, 3) [error i, p, c].
    w : (..., 3, 3, 3, 3) [receive error i, transmit error j, p, c].
    """

    a0: np.ndarray
    u: np.ndarray
    w: np.ndarray


def expansion(omega, omega_hat=None) -> Expansion:
    """Exact expansion of the estimator rows for Faraday rotation ``omega`` and, when the data are
    corrected, the estimate ``omega_hat`` (rad; broadcast; None: no correction).

    Co-pol eq. (2.2): ``S_hat = P R Q S Q T P`` with ``Q = F(omega)``, ``P = F(-omega_hat)``; a0 from R = T = I,
    u from one error term, w from one receive and one transmit term.
    """
    q = faraday_matrix(omega)
    p = np.broadcast_to(np.eye(2), q.shape) if omega_hat is None else faraday_matrix(-np.asarray(omega_hat, float))
    p, q = np.broadcast_arrays(p, q)
    qsq = np.einsum("...ab,cbd,...de->...cae", q, _SCENE_BASIS, q)  # Q E_c Q, (..., c, 2, 2)
    left = np.einsum("...ab,...cbd->...cad", p, qsq)  # P Q E_c Q
    right = np.einsum("...cab,...bd->...cad", qsq, p)  # Q E_c Q P
    full = np.einsum("...cab,...bd->...cad", left, p)  # P Q E_c Q P
    a0 = np.swapaxes(estimate_channels(full), -1, -2)  # (..., p, c)
    # one receive error: P R_i (Q E_c Q P); one transmit error: (P Q E_c Q) T_j P
    pr = np.einsum("...ab,ibd->...iad", p, _RECEIVE_BASIS)
    tp = np.einsum("jab,...bd->...jad", _TRANSMIT_BASIS, p)
    # R_i has one entry, in column b_i, so (P R_i)[a, b] is zero for b != b_i; T_j has one, in row d_j: the sums
    # over b (and d) have one term that is not zero, taken alone (the sums' value exactly; "+ 0.0" turns a -0 into
    # the +0 the sums give), instead of einsum's generic loop over every (b, d), which cost most of the expansion
    pr_b = np.stack([pr[..., i, :, b] for i, b in enumerate(_RECEIVE_COLUMN)], -2)  # (P R_i)[a, b_i], (..., i, a)
    tp_d = np.stack([tp[..., j, d, :] for j, d in enumerate(_TRANSMIT_ROW)], -2)  # (T_j P)[d_j, e], (..., j, e)
    right_b = np.moveaxis(right[..., :, _RECEIVE_COLUMN, :], -2, -3)  # (Q E_c Q P)[b_i, d], (..., i, c, d)
    u_r = pr_b[..., :, None, :, None] * right_b[..., :, :, None, :] + 0.0  # (..., i, c, a, d)
    left_d = np.moveaxis(left[..., :, :, _TRANSMIT_ROW], -1, -3)  # (P Q E_c Q)[a, d_j], (..., j, c, a)
    u_t = left_d[..., None] * tp_d[..., :, None, None, :] + 0.0  # (..., j, c, a, d)
    u = np.swapaxes(estimate_channels(np.concatenate([u_r, u_t], axis=-4)), -1, -2)  # (..., 6, p, c)
    # one of each: P R_i Q E_c Q T_j P, the one term (P R_i)[a, b_i] (Q E_c Q)[b_i, d_j] (T_j P)[d_j, e]
    q_bd = qsq[..., :, _RECEIVE_COLUMN, :][..., _TRANSMIT_ROW]  # (Q E_c Q)[b_i, d_j], (..., c, i, j)
    w = (pr_b[..., :, None, None, :, None] * np.moveaxis(q_bd, -3, -1)[..., None, None]) * tp_d[
        ..., None, :, None, None, :] + 0.0  # (..., i, j, c, a, e)
    w = np.swapaxes(estimate_channels(w), -1, -2)  # (..., i, j, p, c)
    return Expansion(a0, u, w)


EXPANSIONS_KEPT = 16
"""Expansions kept in a ``KernelMemo`` (``expansion_at``): a case's variants share their nodes."""


def expansion_at(omega, omega_hat=None, memo=None) -> Expansion:
    """``expansion`` at quadrature nodes ``omega`` (and ``omega_hat``), with read-only arrays. ``memo``: the
    process's ``KernelMemo`` (``case.services.memo``) or None. It keeps the last ``EXPANSIONS_KEPT`` by the nodes'
    shape and bytes (the nodes are the same for many distributions and for the variants of a case, so an expansion
    is computed once); a kept expansion is the one computed, so a number never depends on whether it was found."""
    om = np.ascontiguousarray(omega, dtype=float)
    oh = None if omega_hat is None else np.ascontiguousarray(omega_hat, dtype=float)
    if not hasattr(memo, "recall"):  # None, or a decoded model's memo (an empty dict)
        return _read_only(expansion(om, oh))
    key = ("expansion", om.shape, om.tobytes(), None if oh is None else oh.tobytes())
    return memo.recall(key, lambda: _read_only(expansion(om, oh)), keep=EXPANSIONS_KEPT)


def _read_only(e: Expansion) -> Expansion:
    for arr in (e.a0, e.u, e.w):
        arr.setflags(write=False)
    return e


def error_vector(delta: np.ndarray, f: np.ndarray) -> np.ndarray:
    """xi = (delta1, delta2, eps1, delta3, delta4, eps2) from crosstalk (..., 4) and imbalance f = 1 + eps (..., 2)."""
    d, e = np.asarray(delta), np.asarray(f) - 1.0
    return np.stack([d[..., 0], d[..., 1], e[..., 0], d[..., 2], d[..., 3], e[..., 1]], -1)


def evaluate(exp: Expansion, xi: np.ndarray) -> np.ndarray:
    """A (..., 3, 3) for error vectors xi (..., 6): the polynomial of co-pol eq. (2.3)."""
    xi = np.asarray(xi)
    lin = np.einsum("...i,...ipc->...pc", xi, exp.u)
    quad = np.einsum("...i,...j,...ijpc->...pc", xi[..., RECEIVE], xi[..., TRANSMIT], exp.w)
    return exp.a0 + lin + quad


def estimator_matrix(delta, f, omega, omega_hat=None, gain=1.0) -> np.ndarray:
    """Exact A (..., 3, 3) with ``(S_hat_hh, S_hat_hv, S_hat_vv) = A (S_hh, S_hv, S_vv)`` for one realisation:
    ``gain F(-omega_hat) R F S F T F(-omega_hat)`` on the scene basis, multiplied out, no expansion (the Monte
    Carlo's reference; for omega_hat None the uncorrected data, rows as ``effective_weights``)."""
    return np.moveaxis(estimator_entries(delta, f, omega, omega_hat, gain), (0, 1), (-2, -1))


def estimator_entries(delta, f, omega, omega_hat=None, gain=1.0) -> np.ndarray:
    """``estimator_matrix`` laid out as (3, 3, ...): each entry a contiguous array over the realisations.

    The 2x2 products are written out entry by entry (batched 2x2 matrix products cost far more per element).
    """
    d = np.asarray(delta)
    e = np.asarray(f)
    one = np.ones(np.broadcast_shapes(d.shape[:-1], e.shape[:-1], np.shape(omega)))
    c, s = np.cos(omega), np.sin(omega)
    rx = (one, d[..., 1], d[..., 0], e[..., 0])  # R = [[1, d2], [d1, f1]] as (00, 01, 10, 11)
    tx = (one, d[..., 2], d[..., 3], e[..., 1])  # T = [[1, d3], [d4, f2]]
    q = (c, s, -s, c)  # F(omega)
    left, right = _mul2(rx, q), _mul2(q, tx)
    if omega_hat is not None:
        ch, sh = np.cos(omega_hat), np.sin(omega_hat)
        p = (ch, -sh, sh, ch)  # F(-omega_hat)
        left, right = _mul2(p, left), _mul2(right, p)
    # L E_c R for the basis (E_hh = e0 e0^T, E_hv = e0 e1^T + e1 e0^T, E_vv = e1 e1^T): outer products of the
    # columns of L and the rows of R
    l0, l1, r0, r1 = (left[0], left[2]), (left[1], left[3]), (right[0], right[1]), (right[2], right[3])
    hv = [x + y for x, y in zip(_outer_channels(l0, r1), _outer_channels(l1, r0))]
    cols = (_outer_channels(l0, r0), hv, _outer_channels(l1, r1))
    g = np.asarray(gain)
    return np.array([[g * cols[col][row] for col in range(3)] for row in range(3)])


def _mul2(a, b):
    """Product of 2x2 matrices given as (00, 01, 10, 11) tuples of arrays."""
    return (a[0] * b[0] + a[1] * b[2], a[0] * b[1] + a[1] * b[3], a[2] * b[0] + a[3] * b[2], a[2] * b[1] + a[3] * b[3])


def _outer_channels(x, y):
    """``estimate_channels`` of the outer product x y^T of 2-vectors: (x0 y0, (x1 y0 + x0 y1)/2, x1 y1)."""
    return (x[0] * y[0], 0.5 * (x[1] * y[0] + x[0] * y[1]), x[1] * y[1])
