"""Statistical model of the polarimetric system errors: crosstalk, channel imbalance, gain, noise.

Men et al. (2021), Section III, assumptions 1-3: the crosstalk terms delta_1..delta_4 and the
channel-imbalance terms epsilon_1, epsilon_2 (f_i = 1 + epsilon_i) are jointly zero-mean circular complex
Gaussian; the only correlated pairs are (delta_1, delta_3), (delta_2, delta_4) and (epsilon_1, epsilon_2);
the noise terms N_pq are independent, identically distributed, zero-mean circular with power sigma_n.
Variances and covariances here may take any values (unequal variances, complex correlations).
"""

from __future__ import annotations

import cmath
import functools
import math
from dataclasses import dataclass, replace

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.units import db_to_linear

_LN10_OVER_10 = np.log(10.0) / 10.0  # d(ln G)/d(G in dB)


@dataclass(frozen=True)
class SystemErrorSamples:
    """Realisations of the system errors, one row per realisation.

    delta : (n, 4) complex crosstalk (delta_1..delta_4). f : (n, 2) complex channel imbalance
    (f_1, f_2). gain : (n,) real amplitude gain A (the phase e^{j phi} does not affect powers).
    """

    delta: np.ndarray
    f: np.ndarray
    gain: np.ndarray


@dataclass(frozen=True)
class SystemErrorModel:
    """Second-order statistics of the system errors and the noise power.

    The crosstalk and channel-imbalance statistics are written as a level times a shape, so that
    trade-off curves and margins can scale a level while keeping the correlation structure:

    crosstalk_level : V_delta, reference variance of the crosstalk terms (E|delta|^2).
    crosstalk_relative : (r_1, r_2, r_3, r_4), so that ``V_i = r_i V_delta`` (all 1 for the paper's
        equal variances, eqs. 13-14).
    crosstalk_rho13, crosstalk_rho24 : complex correlation coefficients of (delta_1, delta_3) and
        (delta_2, delta_4): ``C_13 = <delta_1 delta_3*> = rho_13 sqrt(V_1 V_3)`` (eq. 7).
    imbalance_level, imbalance_relative, imbalance_rho : the same for (epsilon_1, epsilon_2) (eq. 8).
    noise_power : sigma_n, noise power in each of the four measured channels (m^2/m^2, i.e. the NESZ as
        a linear ratio when the scene covariance is in backscattering-coefficient units).
    gain_offset_db, gain_sd_db : absolute radiometric gain |A|^2 in dB ~ N(offset, sd^2) (Quegan et al.
        2018, eq. 11; not part of Men et al. 2021, where A = 1). Noise is added after the gain.
    """

    crosstalk_level: float = 0.0
    imbalance_level: float = 0.0
    crosstalk_relative: tuple = (1.0, 1.0, 1.0, 1.0)
    crosstalk_rho13: complex = 0.0
    crosstalk_rho24: complex = 0.0
    imbalance_relative: tuple = (1.0, 1.0)
    imbalance_rho: complex = 0.0
    noise_power: float = 0.0
    gain_offset_db: float = 0.0
    gain_sd_db: float = 0.0

    def __post_init__(self):
        # plain Python on a dozen numbers: a sweep builds one model per distinct instrument (thousands)
        rel = _floats(self.crosstalk_relative, 4)
        rel_e = _floats(self.imbalance_relative, 2)
        if rel is None or rel_e is None:
            raise PhysicsInputError("need 4 relative crosstalk variances and 2 relative channel-imbalance variances")
        numbers = (*rel, *rel_e, *(float(x) for x in (self.crosstalk_level, self.imbalance_level, self.noise_power,
                                                         self.gain_sd_db)))
        if not all(math.isfinite(x) and x >= 0 for x in numbers):
            raise PhysicsInputError(
                "system-error levels, relative variances, noise power and gain SD must be finite and >= 0"
            )
        for name in ("crosstalk_rho13", "crosstalk_rho24", "imbalance_rho"):
            rho = complex(getattr(self, name))
            if not cmath.isfinite(rho) or abs(rho) > 1 + 1e-12:
                raise PhysicsInputError(f"{name}: correlation coefficient magnitude {abs(rho):.4g} is above 1")
            object.__setattr__(self, name, rho)
        object.__setattr__(self, "crosstalk_relative", rel)
        object.__setattr__(self, "imbalance_relative", rel_e)

    # Variances and covariances as in eqs. (7)-(8) -------------------------------------------
    @property
    def crosstalk_variance(self) -> tuple:
        """(V_1, V_2, V_3, V_4)."""
        return tuple(self.crosstalk_level * r for r in self.crosstalk_relative)

    @property
    def imbalance_variance(self) -> tuple:
        """(V_eps1, V_eps2)."""
        return tuple(self.imbalance_level * r for r in self.imbalance_relative)

    crosstalk_cov13 = property(lambda self: _covariance(self.crosstalk_rho13, self.crosstalk_variance, 0, 2))
    crosstalk_cov24 = property(lambda self: _covariance(self.crosstalk_rho24, self.crosstalk_variance, 1, 3))
    imbalance_cov12 = property(lambda self: _covariance(self.imbalance_rho, self.imbalance_variance, 0, 1))

    @functools.cached_property
    def unit_structure(self) -> tuple:
        """(V_i, C_13, C_24, V_eps_i, C_eps12) for unit levels V_delta = V_eps = 1: the correlation
        structure alone, which the analytic kernels scale by any levels."""
        # the properties' formulas at levels 1.0, without building that model (a block asks for thousands)
        v = tuple(1.0 * r for r in self.crosstalk_relative)
        ve = tuple(1.0 * r for r in self.imbalance_relative)
        return (np.asarray(v), _covariance(self.crosstalk_rho13, v, 0, 2), _covariance(self.crosstalk_rho24, v, 1, 3),
                np.asarray(ve), _covariance(self.imbalance_rho, ve, 0, 1))

    def with_levels(self, crosstalk=None, imbalance=None, noise_power=None) -> SystemErrorModel:
        """Same structure with other levels (variances) or noise power."""
        return replace(
            self,
            crosstalk_level=self.crosstalk_level if crosstalk is None else float(crosstalk),
            imbalance_level=self.imbalance_level if imbalance is None else float(imbalance),
            noise_power=self.noise_power if noise_power is None else float(noise_power),
        )

    @property
    def gain_power_moments(self) -> tuple[float, float]:
        """``(E[|A|^2], E[|A|^4])`` for |A|^2 lognormal with dB mean/SD (gain_offset_db, gain_sd_db)."""
        mu, sd = _LN10_OVER_10 * self.gain_offset_db, _LN10_OVER_10 * self.gain_sd_db
        return float(np.exp(mu + sd**2 / 2)), float(np.exp(2 * mu + 2 * sd**2))

    @property
    def has_gain_error(self) -> bool:
        return self.gain_offset_db != 0.0 or self.gain_sd_db != 0.0

    def scalars(self) -> dict:
        """Output scalars (``system.*``): V_delta and V_eps (variances) and the noise power sigma_n (m^2/m^2)."""
        return {"crosstalk_variance": self.crosstalk_level, "imbalance_variance": self.imbalance_level,
                "noise_power": self.noise_power}

    def sample(self, rng: np.random.Generator, n: int) -> SystemErrorSamples:
        """Draw ``n`` joint realisations of (delta, f, gain) under the Gaussian model of Section III."""
        v = self.crosstalk_variance
        delta = np.empty((4, n), complex)  # rows filled in place, handed out transposed: (n, 4), no stacking copy
        imbalance = np.empty((2, n), complex)
        _correlated_pair(rng, n, v[0], v[2], self.crosstalk_cov13, out=(delta[0], delta[2]))
        _correlated_pair(rng, n, v[1], v[3], self.crosstalk_cov24, out=(delta[1], delta[3]))
        _correlated_pair(rng, n, *self.imbalance_variance, self.imbalance_cov12, out=imbalance)
        imbalance.real += 1.0  # f = 1 + epsilon: the imaginary parts + 0, unchanged
        if self.has_gain_error:
            gain = np.sqrt(db_to_linear(self.gain_offset_db + self.gain_sd_db * rng.standard_normal(n)))
        else:
            gain = np.ones(n)
        return SystemErrorSamples(delta=delta.T, f=imbalance.T, gain=gain)


def _covariance(rho: complex, variances: tuple, i: int, j: int) -> complex:
    """The covariance rho sqrt(V_i V_j) of terms i and j with correlation coefficient rho (eqs. 7-8)."""
    return rho * np.sqrt(variances[i] * variances[j])


def _correlated_pair(rng, n, var_a, var_b, cov_ab, out=None):
    """n draws of (a, b) zero-mean circular complex Gaussian, E|a|^2=var_a, E|b|^2=var_b, E[a b*]=cov_ab.

    ``out``: two contiguous complex arrays of length n to fill (rows of the caller's sample arrays), else new
    ones. ``a = sqrt(V_a) xi_a`` and ``b = (C*/V_a) a + sqrt(V_b - |C|^2/V_a) xi_b`` with ``xi = (x + j y)/sqrt(2)``
    for standard normal x, y: the real parts (x_a, x_b) drawn first, then the imaginary parts."""
    xy = rng.standard_normal((2, 2, n))  # [real, imaginary] x [a, b]
    # A complex times a real is its two parts times the real: the draws are scaled in place as reals (the same
    # values, bit for bit, as the complex products) and written straight into a's and b's parts.
    xy *= 1 / np.sqrt(2)
    a, b = np.empty((2, n), complex) if out is None else out
    np.multiply(xy[:, 0], np.sqrt(var_a), out=_parts(a))
    if var_a > 0:
        rho = np.conj(cov_ab) / var_a  # b = (C*/V_a) a + residual gives E[a b*] = C
        np.multiply(rho, a, out=b)
        residual = xy[:, 1]
        residual *= np.sqrt(max(var_b - abs(cov_ab) ** 2 / var_a, 0.0))
        b_parts = _parts(b)
        b_parts += residual
    else:
        np.multiply(xy[:, 1], np.sqrt(var_b), out=_parts(b))
    return a, b


def _parts(z: np.ndarray) -> np.ndarray:
    """The real and imaginary parts of a contiguous complex (n,) array, as one writable (2, n) view."""
    return z.view(np.float64).reshape(-1, 2).T


def _floats(values, count: int) -> tuple | None:
    """``values`` as a tuple of ``count`` floats, None if it is not a flat sequence of that many numbers."""
    try:
        out = tuple(float(x) for x in values)
    except (TypeError, ValueError):
        return None
    return out if len(out) == count else None
