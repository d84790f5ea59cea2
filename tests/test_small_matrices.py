"""Closed-form algebra of stacks of small matrices against numpy.linalg (e2esim.polarimetry.small_matrices)."""

import numpy as np
import pytest

from e2esim.polarimetry.small_matrices import cholesky, hermitian_inverse_factor, inverse2, inverse_lower


def _complex(rng, shape):
    return rng.standard_normal(shape) + 1j * rng.standard_normal(shape)


def _hermitian_pd(rng, shape, p):
    a = _complex(rng, shape + (p, p))
    return a @ np.conj(np.swapaxes(a, -1, -2)) + 0.1 * np.eye(p)


def test_inverse2_equals_numpy(rng):
    m = _complex(rng, (500, 3, 2, 2))
    inv = inverse2(m)
    np.testing.assert_allclose(inv, np.linalg.inv(m), rtol=1e-10, atol=1e-12 * np.max(np.abs(inv)))
    np.testing.assert_allclose(inv @ m, np.broadcast_to(np.eye(2), m.shape), atol=1e-10)


def test_inverse2_of_a_known_matrix():
    m = np.array([[2.0, 1.0], [4.0, 3.0]])
    np.testing.assert_allclose(inverse2(m), [[1.5, -0.5], [-2.0, 1.0]], rtol=1e-15)


@pytest.mark.parametrize("p", [2, 4, 7])
def test_cholesky_equals_numpy(rng, p):
    a = _hermitian_pd(rng, (400,), p)
    low = cholesky(a)
    np.testing.assert_allclose(low, np.linalg.cholesky(a), rtol=1e-10, atol=1e-12)
    assert np.all(np.triu(low, 1) == 0)
    np.testing.assert_allclose(low @ np.conj(np.swapaxes(low, -1, -2)), a, rtol=1e-12, atol=1e-12)


def test_cholesky_of_a_real_matrix_is_real():
    a = np.array([[4.0, 2.0], [2.0, 5.0]])
    low = cholesky(a)
    assert low.dtype == float
    np.testing.assert_allclose(low, [[2.0, 0.0], [1.0, 2.0]], rtol=1e-15)


@pytest.mark.parametrize("p", [2, 4, 7])
def test_inverse_lower_equals_numpy(rng, p):
    low = np.linalg.cholesky(_hermitian_pd(rng, (300, 2), p))
    np.testing.assert_allclose(inverse_lower(low), np.linalg.inv(low), rtol=1e-9, atol=1e-11)


def test_hermitian_inverse_factor_whitens(rng):
    a = _hermitian_pd(rng, (200, 4), 4)
    w = hermitian_inverse_factor(a)
    np.testing.assert_allclose(w @ a @ np.conj(np.swapaxes(w, -1, -2)), np.broadcast_to(np.eye(4), a.shape),
                               atol=1e-10)
    np.testing.assert_allclose(np.conj(np.swapaxes(w, -1, -2)) @ w, np.linalg.inv(a), rtol=1e-9, atol=1e-10)
