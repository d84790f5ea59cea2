"""Faraday-rotation estimators on quad-pol data: Bickel & Bates (circular basis) and Freeman (second moments).

One base class, like isce3's ``FaradayRotAngleSlc`` with its ``FaradayRotEstBickelBates`` and
``FaradayRotEstFreemanSecond`` subclasses: an estimator works on an image (block averages over a window)
or on 4x4 sample covariances of (hh, hv, vh, vv) (a Monte Carlo over windows), and returns a
``FaradayRotationEstimate``. Both need only second moments, so the two paths give identical numbers on
the same data.

Sign convention (docs/conventions.md): ``M = F S F`` with ``F = [[cos, sin], [-sin, cos]]`` (Quegan et al.
2018, eqs. 1-2). For a reciprocal target ``z_a = (M_hv - M_vh) + j (M_hh + M_vv) = j (S_hh + S_vv) e^{2j Omega}``
and ``z_b = (M_vh - M_hv) + j (M_hh + M_vv) = j (S_hh + S_vv) e^{-2j Omega}``, so
``Omega = arg(<z_a z_b*>) / 4`` (Bickel & Bates 1965): the two circular cross-polarised channels of the
circular-basis scattering matrix. isce3 forms the same product as ``LR conj(RL)``.
Both estimators are unambiguous only modulo pi/2 (``resolve_ambiguity``).

In the circular basis ``P = [[1, j], [j, 1]]`` the Faraday matrix is diagonal,
``P F(Omega) = diag(e^{-j Omega}, e^{j Omega}) P``, and ``z_a``, ``z_b`` are the two off-diagonal entries of
``P M P``: that is why their cross product carries ``4 Omega``. The often-quoted ``arg(Z12 Z21*)/4`` has the
opposite sign because it belongs to the transposed Faraday matrix (tests/test_faraday_sign.py recovers
+Omega through ``measured_matrix``). The variance of the estimate is in ``e2esim.faraday.theory``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.polarimetry.simulate import QuadPolImage
from e2esim.polarimetry.system_model import to_vector

AMBIGUITY_PERIOD = np.pi / 2
"""Both estimators give Omega modulo pi/2: F(pi/2) S F(pi/2) swaps S_hh and -S_vv, another valid target."""

# Linear combinations of (hh, hv, vh, vv) used by the estimators.
Z_A = np.array([1j, 1, -1, 1j])  # (M_hv - M_vh) + j (M_hh + M_vv)
Z_B = np.array([1j, -1, 1, 1j])  # (M_vh - M_hv) + j (M_hh + M_vv)
_CO_SUM = np.array([1, 0, 0, 1])  # M_hh + M_vv
_CROSS_DIFF = np.array([0, -1, 1, 0])  # M_vh - M_hv


@dataclass(frozen=True)
class FaradayRotationEstimate:
    """Faraday rotation estimated per window.

    omega : one-way Faraday rotation (rad) in [-pi/4, pi/4), shape (...) (one per window).
    magnitude : magnitude of the estimator's statistic (``|<z_a z_b*>|`` for Bickel-Bates,
        ``sqrt(<|M_hh+M_vv|^2> + <|M_vh-M_hv|^2>)`` for Freeman), m^2/m^2; a quality measure.
    coherence : ``|<z_a z_b*>| / sqrt(<|z_a|^2><|z_b|^2>)`` (Bickel-Bates) or NaN; gamma of eq. (6).
    looks : independent samples averaged per window. method : estimator name.
    """

    omega: np.ndarray
    magnitude: np.ndarray
    coherence: np.ndarray
    looks: int
    method: str


def _quadratic(cov: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``<(u.m)(v.m)*> = u^T C conj(v)`` for covariances C = <m m^H>, shape (...)."""
    return np.einsum("i,...ij,j->...", u, cov, np.conj(v))


def block_mean(x: np.ndarray, window: tuple | None) -> np.ndarray:
    """Means over non-overlapping (wy, wx) blocks of a 2-D array (edges that do not fill a block are
    dropped); ``window=None`` averages the whole array."""
    if window is None:
        return np.mean(x, axis=(-2, -1))
    wy, wx = window
    ny, nx = x.shape[-2] // wy, x.shape[-1] // wx
    if ny == 0 or nx == 0:
        raise PhysicsInputError(f"window {window} is larger than the image {x.shape[-2:]}")
    x = x[..., : ny * wy, : nx * wx]
    return x.reshape(x.shape[:-2] + (ny, wy, nx, wx)).mean(axis=(-3, -1))


def check_window(window, shape) -> tuple | None:
    if window is None:
        return None
    if len(window) != 2 or any(int(w) != w or w < 1 for w in window):
        raise PhysicsInputError(f"window must be two positive integers (azimuth, range), got {window!r}")
    return int(window[0]), int(window[1])


class FaradayRotationEstimator(ABC):
    """Base class: estimate Omega from an image or from sample covariances.

    Subclasses define ``statistics`` (which second moments they need, as pairs of linear combinations of
    the channels) and ``finish`` (Omega from those moments).
    """

    name: ClassVar[str] = ""
    statistics: ClassVar[dict] = {}

    def estimate(self, image: QuadPolImage, window: tuple | None = None) -> FaradayRotationEstimate:
        """Per-window estimates from an image; window = (azimuth, range) pixels, None for the whole image."""
        window = check_window(window, image.shape)
        channels = (image.hh, image.hv, image.vh, image.vv)
        combos: dict = {}  # each linear combination of the channels formed once

        def combo(w):
            if id(w) not in combos:
                combos[id(w)] = sum(c * x for c, x in zip(w, channels) if c != 0)
            return combos[id(w)]

        moments = {}
        for key, (u, v) in self.statistics.items():
            zu, zv = combo(u), combo(v)
            prod = zu.real**2 + zu.imag**2 if v is u else zu * np.conj(zv)
            moments[key] = block_mean(prod, window)
        looks = int(np.prod(image.shape)) if window is None else window[0] * window[1]
        return self.finish(moments, looks)

    def from_matrices(self, m: np.ndarray, axis: int = -1) -> FaradayRotationEstimate:
        """Estimates from measured matrices ``m`` (..., 2, 2) laid out ``[[hh, vh], [hv, vv]]``, averaging the
        statistics over ``axis`` of the leading dimensions (the looks of a window)."""
        m = np.asarray(m)
        vector = to_vector(m)  # (..., 4) in the order (hh, hv, vh, vv)
        looks = m.shape[:-2][axis]
        moments = {}
        for key, (u, v) in self.statistics.items():
            zu, zv = vector @ u, vector @ v  # shape m.shape[:-2]: ``axis`` is the same
            moments[key] = np.mean(zu * np.conj(zv), axis=axis)
        return self.finish(moments, looks)

    def from_covariance(self, cov: np.ndarray, looks: int) -> FaradayRotationEstimate:
        """Estimates from sample covariances ``<m m^H>`` of (hh, hv, vh, vv), shape (..., 4, 4)."""
        cov = np.asarray(cov)
        if cov.shape[-2:] != (4, 4):
            raise PhysicsInputError(f"covariances must be 4x4 over (hh, hv, vh, vv), got shape {cov.shape}")
        moments = {key: _quadratic(cov, u, v) for key, (u, v) in self.statistics.items()}
        return self.finish(moments, looks)

    @abstractmethod
    def finish(self, moments: dict, looks: int) -> FaradayRotationEstimate:
        """Omega from the window moments."""


class BickelBates(FaradayRotationEstimator):
    """``Omega = arg(<z_a z_b*>) / 4`` (Bickel & Bates 1965; Quegan et al. 2018, Section 3, eqs. 5-6).

    The best estimator of Omega (Rogers & Quegan 2014). For a reflection-symmetric or any reciprocal target
    with noise of equal power in the four channels, ``z_a`` and ``z_b`` are jointly circular Gaussian with
    coherence ``gamma = 1 / (1 + SNR^-1)``, ``SNR = <|S_hh + S_vv|^2> / sum of the four noise powers``
    (eq. 6), so its variance is that of the phase of an L-look coherence, divided by 16
    (``e2esim.faraday.theory``).
    """

    name = "bickel_bates"
    statistics: ClassVar[dict] = {"ab": (Z_A, Z_B), "aa": (Z_A, Z_A), "bb": (Z_B, Z_B)}

    def finish(self, moments, looks):
        ab = moments["ab"]
        omega = np.angle(ab) / 4
        power = np.sqrt(np.real(moments["aa"]) * np.real(moments["bb"]))
        with np.errstate(invalid="ignore", divide="ignore"):
            coherence = np.where(power > 0, np.abs(ab) / np.where(power > 0, power, 1.0), np.nan)
        return FaradayRotationEstimate(omega, np.abs(ab), coherence, looks, self.name)


class FreemanSecondMoment(FaradayRotationEstimator):
    """``Omega = (s/2) arctan sqrt(<|M_vh - M_hv|^2> / <|M_hh + M_vv|^2>)`` (Freeman 2004), sign s of
    ``Re<(M_vh - M_hv)(M_hh + M_vv)*>``.

    For a reciprocal target ``M_vh - M_hv = (S_hh + S_vv) sin 2 Omega`` and ``M_hh + M_vv = (S_hh + S_vv)
    cos 2 Omega``. isce3's ``FaradayRotEstFreemanSecond`` takes the sign from the mean of the per-pixel
    ratio; here it is the real part of the cross moment, which has no heavy tails. Noise adds
    ``2 sigma_n`` to both powers and biases |Omega| towards pi/8; give ``noise_power`` (per channel) to
    subtract it.
    """

    name = "freeman"
    statistics: ClassVar[dict] = {"cross": (_CROSS_DIFF, _CROSS_DIFF), "co": (_CO_SUM, _CO_SUM),
                                  "mix": (_CROSS_DIFF, _CO_SUM)}

    def __init__(self, noise_power: float | None = None):
        if noise_power is not None and not (np.isfinite(noise_power) and noise_power >= 0):
            raise PhysicsInputError(f"noise_power must be a finite number >= 0, got {noise_power!r}")
        self.noise_power = noise_power

    def finish(self, moments, looks):
        cross, co = np.real(moments["cross"]), np.real(moments["co"])
        if self.noise_power:
            cross = np.clip(cross - 2 * self.noise_power, 0.0, None)
            co = np.clip(co - 2 * self.noise_power, 0.0, None)
        sign = np.sign(np.real(moments["mix"]))
        with np.errstate(invalid="ignore", divide="ignore"):
            omega = 0.5 * sign * np.arctan(np.sqrt(cross / co))
        return FaradayRotationEstimate(omega, np.sqrt(cross + co), np.full(np.shape(omega), np.nan), looks, self.name)


ESTIMATORS = {cls.name: cls for cls in (BickelBates, FreemanSecondMoment)}


def resolve_ambiguity(omega_hat, prior_rad, period: float = AMBIGUITY_PERIOD) -> np.ndarray:
    """The branch ``omega_hat + k period`` nearest the prior (e.g. the Faraday rotation predicted from a
    TEC map and a geomagnetic model, the ionosphere module's mean): Chen & Quegan (2010) resolve the
    ambiguity of FR estimators the same way."""
    omega_hat = np.asarray(omega_hat, dtype=float)
    return omega_hat + period * np.round((np.asarray(prior_rad, dtype=float) - omega_hat) / period)


def wrap_error(error, period: float = AMBIGUITY_PERIOD) -> np.ndarray:
    """An angle difference wrapped to [-period/2, period/2)."""
    return (np.asarray(error, dtype=float) + period / 2) % period - period / 2
