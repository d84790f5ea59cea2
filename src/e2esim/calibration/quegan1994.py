"""Crosstalk and channel imbalance from distributed targets: the unified algorithm of Quegan (1994).

S. Quegan, "A unified algorithm for phase and cross-talk calibration of polarimetric data - theory and
observations", IEEE TGRS 32(1), 89-99, 1994; the method Quegan et al. (2018), Section 5.2, cite as [6].

Model ``M = Y R S T + N`` without Faraday rotation, in the project's notation ``R = [[1, delta2], [delta1, f1]]``,
``T = [[1, delta3], [delta4, f2]]``. For a reciprocal, reflection-symmetric target
(``<S_hh S_hv*> = <S_vv S_hv*> = 0``) and to first order in the crosstalk, the covariance
``C = <m m^H>`` of m = (hh, hv, vh, vv) (indices 0..3) gives, with ``Delta = C00 C33 - |C03|^2``,

    u = delta1      = (C33 C10 - C30 C13) / Delta        v = delta4 / f2 = (C00 C13 - C10 C03) / Delta
    z = delta3      = (C33 C20 - C30 C23) / Delta        w = delta2 / f1 = (C00 C23 - C20 C03) / Delta

and the ratio of receive and transmit imbalances ``alpha = f1 / f2`` from the cross-polarised powers after
the crosstalk is removed (two estimates alpha1, alpha2 combined so that equal noise in HV and VH
cancels). The co-polarised imbalance ``k = f1 f2`` (and the absolute gain Y) are not observable on a
distributed target: they need a point target of known scattering matrix such as a trihedral.

Known limits, shown by simulation in docs/theory/calibration.md:

* the neglected terms are of order ``delta sigma_hv / sigma_co``: e.g. ``C10`` contains
  ``f1 (delta2 + delta4)* sigma_hv``, so u is biased by about ``(delta2 + delta4)* sigma_hv / sigma_hh``.
  That is small only when HV is much weaker than the co-polarised channels, which is not the case for
  P-band forest (sigma_hv / sigma_hh = 0.11 to 0.38 in Men et al. 2021, Table I). Iterating the algorithm
  on the data it has corrected (``iterations > 1``) shrinks this bias geometrically, by roughly
  ``sigma_hv (1/sigma_hh + 1/sigma_vv)`` per pass (0.38 boreal 200 t/ha, 0.71 tropical 338 t/ha), since
  the calibrated truth is a fixed point;
* Faraday rotation ``Omega`` looks like crosstalk: ``R F(Omega)`` has crosstalk ``delta1 - Omega``,
  ``delta2 + Omega`` (and ``T``: ``delta3 + Omega``, ``delta4 - Omega``) to first order, the ambiguity of
  Quegan et al. (2018), Sect. 5.2. So the crosstalk itself can be estimated (e.g. to verify a -30 dB
  specification) only where |Omega| is well below it, on the zero-FR line. As a *correction* the algorithm
  absorbs the rotation while the first-order solution holds: one pass up to about 12 deg, five passes up to
  about 40 deg; beyond, it fails (near 45 deg the rotation swaps the channels), so Faraday rotation must be
  corrected first away from the magnetic equator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.faraday.estimators import block_mean, check_window
from e2esim.polarimetry.simulate import QuadPolImage
from e2esim.polarimetry.small_matrices import inverse2
from e2esim.polarimetry.system_model import batched_kron


@dataclass(frozen=True)
class QueganEstimate:
    """Estimated distortion, Quegan (1994). All complex, shape (...).

    u, v, w, z : crosstalk ratios (u = delta1, v = delta4/f2, w = delta2/f1, z = delta3).
    alpha : f1 / f2. k : the co-polarised imbalance f1 f2 used to split alpha (1 unless a point target
        measured it). receive, transmit : (..., 2, 2) estimated R and T in the model's normalisation.
    iterations : passes made.
    """

    u: np.ndarray
    v: np.ndarray
    w: np.ndarray
    z: np.ndarray
    alpha: np.ndarray
    k: np.ndarray
    receive: np.ndarray
    transmit: np.ndarray
    iterations: int

    @property
    def delta(self) -> np.ndarray:
        """(delta1, delta2, delta3, delta4) of the estimated R and T, shape (..., 4)."""
        r, t = self.receive, self.transmit
        return np.stack([r[..., 1, 0], r[..., 0, 1], t[..., 0, 1], t[..., 1, 0]], -1)

    @property
    def f(self) -> np.ndarray:
        """(f1, f2), shape (..., 2)."""
        return np.stack([self.receive[..., 1, 1], self.transmit[..., 1, 1]], -1)


def quegan_ratios(cov: np.ndarray, noise_power: float | None = None) -> dict:
    """One pass of Quegan (1994): u, v, w, z and alpha from covariances (..., 4, 4) of (hh, hv, vh, vv).

    noise_power : per-channel noise power to subtract from C00 and C33 (the co-polarised powers in the
    denominators); the alpha combination already cancels equal HV/VH noise.
    """
    c = np.asarray(cov)
    c00, c33 = np.real(c[..., 0, 0]), np.real(c[..., 3, 3])
    if noise_power:
        c00, c33 = c00 - noise_power, c33 - noise_power
    c03, c30 = c[..., 0, 3], c[..., 3, 0]
    delta = c00 * c33 - np.abs(c03) ** 2
    u = (c33 * c[..., 1, 0] - c30 * c[..., 1, 3]) / delta
    v = (c00 * c[..., 1, 3] - c[..., 1, 0] * c03) / delta
    z = (c33 * c[..., 2, 0] - c30 * c[..., 2, 3]) / delta
    w = (c00 * c[..., 2, 3] - c[..., 2, 0] * c03) / delta
    x = c[..., 2, 1] - z * c[..., 0, 1] - w * c[..., 3, 1]  # ~ f2 f1* sigma_hv
    alpha1 = (c[..., 1, 1] - u * c[..., 0, 1] - v * c[..., 3, 1]) / x
    alpha2 = np.conj(x) / (c[..., 2, 2] - np.conj(z) * c[..., 2, 0] - np.conj(w) * c[..., 2, 3])
    a12, a2 = np.abs(alpha1 * alpha2), np.abs(alpha2)
    mag = (a12 - 1 + np.sqrt((a12 - 1) ** 2 + 4 * a2**2)) / (2 * a2)
    alpha = mag * np.exp(1j * np.angle(alpha1))
    return {"u": u, "v": v, "w": w, "z": z, "alpha": alpha}


def distortion_from_ratios(u, v, w, z, alpha, k=1.0) -> tuple[np.ndarray, np.ndarray]:
    """R and T from the ratios: ``f1 = sqrt(alpha k)``, ``f2 = sqrt(k / alpha)`` (roots near 1),
    ``delta1 = u``, ``delta2 = w f1``, ``delta3 = z``, ``delta4 = v f2``."""
    f1 = _root_near_one(np.asarray(alpha) * k)
    f2 = _root_near_one(np.asarray(k) / np.asarray(alpha))
    one = np.ones_like(f1)
    receive = np.stack([np.stack([one, w * f1], -1), np.stack([u * one, f1], -1)], -2)
    transmit = np.stack([np.stack([one, z * one], -1), np.stack([v * f2, f2], -1)], -2)
    return receive, transmit


def _root_near_one(x) -> np.ndarray:
    r = np.sqrt(np.asarray(x, dtype=complex))
    return np.where(np.real(r) < 0, -r, r)


def transform_covariance(cov: np.ndarray, p_receive: np.ndarray, p_transmit: np.ndarray) -> np.ndarray:
    """Covariance of vec(P_r M P_t): ``G C G^H`` with ``G = P_t^T kron P_r`` (column-major vec)."""
    g = batched_kron(np.swapaxes(p_transmit, -1, -2), p_receive)
    return g @ cov @ np.swapaxes(g.conj(), -1, -2)


def quegan_calibrate(
    cov: np.ndarray, iterations: int = 1, noise_power: float | None = None, k=1.0
) -> QueganEstimate:
    """Estimate R and T by Quegan (1994), optionally iterated on the corrected covariance.

    Pass i estimates the distortion left after the corrections of passes 1..i-1 and composes it, so the
    returned R, T are the products of the pass estimates (renormalised to R11 = T11 = 1).
    k : co-polarised imbalance f1 f2 from a point target (default 1: not corrected).
    """
    if int(iterations) != iterations or iterations < 1:
        raise PhysicsInputError(f"iterations must be a positive integer, got {iterations!r}")
    cov = np.asarray(cov, dtype=complex)
    if cov.shape[-2:] != (4, 4):
        raise PhysicsInputError(f"covariances must be 4x4 over (hh, hv, vh, vv), got shape {cov.shape}")
    batch = cov.shape[:-2]
    receive = np.broadcast_to(np.eye(2, dtype=complex), batch + (2, 2)).copy()
    transmit = receive.copy()
    current = cov
    first = None
    for i in range(int(iterations)):
        ratios = quegan_ratios(current, noise_power)
        r_i, t_i = distortion_from_ratios(**ratios, k=k if i == 0 else 1.0)
        if first is None:
            first = ratios
        receive = receive @ r_i
        transmit = t_i @ transmit
        current = transform_covariance(cov, inverse2(receive), inverse2(transmit))
    receive, transmit = _normalise(receive), _normalise(transmit)
    return QueganEstimate(
        first["u"], first["v"], first["w"], first["z"], first["alpha"],
        np.broadcast_to(np.asarray(k, dtype=complex), batch), receive, transmit, int(iterations),
    )


def _normalise(m: np.ndarray) -> np.ndarray:
    return m / m[..., :1, :1]


def block_covariances(image: QuadPolImage, window: tuple | None = None) -> np.ndarray:
    """Sample covariances ``<m m^H>`` of (hh, hv, vh, vv) over non-overlapping windows, (..., 4, 4)."""
    window = check_window(window, image.shape)
    ch = (image.hh, image.hv, image.vh, image.vv)
    out = None
    for i in range(4):
        for j in range(i, 4):
            cij = block_mean(ch[i] * np.conj(ch[j]), window)
            if out is None:
                out = np.empty(np.shape(cij) + (4, 4), dtype=complex)
            out[..., i, j] = cij
            out[..., j, i] = np.conj(cij)
    return out
