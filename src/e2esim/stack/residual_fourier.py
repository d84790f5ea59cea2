"""The joint kernel's dependence on the residual rotations of the co-polarised correction, as trigonometric polynomials.

When every pass's co-polarised channels are corrected with an estimate Omega_hat_n = Omega_n - dW_n
(``StackFaraday.residual_nodes``), the kernel ``e2esim.stack.channel_forms.channel_node_polynomials`` is evaluated at
every Faraday-rotation node times every node of the residuals: 119 x 19 nodes for the 3-pass stack of
scenarios/biomass_fr_requirement.yaml, and the residual nodes change with the residual's mean and SD (every row of a
solve over them). The dependence on dW is a trigonometric polynomial of low degree (ground-cancellation.md,
Section 3.4): with F(a) = cos a I + sin a J the correction is F(-Omega_hat) = F(dW) F(-Omega), so

    A_n(Omega, dW) = A_n^0(Omega) + cos 2dW_n A_n^c(Omega) + sin 2dW_n A_n^s(Omega)                       (eq. 27)

(Quegan et al. 2018, eq. 4, for the correction; the identity F M F = c^2 M + cs (JM + MJ) + s^2 JMJ of Section 3.3).
Every output of the kernel is a polynomial of degree 2 (the signal covariances, the means, tr(Q^2 Y)) or 4 (the
covariances of the channels' forms, the speckle cross term) in the A_n, hence a trigonometric polynomial in
z_n = exp(2i dW_n) with frequencies k in Z^N, |k|_1 <= 2 or 4 (eq. 28). Its coefficients depend on the rotation
nodes only: ``residual_coefficients`` finds them once per geometry, exactly, from the kernel at Ns residuals on a line
2 dW_n = 2 pi m_n l / Ns (l = 0..Ns-1) where k . m is distinct modulo Ns for every k of the set (a discrete Fourier
transform of length Ns, no fit); ``evaluate_at`` gives the kernel at any residual nodes from them. The values equal
the node-by-node kernel to rounding (tests/test_stack_residual_fourier.py), so the quadrature, and every number, is
unchanged; a row of the solve costs the evaluation of the polynomials instead of the kernel.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import itertools
import json
from pathlib import Path

import numpy as np

from e2esim.stack.channel_forms import channel_node_polynomials

PLANS = {1: (9, (1,)), 2: (41, (1, 9)), 3: (145, (1, 9, 61))}
"""Passes -> (Ns, m): the shortest line found by search on which k . m is distinct modulo Ns for every k with
|k|_1 <= 4 (9, 41 and 129 frequencies). Stacks of more passes are evaluated node by node."""

DEGREE = {"y0": 2, "mean": 2, "trq2y": 2, "cov": 4, "csys": 4}
"""The degree of each output of ``channel_node_polynomials`` in the per-pass operators A_n (eq. 28)."""

_NODES_PER_CALL = 2048
"""Kernel nodes per call while sampling (rotation nodes x Ns): the size of one row's call, so memory stays bounded."""


@functools.cache  # a few (passes, degree) pairs: read by every row
def frequencies(passes: int, degree: int) -> np.ndarray:
    """(F, N) integer frequencies: 0 first, then every k with |k|_1 <= degree whose first non-zero entry is positive
    (the other half is their negative: the outputs are real). Read-only."""
    half = [k for k in itertools.product(range(-degree, degree + 1), repeat=passes)
            if 0 < sum(map(abs, k)) <= degree and next(x for x in k if x) > 0]
    out = np.array([(0,) * passes] + half, dtype=np.int64).reshape(-1, passes)
    out.setflags(write=False)
    return out


def _real_view(x: np.ndarray) -> np.ndarray:
    """A real array of a kernel output, node axis 1: complex entries as (real, imaginary) on a last axis."""
    return np.stack([x.real, x.imag], -1) if np.iscomplexobj(x) else x


def residual_coefficients(blocks: np.ndarray, q: np.ndarray, omega: np.ndarray, r: np.ndarray, gammas: np.ndarray,
                          gain_pair: np.ndarray | None = None, population_cross: bool = False,
                          signal: bool = True) -> dict:
    """The real coefficients of eq. (28) of every output of ``channel_node_polynomials`` (the same inputs, with the
    rotation nodes ``omega`` (G, N) alone): per output ``(F, 6, G, P)`` on the basis (1, cos 2k.dW, sin 2k.dW) of
    ``frequencies(N, DEGREE[name])`` (P: the output's entries per node, complex ones as two reals), and ``shapes``,
    each output's shape per node and whether it is complex. signal : also the coefficients of ``y0`` (the largest:
    left out, and None when evaluated, where the moments do not read it); ``csys`` only with ``population_cross``
    (zeros otherwise, as the kernel's)."""
    g, n = omega.shape
    ns, m = PLANS[n]
    dw = np.outer(np.arange(ns), m) * (np.pi / ns)  # 2 dW_n = 2 pi m_n l / Ns
    names = [name for name in DEGREE if (signal or name != "y0") and (population_cross or name != "csys")]
    picks = {name: frequencies(n, DEGREE[name]) @ np.asarray(m) % ns for name in names}
    chunk = max(1, _NODES_PER_CALL // ns)
    parts, shapes = {name: [] for name in names}, {}
    for start in range(0, g, chunk):
        om = np.repeat(omega[start:start + chunk], ns, axis=0)
        out = channel_node_polynomials(blocks, q, om, om - np.tile(dw, (len(om) // ns, 1)), r, gammas, gain_pair,
                                       population_cross)
        for name in names:
            x = out[name]
            shapes[name] = (x.shape[2:], np.iscomplexobj(x))
            real = _real_view(x)
            real = real.reshape(real.shape[0], -1, ns, int(np.prod(real.shape[2:], dtype=int)))  # (6, g, Ns, P)
            level = real.mean(axis=2, keepdims=True)  # c_0, taken out first: the transform sees the variation alone
            c = np.fft.fft(real - level, axis=2)[:, :, picks[name]] / ns  # c_k at K = k . m mod Ns, (6, g, F, P)
            parts[name].append(np.concatenate([level + c[:, :, :1].real, 2 * c[:, :, 1:].real,
                                               -2 * c[:, :, 1:].imag], 2))
    coefficients = {name: np.ascontiguousarray(np.concatenate(parts[name], 1).transpose(2, 0, 1, 3))
                    for name in names}
    coefficients["shapes"] = shapes
    coefficients["nodes"] = g
    return coefficients


STORE_KIND = "stack_residual_coefficients"
"""The kind of ``kept_coefficients``'s entries in an array cache."""

_CODE = ("e2esim.stack.residual_fourier", "e2esim.stack.channel_forms", "e2esim.distortion.expansion",
         "e2esim.polarimetry.system_model")
"""The modules whose code computes the coefficients: their source is part of a kept entry's key."""


@functools.cache  # the source of this process's modules does not change while it runs
def _code_digest() -> str:
    digest = hashlib.sha256()
    for name in _CODE:  # a module without a file (a frozen install) by its name: its code changes with the install
        file = getattr(importlib.import_module(name), "__file__", None)
        digest.update(name.encode() if file is None else Path(file).read_bytes())
    return digest.hexdigest()


def kept_coefficients(store, digest: str, make) -> dict:
    """``make()``, the result of ``residual_coefficients`` for inputs of ``digest`` (their content, as the kernel
    memo keys them, ``e2esim.stack.analytic.memoised``), kept between runs in ``store`` (an array cache with ``get``
    and ``put``: the front doors' ``e2esim.io.array_cache.ArrayCache``, handed in as ``KernelMemo.store``). The key
    holds the digest, the source of the code that computes them (``_CODE``) and numpy's version, so an entry is
    found again only where this code would compute the same numbers; the arrays read back are those computed, bit
    for bit (HDF5 keeps every float64 exactly, and the cache checks their checksum)."""
    description = {"inputs": digest, "code": _code_digest(), "numpy": np.__version__}
    found = store.get(STORE_KIND, description, None, ("shapes",))
    if found is not None:
        shapes = json.loads(found["attrs"]["shapes"])
        out = {name: found[name] for name in shapes}
        for array in out.values():
            array.setflags(write=False)
        out["shapes"] = {name: (tuple(shape), bool(complex_)) for name, (shape, complex_) in shapes.items()}
        out["nodes"] = int(found["attrs"]["nodes"])
        return out
    out = make()
    arrays = {name: out[name] for name in out["shapes"]}
    store.put(STORE_KIND, description, None, arrays,
              {"description": description, "shapes": out["shapes"], "nodes": out["nodes"]})
    return out


SUMMED = ("cov", "trq2y", "csys")
"""The outputs the joint moments read only as their weighted sums over the nodes (``evaluate_at``'s node_weights)."""


def evaluate_at(coefficients: dict, residual: np.ndarray, node_weights: tuple | None = None) -> dict:
    """The outputs of ``channel_node_polynomials`` at the rotation nodes times the residual nodes ``residual`` (J, N)
    rad (node (g, j) at g J + j, as ``joint_moments.joint_node_terms`` orders them), from ``residual_coefficients``;
    ``y0`` None where its coefficients were left out, ``csys`` zeros where the kernel gives zeros. node_weights :
    (w_g (G,), w_j (J,)), the rotation's and the residual's node weights: the outputs of ``SUMMED`` are then their
    weighted sums over the nodes, (6, ...) without a node axis, sum_g w_g sum_j w_j sum_f B_jf c_fg =
    sum_f (sum_j w_j B_jf) (sum_g w_g c_fg) (B the basis of eq. 28 at the residual's nodes): the sum the moments take,
    in another order (equal to rounding), without the values at the G J nodes."""
    shapes = coefficients["shapes"]
    j = residual.shape[0]
    summed = node_weights is not None
    out = {"y0": None, "csys": np.zeros((6, 3) if summed else (6, coefficients["nodes"] * j, 3))}
    for name, (shape, complex_) in shapes.items():
        coef = coefficients[name]  # (F', 6, G, P)
        _, k, g, p = coef.shape
        phase = 2.0 * residual @ frequencies(residual.shape[1], DEGREE[name])[1:].T  # (J, F)
        basis = np.concatenate([np.ones((j, 1)), np.cos(phase), np.sin(phase)], 1)
        if summed and name in SUMMED:
            at_nodes = (node_weights[1] @ basis) @ coef.reshape(coef.shape[0], -1)  # sum_j w_j B_jf c_f, (6 G P)
            values = np.einsum("g,kgp->kp", node_weights[0], at_nodes.reshape(k, g, p))
            values = values.reshape((k,) + shape + ((2,) if complex_ else ()))
        else:
            values = (basis @ coef.reshape(coef.shape[0], -1)).reshape(j, k, g, p).transpose(1, 2, 0, 3)
            values = values.reshape((k, g * j) + shape + ((2,) if complex_ else ()))
        out[name] = values[..., 0] + 1j * values[..., 1] if complex_ else values
    return out


__all__ = ["DEGREE", "PLANS", "STORE_KIND", "SUMMED", "evaluate_at", "frequencies", "kept_coefficients",
           "residual_coefficients"]
