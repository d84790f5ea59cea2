"""The polarimetric system model: crosstalk, channel imbalance, Faraday rotation, gain and noise.

Conventions (docs/conventions.md, pinned by tests/test_conventions.py):

* A 2x2 scattering matrix has rows indexed by the *receive* polarisation and columns by the
  *transmit* polarisation, laid out as in Quegan et al. (2018), eq. (11):
  ``[[S_hh, S_vh], [S_hv, S_vv]]``. So ``S_hv`` is "transmit h, receive v", the usual SAR product
  label (HV = H transmitted, V received).
* The scattering vector is the column-major (Fortran) vectorisation of that matrix,
  ``(hh, hv, vh, vv)``, which is the order of Men et al. (2021), eq. (1).
* The one-way Faraday rotation matrix is ``F(Omega) = [[cos, sin], [-sin, cos]]`` (Quegan et al. 2018,
  eq. 2), applied on both the way down and the way up: ``M = R F S F T``.
* Receive distortion ``R = [[1, delta2], [delta1, f1]]``, transmit distortion
  ``T = [[1, delta3], [delta4, f2]]`` with ``f_i = 1 + epsilon_i`` (Quegan et al. 2018, eq. 11;
  Freeman 2004).

Every function is vectorised over leading axes: ``delta`` has shape ``(..., 4)``, ``f`` shape
``(..., 2)``, ``omega`` shape ``(...)``, all broadcast together.
"""

from __future__ import annotations

import math

import numpy as np

CHANNELS = ("hh", "hv", "vh", "vv")
"""Order of the 4-element scattering vector: column-major vec of the receive x transmit matrix."""

RECIPROCAL_CHANNELS = ("hh", "hv", "vv")
"""Order of the 3-element (reciprocal, S_hv = S_vh) scattering vector used for scene covariances."""

RECIPROCAL_EMBEDDING = np.array(
    [[1, 0, 0], [0, 1, 0], [0, 1, 0], [0, 0, 1]], dtype=float
)
"""4x3 matrix mapping (hh, hv, vv) to (hh, hv, vh, vv) under reciprocity S_vh = S_hv."""


def faraday_matrix(omega: np.ndarray) -> np.ndarray:
    """One-way Faraday rotation matrix, shape ``omega.shape + (2, 2)``.

    omega : one-way Faraday rotation angle (rad), any shape. Quegan et al. (2018), eq. (2).
    """
    omega = np.asarray(omega, dtype=float)
    c, s = np.cos(omega), np.sin(omega)
    return np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], -2)


def _distortion(delta: np.ndarray, f: np.ndarray, upper: int, lower: int, diagonal: int) -> np.ndarray:
    """``[[1, delta[upper]], [delta[lower], f[diagonal]]]`` over the leading axes of delta and f together."""
    delta, f = np.asarray(delta), np.asarray(f)
    one = np.ones(np.broadcast_shapes(delta.shape[:-1], f.shape[:-1]), dtype=complex)
    return np.stack(
        [np.stack([one, delta[..., upper] * one], -1), np.stack([delta[..., lower] * one, f[..., diagonal] * one], -1)],
        -2,
    )


def receive_distortion(delta: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Receive-side distortion ``[[1, delta2], [delta1, f1]]``, Quegan et al. (2018), eq. (11)."""
    return _distortion(delta, f, upper=1, lower=0, diagonal=0)


def transmit_distortion(delta: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Transmit-side distortion ``[[1, delta3], [delta4, f2]]``, Quegan et al. (2018), eq. (11)."""
    return _distortion(delta, f, upper=2, lower=3, diagonal=1)


def measured_matrix(
    scattering: np.ndarray,
    delta: np.ndarray,
    f: np.ndarray,
    omega: np.ndarray,
    gain: complex | np.ndarray = 1.0,
    noise: np.ndarray | float = 0.0,
) -> np.ndarray:
    """Measured 2x2 scattering matrix ``M = A e^{j phi} R F S F T + N``.

    Quegan et al. (2018), eq. (11); Men et al. (2021), eq. (1) in vector form.

    scattering : true 2x2 matrix(es) ``[[S_hh, S_vh], [S_hv, S_vv]]``, shape ``(..., 2, 2)``.
    delta : crosstalk ``(delta1, delta2, delta3, delta4)``, shape ``(..., 4)``.
    f : channel imbalance ``(f1, f2)``, shape ``(..., 2)``.
    omega : one-way Faraday rotation (rad), shape ``(...)``.
    gain : complex gain ``A e^{j phi}`` (linear amplitude), shape ``(...)``.
    noise : additive noise matrix, shape ``(..., 2, 2)``.
    """
    rx = receive_distortion(delta, f)
    tx = transmit_distortion(delta, f)
    rot = faraday_matrix(omega)
    gain = np.asarray(gain)[..., None, None]
    return gain * (rx @ rot @ np.asarray(scattering) @ rot @ tx) + noise


def to_vector(matrix: np.ndarray) -> np.ndarray:
    """2x2 matrix ``[[hh, vh], [hv, vv]]`` -> vector ``(hh, hv, vh, vv)`` (column-major vec)."""
    m = np.asarray(matrix)
    return np.stack([m[..., 0, 0], m[..., 1, 0], m[..., 0, 1], m[..., 1, 1]], -1)


def to_matrix(vector: np.ndarray) -> np.ndarray:
    """Vector ``(hh, hv, vh, vv)`` -> 2x2 matrix ``[[hh, vh], [hv, vv]]``."""
    v = np.asarray(vector)
    return np.stack([np.stack([v[..., 0], v[..., 2]], -1), np.stack([v[..., 1], v[..., 3]], -1)], -2)


def distortion_operator(delta: np.ndarray, f: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """The 4x4 operator of Men et al. (2021), eq. (1): ``M_vec = K S_vec`` (gain and noise aside).

    ``K = (T^T kron R) (F^T kron F)``, the column-major vectorisation of ``R F S F T``. Its first
    factor is the distortion matrix of eq. (1) (whose printed entry "delta2 delta2" in row 3 is
    delta2 delta3, see docs/errata.md), its second the Faraday matrix of eq. (1).
    Shape ``(..., 4, 4)``.
    """
    rx = receive_distortion(delta, f)
    tx = transmit_distortion(delta, f)
    rot = faraday_matrix(omega)
    return batched_kron(np.swapaxes(tx, -1, -2), rx) @ batched_kron(np.swapaxes(rot, -1, -2), rot)


def batched_kron(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched Kronecker product of 2x2 matrices: shape ``(..., 4, 4)``."""
    out = a[..., :, None, :, None] * b[..., None, :, None, :]
    return out.reshape(out.shape[:-4] + (4, 4))


ESTIMATOR_WEIGHTS = {
    "hh": np.array([1.0, 0.0, 0.0, 0.0]),
    "hv": np.array([0.0, 0.5, 0.5, 0.0]),
    "vv": np.array([0.0, 0.0, 0.0, 1.0]),
}
"""Linear estimators of the reciprocal scattering amplitudes from the measured vector.

``hv``: ``S_hv_hat = (M_hv + M_vh) / 2``, Men et al. (2021), eq. (2) (independent of Omega)."""


def estimator_noise_factor(channel: str) -> float:
    """Noise power of the estimator for ``channel`` per unit noise power in each measured channel.

    ``S_hv_hat`` averages two independent noise terms, so its noise power is sigma_n / 2
    (the ``sigma_n / 2`` of Men et al. 2021, eq. 3); ``hh`` and ``vv`` keep sigma_n.
    """
    w = ESTIMATOR_WEIGHTS[channel]
    return float(np.sum(w**2))


def distortion_rows(delta: np.ndarray, f: np.ndarray) -> np.ndarray:
    """The distortion matrix of Men et al. (2021), eq. (1), ``T^T kron R``, shape ``(..., 4, 4)``.

    Rows (hh, hv, vh, vv): ``[1, d2, d4, d2 d4]``, ``[d1, f1, d1 d4, f1 d4]``,
    ``[d3, d2 d3, f2, f2 d2]``, ``[d1 d3, f1 d3, f2 d1, f1 f2]`` (row 3 printed with "d2 d2", errata).
    """
    d1, d2, d3, d4 = (np.asarray(delta)[..., i] for i in range(4))
    f1, f2 = np.asarray(f)[..., 0], np.asarray(f)[..., 1]
    one = np.ones_like(d1 * f1)
    rows = [
        [one, d2 * one, d4 * one, d2 * d4],
        [d1 * one, f1 * one, d1 * d4, f1 * d4],
        [d3 * one, d2 * d3, f2 * one, f2 * d2],
        [d1 * d3, f1 * d3, f2 * d1, f1 * f2],
    ]
    return np.stack([np.stack(r, -1) for r in rows], -2)


def faraday_reciprocal_columns(omega: np.ndarray) -> np.ndarray:
    """``(F^T kron F) P``: the Faraday matrix of Men et al. (2021) eq. (1) acting on (hh, hv, vv).

    Shape ``omega.shape + (4, 3)``; columns hh ``[c^2, -cs, cs, -s^2]``, hv ``[0, 1, 1, 0]`` (so S_hv_hat
    does not depend on Omega, eq. 2), vv ``[-s^2, -cs, cs, c^2]``.
    """
    omega = np.asarray(omega, dtype=float)
    c, s = np.cos(omega), np.sin(omega)
    zero, one = np.zeros_like(c), np.ones_like(c)
    cols = [[c * c, zero, -s * s], [-c * s, one, -c * s], [c * s, one, c * s], [-s * s, zero, c * c]]
    return np.stack([np.stack(r, -1) for r in cols], -2)


def effective_weights(
    delta: np.ndarray,
    f: np.ndarray,
    omega: np.ndarray,
    channel: str = "hv",
    gain: complex | np.ndarray = 1.0,
) -> np.ndarray:
    """Row vector ``a`` with ``S_pq_hat = a . (S_hh, S_hv, S_vv) + noise`` for one realisation.

    ``a = gain * w^T D(delta, f) (F^T kron F)(Omega) P``: the estimator weights ``w`` applied to the
    operator of Men et al. (2021) eq. (1) (``distortion_operator``), restricted to reciprocal scenes.
    Computed element-wise (``effective_weight_parts``), several times faster than forming the 4x4 operator.
    Shape ``(..., 3)``, complex.
    """
    parts = effective_weight_parts(delta, f, omega, channel)
    a = np.empty(parts.shape[2:] + (3,), complex)  # filled, not stacked
    a.real, a.imag = np.moveaxis(parts[:, 0], 0, -1), np.moveaxis(parts[:, 1], 0, -1)
    gain = np.asarray(gain)
    return a if gain.ndim == 0 and gain == 1.0 else gain[..., None] * a


def effective_weight_parts(delta: np.ndarray, f: np.ndarray, omega: np.ndarray, channel: str = "hv") -> np.ndarray:
    """The real and imaginary parts of ``effective_weights`` at unit gain, shape ``(3, 2, ...)``: element
    (hh, hv, vv) of ``a``, then (real, imaginary), then the broadcast leading axes of delta, f and omega.

    ``a = w^T D (F^T kron F) P`` (Men et al. 2021, eq. (1), restricted to reciprocal scenes) element by
    element: with ``d = w^T D`` (the rows of ``_distortion_row``
    with non-zero weight), ``a_hh = d_1 c^2 + (d_3 - d_2) c s - d_4 s^2``, ``a_hv = d_2 + d_3``,
    ``a_vv = -d_1 s^2 + (d_3 - d_2) c s + d_4 c^2`` (c, s: cos and sin of Omega; the columns of
    ``faraday_reciprocal_columns``). Planes of contiguous reals: a complex times a real is its two parts
    times the real, the same values bit for bit as the complex product, without casting the real to complex.
    """
    delta, f = np.asarray(delta), np.asarray(f)
    omega = np.asarray(omega, dtype=float)
    shape = np.broadcast_shapes(delta.shape[:-1], f.shape[:-1], omega.shape)
    d = _weighted_distortion_parts(ESTIMATOR_WEIGHTS[channel], delta, f, shape)
    c, s = np.cos(omega), np.sin(omega)
    a = np.empty((3, 2) + shape)
    np.add(d[1], d[2], out=a[1])
    cross = d[2]  # (d_3 - d_2) c s, in d_3's place once a_hv has it
    cross -= d[1]
    cross *= c * s
    corners = d[0::3]  # d_1 and d_4: (d s) s beside, then (d c) c in place
    ss = corners * s
    ss *= s
    corners *= c
    corners *= c
    np.add(corners[0], cross, out=a[0])
    a[0] -= ss[1]
    np.subtract(cross, ss[0], out=a[2])  # -d_1 s^2 + cross, exactly
    a[2] += corners[1]
    return a


def _weighted_distortion_parts(w: np.ndarray, delta, f, shape: tuple) -> np.ndarray:
    """``d = w^T D`` (the distortion matrix's rows weighted by the estimator) as parts, shape (4, 2, *shape).

    Each d_k sums the entries of the rows with non-zero weight. Every estimator weights at most two rows by one
    power of two: a sum of two terms is the same bits in either order (so a product is written in place first)
    and scaling by a power of two is exact, so ``w x + w y`` and ``w (x + y)`` are the same bits."""
    rows = np.flatnonzero(w)
    weight = float(w[rows[0]])
    if len(rows) > 2 or any(w[r] != weight for r in rows) or math.frexp(weight)[0] != 0.5:
        raise ValueError(f"estimator weights {w}: expected one power-of-two weight on at most two rows")
    factors = _distortion_factors(delta, f)
    d = np.empty((4,) + shape, complex)
    for col in range(4):
        _sum_into(d[col, ...], [factors[r][col] for r in rows])
    parts = np.empty((4, 2) + shape)
    np.multiply(d.real, weight, out=parts[:, 0])
    np.multiply(d.imag, weight, out=parts[:, 1])
    return parts


def _sum_into(out: np.ndarray, terms: list) -> None:
    """``out`` = the sum of one or two terms, each the product of its tuple of factors (an empty tuple is 1);
    a product is written straight into ``out`` (no temporary array)."""
    products = [term for term in terms if len(term) == 2]
    singles = [term[0] if term else 1.0 for term in terms if len(term) < 2]
    if products:
        np.multiply(*products[0], out=out)
        rest = [np.multiply(*term) for term in products[1:]] + singles
    elif len(singles) == 2:
        np.add(*singles, out=out)
        rest = []
    else:
        out[...] = singles[0]
        rest = []
    for term in rest:
        out += term


def _distortion_factors(delta, f) -> tuple:
    """The rows of ``distortion_rows`` as factors: each entry is the product of its tuple (an empty one is 1)."""
    d1, d2, d3, d4 = delta[..., 0], delta[..., 1], delta[..., 2], delta[..., 3]
    f1, f2 = f[..., 0], f[..., 1]
    return (((), (d2,), (d4,), (d2, d4)), ((d1,), (f1,), (d1, d4), (f1, d4)),
            ((d3,), (d2, d3), (f2,), (f2, d2)), ((d1, d3), (f1, d3), (f2, d1), (f1, f2)))
