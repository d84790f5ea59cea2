"""Closed-form algebra of stacks of small matrices: 2x2 inverse, Cholesky factor, triangular inverse.

The calibration pipeline works on stacks of thousands of 2x2 and 4x4 matrices (one per Monte Carlo
realisation and calibrator). ``numpy.linalg`` calls LAPACK once per matrix (``inv`` through an LU
factorisation), so for such stacks its per-matrix overhead dominates; written element by element, with the
loops over the matrix entries (never over the stack), the same algebra is several times faster (for the
transponder whitening, the inverse Cholesky factor of 16,000 4x4 matrices: 9 ms against 35 ms). For 7x7 and
larger, or for a Cholesky factor alone, ``numpy.linalg`` is as fast. Products of the results are left to
``@``, which is fast for stacks. tests/test_small_matrices.py checks every function against ``numpy.linalg``.
"""

from __future__ import annotations

import numpy as np


def inverse2(m: np.ndarray) -> np.ndarray:
    """Inverse of 2x2 matrices (..., 2, 2): ``[[d, -b], [-c, a]] / (a d - b c)`` (Cramer's rule)."""
    a, b, c, d = m[..., 0, 0], m[..., 0, 1], m[..., 1, 0], m[..., 1, 1]
    det = a * d - b * c
    return np.stack([np.stack([d, -b], -1), np.stack([-c, a], -1)], -2) / det[..., None, None]


def cholesky(a: np.ndarray) -> np.ndarray:
    """Lower-triangular L with ``L L^H = a`` for Hermitian positive-definite matrices (..., p, p), real positive
    diagonal: the Cholesky-Banachiewicz recurrence, row by row (Golub & Van Loan, Matrix Computations, 4th ed.,
    Algorithm 4.2.1, in its row-oriented form)."""
    p = a.shape[-1]
    low = [[None] * p for _ in range(p)]
    for i in range(p):
        for j in range(i + 1):
            s = a[..., i, j]
            for k in range(j):
                s = s - low[i][k] * np.conj(low[j][k])
            low[i][j] = np.sqrt(np.real(s)) if i == j else s / low[j][j]
    return _assemble(low, a.shape, np.result_type(a.dtype, float))


def inverse_lower(low: np.ndarray) -> np.ndarray:
    """Inverse of lower-triangular matrices (..., p, p): ``M_ii = 1 / L_ii``,
    ``M_ij = -(sum_{k=j}^{i-1} L_ik M_kj) / L_ii`` for j < i (forward substitution on the identity, Golub &
    Van Loan, Algorithm 3.1.1)."""
    p = low.shape[-1]
    inv = [[None] * p for _ in range(p)]
    for j in range(p):
        inv[j][j] = 1.0 / low[..., j, j]
        for i in range(j + 1, p):
            s = low[..., i, j] * inv[j][j]
            for k in range(j + 1, i):
                s = s + low[..., i, k] * inv[k][j]
            inv[i][j] = -s / low[..., i, i]
    return _assemble(inv, low.shape, low.dtype)


def hermitian_inverse_factor(a: np.ndarray) -> np.ndarray:
    """``W = L^-1`` of the Cholesky factor of Hermitian positive-definite matrices (..., p, p), so that
    ``a^-1 = W^H W`` and ``a^-1 b = W^H (W b)``: solves and inverses without an LU factorisation."""
    return inverse_lower(cholesky(a))


def _assemble(entries: list, shape: tuple, dtype) -> np.ndarray:
    """A (..., p, p) array from the lower-triangular ``entries[i][j]`` (j <= i); zeros above the diagonal."""
    out = np.zeros(shape, dtype=dtype)
    for i, row in enumerate(entries):
        for j in range(i + 1):
            out[..., i, j] = row[j]
    return out
