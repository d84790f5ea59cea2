"""The polarimetric system model of Men et al. (2021), eq. (1) / Quegan et al. (2018), eq. (11)."""

import numpy as np
import pytest

from e2esim.polarimetry.system_model import (
    ESTIMATOR_WEIGHTS,
    RECIPROCAL_EMBEDDING,
    distortion_operator,
    distortion_rows,
    effective_weights,
    estimator_noise_factor,
    faraday_reciprocal_columns,
)


def _random_errors(rng, n=50, scale=0.3):
    delta = scale * (rng.normal(size=(n, 4)) + 1j * rng.normal(size=(n, 4)))
    f = 1 + scale * (rng.normal(size=(n, 2)) + 1j * rng.normal(size=(n, 2)))
    return delta, f, rng.uniform(-np.pi, np.pi, n)


def test_distortion_matrix_rows_of_eq1_with_delta2_delta3(rng):
    # Row 3 is [d3, d2 d3, f2, f2 d2]: eq. (1) prints "d2 d2" (docs/errata.md, E1).
    delta, f, _ = _random_errors(rng, 1)
    d1, d2, d3, d4 = delta[0]
    f1, f2 = f[0]
    expected = np.array([
        [1, d2, d4, d2 * d4],
        [d1, f1, d1 * d4, f1 * d4],
        [d3, d2 * d3, f2, f2 * d2],
        [d1 * d3, f1 * d3, f2 * d1, f1 * f2],
    ])
    np.testing.assert_allclose(distortion_rows(delta, f)[0], expected)


def test_faraday_matrix_of_eq1(rng):
    om = rng.uniform(-3, 3)
    c, s = np.cos(om), np.sin(om)
    f4 = np.array([[c * c, c * s, -c * s, -s * s], [-c * s, c * c, s * s, -c * s],
                   [c * s, s * s, c * c, c * s], [-s * s, c * s, -c * s, c * c]])
    np.testing.assert_allclose(distortion_operator(np.zeros(4), np.ones(2), om), f4, atol=1e-15)
    np.testing.assert_allclose(faraday_reciprocal_columns(om), f4 @ RECIPROCAL_EMBEDDING, atol=1e-15)


@pytest.mark.parametrize("channel", ["hh", "hv", "vv"])
def test_effective_weights_equal_operator_row(rng, channel):
    delta, f, om = _random_errors(rng)
    gain = rng.uniform(0.5, 2, delta.shape[0])
    a = effective_weights(delta, f, om, channel, gain)
    ref = gain[:, None] * np.einsum("i,nij,jk->nk", ESTIMATOR_WEIGHTS[channel], distortion_operator(delta, f, om),
                                    RECIPROCAL_EMBEDDING)
    np.testing.assert_allclose(a, ref, rtol=1e-12, atol=1e-12)


def test_exact_expansion_of_the_hv_coefficients(rng):
    # The exact coefficients behind docs/errata.md E3 and e2esim.distortion.second_order:
    # a_hh = X + B + (s/2)(c U - s D), a_hv = 1 + A + W/2, a_vv = Y + B + (c/2)(c D + s U).
    delta, f, om = _random_errors(rng)
    d1, d2, d3, d4 = delta.T
    e1, e2 = (f - 1).T
    c, s = np.cos(om), np.sin(om)
    s13, s24 = (d1 + d3) / 2, (d2 + d4) / 2
    x, y = c**2 * s13 - s**2 * s24, c**2 * s24 - s**2 * s13
    a_, b_ = (e1 + e2) / 2, c * s * (e2 - e1) / 2
    u, w, dd = d1 * d4 - d2 * d3, d1 * d4 + d2 * d3, d2 * e2 + d4 * e1
    expected = np.stack([x + b_ + s / 2 * (c * u - s * dd), 1 + a_ + w / 2, y + b_ + c / 2 * (c * dd + s * u)], -1)
    np.testing.assert_allclose(effective_weights(delta, f, om, "hv"), expected, rtol=1e-12, atol=1e-12)


def test_estimator_noise_factors():
    # sigma_n / 2 for S_hv_hat = (M_hv + M_vh)/2 (Men et al. 2021, eq. 3); sigma_n for hh and vv.
    assert estimator_noise_factor("hv") == 0.5
    assert estimator_noise_factor("hh") == 1.0
    assert estimator_noise_factor("vv") == 1.0


def test_broadcasting_of_vectorised_kernels(rng):
    delta, f, om = _random_errors(rng, 6)
    a = effective_weights(delta.reshape(2, 3, 4), f.reshape(2, 3, 2), om.reshape(2, 3), "hv")
    assert a.shape == (2, 3, 3)
    np.testing.assert_allclose(a.reshape(6, 3), effective_weights(delta, f, om, "hv"))


def _complex_effective_weights(delta, f, om, channel, gain):
    """The element-wise formula in complex arithmetic, term by term: w_r times each row entry of
    ``distortion_rows``, summed in row order, then the Faraday columns as complex-times-real products."""
    w, rows = ESTIMATOR_WEIGHTS[channel], np.moveaxis(distortion_rows(delta, f), (-2, -1), (0, 1))
    first, *rest = np.flatnonzero(w)
    d = [sum((w[r] * rows[r, col] for r in rest), w[first] * rows[first, col]) for col in range(4)]
    c, s = np.cos(om), np.sin(om)
    cross = (d[2] - d[1]) * (c * s)
    a = np.stack([d[0] * c * c + cross - d[3] * s * s, d[1] + d[2], -d[0] * s * s + cross + d[3] * c * c], -1)
    return gain[..., None] * a


@pytest.mark.parametrize("channel", ["hh", "hv", "vv"])
@pytest.mark.parametrize("shape", [(40,), (), (2, 3)])
def test_effective_weights_are_the_complex_formula_bit_for_bit(rng, channel, shape):
    # The parts are computed in real arithmetic (a complex times a real is its two parts times the real) and a
    # power-of-two estimator weight scales the sum of the rows once: the same bits as the complex products.
    n = int(np.prod(shape))
    delta, f, om = _random_errors(rng, n)
    delta, f, om = delta.reshape(shape + (4,)), f.reshape(shape + (2,)), om.reshape(shape)
    gain = rng.uniform(0.5, 2, shape)
    expected = _complex_effective_weights(delta, f, om, channel, gain)
    assert np.array_equal(effective_weights(delta, f, om, channel, gain), expected)
    assert np.array_equal(effective_weights(delta, f, om[..., :1] if shape == (2, 3) else om, channel),
                          _complex_effective_weights(delta, f, om[..., :1] if shape == (2, 3) else om, channel,
                                                     np.ones(shape)))
