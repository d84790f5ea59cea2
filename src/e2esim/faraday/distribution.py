"""Distributions of the one-way Faraday rotation angle Omega (rad).

Everything the error propagation needs from Omega is its circular moments
``phi_k = E[exp(i k Omega)]`` (Men et al. 2021, eqs. 9-10 use k = 2, 4) and, for the Monte Carlo, samples.
A distribution given by a climatology (issue "FR climatology") plugs in as ``EmpiricalFaraday``.

Note on Men et al. (2021), eq. (10): ``<cos p Omega> = cos(p <Omega>) exp(-sigma^2 p^2 / 2)`` is the
real part of the Gaussian characteristic function at integer p, so it is *exact* for a Gaussian Omega
on the real line (equivalently a wrapped normal); the paper's caveat that it is "only approximate because
Omega is a circular variable" does not apply to these moments (docs/errata.md).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from e2esim.errors import PhysicsInputError

QUADRATURE_DEGREE = 8
"""Highest harmonic in Omega of any quantity averaged over Faraday rotation (the second-order variance
contains products of four of cos^2, sin^2, cos sin, i.e. harmonics up to 8 Omega)."""
FINE_QUADRATURE_DEGREE = 16
"""The other degree e2esim averages at: the exact covariance of Faraday-corrected co-polarised channels
(``e2esim.distortion.faraday_correction.CORRECTED_DEGREE``)."""


def _read_only(nodes: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    nodes.setflags(write=False)
    weights.setflags(write=False)
    return nodes, weights


def quadrature_nodes(degree: int = QUADRATURE_DEGREE) -> np.ndarray:
    """The nodes of ``FaradayDistribution.quadrature``: ``2 pi g / G``, g = 0..G-1, G = 2 degree + 1 (rad), the
    same for every distribution (only the weights depend on it)."""
    n_nodes = 2 * degree + 1
    return 2 * np.pi * np.arange(n_nodes) / n_nodes


_EVEN_U = np.cos(np.pi * (2 * np.arange(5) + 1) / 10)  # Chebyshev points of [-1, 1]
EVEN_NODES = 0.5 * np.arccos(_EVEN_U)
"""Nodes Omega_j (rad) of ``FaradayDistribution.even_quadrature``, the same for every distribution."""
EVEN_NODES.setflags(write=False)
EVEN_WEIGHTS = np.linalg.inv(np.vander(_EVEN_U, 5, increasing=True).T)  # w = V^-T E[u^k]
"""Weights of ``even_quadrature``: ``EVEN_WEIGHTS @ (E[u^k], k = 0..4)``, u = cos(2 Omega), at ``EVEN_NODES``."""


PERCENTILES = (0.135, 2.275, 5.0, 25.0, 50.0, 75.0, 95.0, 97.725, 99.865)
"""Percentiles (%) of Omega reported for every climatology (3-sigma, 2-sigma, quartiles, median)."""


def weighted_percentiles(values, weights, percents) -> np.ndarray:
    """Percentiles (%) of a weighted sample: the inverse of the weighted empirical CDF, with linear
    interpolation between the mid-points of the sorted samples' probability masses."""
    v = np.asarray(values, float).ravel()
    w = np.asarray(weights, float).ravel()
    order = np.argsort(v)
    v, w = v[order], w[order] / w.sum()
    cdf = np.cumsum(w) - w / 2
    return np.interp(np.asarray(percents, float) / 100.0, cdf, v)


class FaradayDistribution(ABC):
    """Distribution of the one-way Faraday rotation angle Omega (rad)."""

    @abstractmethod
    def circular_moment(self, k) -> np.ndarray:
        """``E[exp(i k Omega)]`` for integer ``k`` (any shape), complex."""

    @abstractmethod
    def sample(self, rng: np.random.Generator, size) -> np.ndarray:
        """Draw Omega (rad), array of shape ``size``."""

    @property
    @abstractmethod
    def mean_rad(self) -> float:
        """Mean of Omega (rad)."""

    @property
    @abstractmethod
    def sd_rad(self) -> float:
        """Standard deviation of Omega (rad)."""

    # ------------------------------------------------------------------------------------------
    def trig_moments(self) -> dict:
        """Moments of trigonometric functions of Omega, Men et al. (2021), eq. (9a-d).

        Returns ``c4 = <cos^4>``, ``s4 = <sin^4>``, ``c2s2 = <cos^2 sin^2>``, ``cs = <cos sin>``.
        """
        phi2 = self.circular_moment(2)
        phi4 = self.circular_moment(4)
        cos2, cos4, sin2 = phi2.real, phi4.real, phi2.imag
        return {
            "c4": (3 + 4 * cos2 + cos4) / 8,  # eq. (9a)
            "s4": (3 - 4 * cos2 + cos4) / 8,  # eq. (9b)
            "c2s2": (1 - cos4) / 8,  # eq. (9c)
            "cs": sin2 / 2,  # eq. (9d)
        }

    def quadrature(self, degree: int = QUADRATURE_DEGREE) -> tuple[np.ndarray, np.ndarray]:
        """Nodes and weights that average any trigonometric polynomial of Omega exactly.

        For ``h(Omega) = sum_{|m| <= degree} h_m exp(i m Omega)``, ``sum_g w_g h(Omega_g) = E[h(Omega)]``
        with equally spaced nodes ``Omega_g = 2 pi g / G``, ``G = 2 degree + 1``, and weights
        ``w_g = (1/G) sum_{|k| <= degree} phi_k exp(-i k Omega_g)``: the discrete Fourier transform of h
        is exact for G > 2 degree, and ``E[exp(i m Omega)] = phi_m``. Weights can be negative; the arrays are
        read-only. At the two degrees e2esim asks (``QUADRATURE_DEGREE``, ``FINE_QUADRATURE_DEGREE``) the rule is
        kept with the distribution (``quadrature_rule``, ``fine_quadrature_rule``): every evaluation of the error
        model of a case averages over the same distribution. Another degree is computed at each call.
        """
        if degree == QUADRATURE_DEGREE:
            return self.quadrature_rule
        if degree == FINE_QUADRATURE_DEGREE:
            return self.fine_quadrature_rule
        return _read_only(*self._quadrature(degree))

    @cached_property
    def quadrature_rule(self) -> tuple[np.ndarray, np.ndarray]:
        """``quadrature(QUADRATURE_DEGREE)``, derived once."""
        return _read_only(*self._quadrature(QUADRATURE_DEGREE))

    @cached_property
    def fine_quadrature_rule(self) -> tuple[np.ndarray, np.ndarray]:
        """``quadrature(FINE_QUADRATURE_DEGREE)``, derived once."""
        return _read_only(*self._quadrature(FINE_QUADRATURE_DEGREE))

    def even_quadrature(self) -> tuple[np.ndarray, np.ndarray]:
        """Nodes (rad) and weights that average any polynomial of degree <= 4 in ``u = cos 2 Omega`` exactly: the
        quantities of the sigma_hv error moments (Men et al. 2021, eqs. 6-8 and their products, functions of
        cos^4, sin^4, cos^2 sin^2 and (cos sin)^2 only) are such polynomials.

        Five fixed nodes ``u_j`` (the Chebyshev points of [-1, 1]; ``Omega_j = arccos(u_j) / 2``) with weights
        solving ``sum_j w_j u_j^k = E[u^k]``, k = 0..4, where ``E[u^k]`` follows from the circular moments
        phi_2, phi_4, phi_6, phi_8 (``u^2 = (1 + cos 4 Omega)/2``, ``u^3 = (3 cos 2 Omega + cos 6 Omega)/4``,
        ``u^4 = (3 + 4 cos 4 Omega + cos 8 Omega)/8``). Weights can be negative; kept with the distribution
        (``even_quadrature_rule``).
        """
        return self.even_quadrature_rule

    @cached_property
    def even_quadrature_rule(self) -> tuple[np.ndarray, np.ndarray]:
        """``even_quadrature()``, derived once."""
        phi = np.real(self.circular_moment(np.array([2.0, 4.0, 6.0, 8.0])))
        moments = np.array([1.0, phi[0], (1 + phi[1]) / 2, (3 * phi[0] + phi[2]) / 4, (3 + 4 * phi[1] + phi[3]) / 8])
        weights = EVEN_WEIGHTS @ moments
        weights.setflags(write=False)
        return EVEN_NODES, weights

    def _quadrature(self, degree: int) -> tuple[np.ndarray, np.ndarray]:
        """Uncached ``quadrature``."""
        nodes = quadrature_nodes(degree)
        n_nodes = nodes.size
        k = np.arange(1, degree + 1)
        phi = self.circular_moment(k)
        weights = (1 + 2 * np.real(phi[None, :] * np.exp(-1j * np.outer(nodes, k))).sum(1)) / n_nodes
        return nodes, weights

    def describe(self) -> str:
        return f"mean {np.degrees(self.mean_rad):.3g} deg, SD {np.degrees(self.sd_rad):.3g} deg"

    def scalars(self) -> dict:
        """Output scalars: mean and SD of Omega in degrees (``mean_deg``, ``sd_deg``)."""
        return {"mean_deg": math.degrees(self.mean_rad), "sd_deg": math.degrees(self.sd_rad)}


@dataclass(frozen=True)
class GaussianFaraday(FaradayDistribution):
    """Gaussian Omega with mean ``mean`` and SD ``sd`` (rad), Men et al. (2021), Section III item 4.

    Circular moments ``exp(i k mean - k^2 sd^2 / 2)``: eq. (10) and its sine counterpart.
    """

    mean: float
    sd: float

    def __post_init__(self):
        if not (np.isfinite(self.mean) and np.isfinite(self.sd)) or self.sd < 0:
            raise PhysicsInputError(f"GaussianFaraday needs a finite mean and SD >= 0, got {self}")

    def circular_moment(self, k) -> np.ndarray:
        k = np.asarray(k, dtype=float)
        return np.exp(1j * k * self.mean - 0.5 * (k * self.sd) ** 2)

    def sample(self, rng, size) -> np.ndarray:
        return self.mean + self.sd * rng.standard_normal(size)

    @property
    def mean_rad(self) -> float:
        return float(self.mean)

    @property
    def sd_rad(self) -> float:
        return float(self.sd)


@dataclass(frozen=True)
class ConstantFaraday(FaradayDistribution):
    """A fixed Omega (rad)."""

    value: float

    def circular_moment(self, k) -> np.ndarray:
        return np.exp(1j * np.asarray(k, dtype=float) * self.value)

    def sample(self, rng, size) -> np.ndarray:
        return np.full(size, float(self.value))

    @property
    def mean_rad(self) -> float:
        return float(self.value)

    @property
    def sd_rad(self) -> float:
        return 0.0


@dataclass(frozen=True, eq=False)
class EmpiricalFaraday(FaradayDistribution):
    """Omega given by (weighted) samples, e.g. from a Faraday-rotation climatology.

    samples : Omega values (rad), 1-D. weights : non-negative, same length, normalised here
    (equal weights when omitted). Sampling draws from the samples with these probabilities.
    """

    samples: np.ndarray
    weights: np.ndarray | None = None
    label: str = "samples"
    _w: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        samples = np.asarray(self.samples, dtype=float).ravel()
        if samples.size == 0 or not np.all(np.isfinite(samples)):
            raise PhysicsInputError("EmpiricalFaraday needs at least one finite sample")
        if self.weights is None:
            w = np.full(samples.size, 1.0 / samples.size)
        else:
            w = np.asarray(self.weights, dtype=float).ravel()
            if w.shape != samples.shape or np.any(w < 0) or not np.isfinite(w).all() or w.sum() <= 0:
                raise PhysicsInputError(
                    "EmpiricalFaraday weights must be non-negative, finite, not all zero and one per sample"
                )
            w = w / w.sum()
        object.__setattr__(self, "samples", samples)
        object.__setattr__(self, "_w", w)

    def circular_moment(self, k) -> np.ndarray:
        k = np.asarray(k, dtype=float)
        return np.tensordot(np.exp(1j * k[..., None] * self.samples), self._w, axes=(-1, 0))

    def sample(self, rng, size) -> np.ndarray:
        return rng.choice(self.samples, size=size, p=self._w)

    @property
    def probabilities(self) -> np.ndarray:
        """The normalised weight of every sample."""
        return self._w

    def percentiles_deg(self, percents=PERCENTILES) -> dict:
        """``{percent: Omega (deg)}`` of the distribution."""
        vals = weighted_percentiles(self.samples, self._w, percents)
        return {float(p): float(np.degrees(v)) for p, v in zip(percents, vals)}

    @property
    def mean_rad(self) -> float:
        return float(np.dot(self._w, self.samples))

    @property
    def sd_rad(self) -> float:
        return float(np.sqrt(np.dot(self._w, (self.samples - self.mean_rad) ** 2)))
