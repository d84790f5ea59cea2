"""What an error term does to the backscatter estimates: the equations of the shipped wrappers.

An effect acts on the estimates of every channel of an error model at once. With ``e_p = sigma_hat_p - sigma_p``
of mean ``m_p`` and covariance ``C_pq`` (the wrapped model), ``a_p = sigma_p + m_p = E[sigma_hat_p]`` and an
effect independent of the wrapped errors, the new errors have the exact moments each class states. ``level``
is the effect's one scalable level (a variance or a power, linear units): requirement margins vary it, and a
level of 0 (with nothing else set) removes the effect. Arrays broadcast: a level of shape S gives moments of
shape S + (C,) and S + (C, C).

Monte Carlo: ``draw`` takes the effect's random numbers from the case's generator once (in the stage's
``forward``), ``sampled`` applies them to relative errors ``x_p = e_p / sigma_p`` of shape (M, N, C).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

_LN10_10 = math.log(10.0) / 10.0  # d ln(g) / d(g in dB)


def _lv(level, extra: int) -> np.ndarray:
    """``level`` with ``extra`` trailing axes, to broadcast against (..., C) or (..., C, C)."""
    return np.asarray(level, dtype=float)[(...,) + (None,) * extra]


@dataclass(frozen=True)
class Effect(ABC):
    """One error term's action on the estimates (module docstring). source : its name (a level and a source of
    the wrapped model). level : its current level. description : one line for contribution tables."""

    source: str
    level: float
    description: str = ""
    draws: tuple | None = None
    outputs: tuple = ()
    """(name, value) pairs: output scalars the term reports beside the model's (e.g. the notched impulse
    response's metrics of ``e2esim.error_terms.rfi_modules``)."""

    stacked_fields: ClassVar[dict | None] = None
    """{field: axes}: the numbers of the effect that may differ between cases whose moments a block evaluates
    together (``e2esim.error_terms.effect_stack``), each with its axes after the level's (1 for a tuple, or for a
    number the equations combine with a tuple's axis; else 0). Only a class's own declaration counts: None (the
    default, a plug-in's effect) evaluates each distinct effect alone, with the same numbers."""

    @abstractmethod
    def joint(self, mean, cov, values, level):
        """(mean (..., C), covariance (..., C, C)) of the new errors from those of the wrapped model."""

    @abstractmethod
    def draw(self, rng, shape: tuple) -> Effect:
        """This effect with its random numbers for samples of shape (M, N, C) drawn from ``rng``."""

    @abstractmethod
    def sampled(self, relative, values) -> np.ndarray:
        """New relative errors from relative errors (M, N, C) of the wrapped model (needs ``draws``)."""

    @property
    def active(self) -> bool:
        """Whether the effect changes anything (False: ``without`` its source is the model itself)."""
        return self.level != 0.0

    def removed(self) -> Effect:
        """The effect with nothing left (its source taken away)."""
        return replace(self, level=0.0, draws=None)


@dataclass(frozen=True)
class IntensityFactor(Effect):
    """A factor ``g`` multiplying every channel's intensity, independent of everything else, with
    ``E[g] = mu(level)`` and ``Var[g] = V(level)`` (``factor_moments``). Then, exactly (expectation of a product
    of independent variables),

        E[e'_p] = m_p mu + sigma_p (mu - 1),
        Cov[e'_p, e'_q] = C_pq E[g^2] + a_p a_q V,      E[g^2] = V + mu^2,

    and ``x'_p = (1 + x_p) g - 1`` per realisation. ``unit_mean``: E[g] = 1 at every level."""

    @abstractmethod
    def factor_moments(self, level) -> tuple:
        """(E[g], Var[g]) at ``level`` (broadcast)."""

    @abstractmethod
    def factors(self, rng, shape: tuple) -> np.ndarray:
        """Draws of g, shape ``shape`` (M, N)."""

    def joint(self, mean, cov, values, level):
        mu, var = self.factor_moments(level)
        mu1, var1 = _lv(mu, 1), _lv(var, 2)
        a = values + mean
        new_mean = mean * mu1 + values * (mu1 - 1.0)
        second = var1 + _lv(mu, 2) * _lv(mu, 2)
        return new_mean, cov * second + a[..., :, None] * a[..., None, :] * var1

    def draw(self, rng, shape: tuple) -> Effect:
        return replace(self, draws=(self.factors(rng, shape[:2]),)) if self.active else self

    def sampled(self, relative, values) -> np.ndarray:
        return (1.0 + relative) * self.draws[0][..., None] - 1.0


@dataclass(frozen=True)
class GammaFactor(IntensityFactor):
    """A factor of mean 1 and variance ``level``, gamma distributed (shape 1/V, scale V): the mean intensity of
    independent Nakagami-m patterns, e.g. amplitude scintillation (Fremouw, Livingston & Miller 1980)."""

    stacked_fields: ClassVar[dict] = {}

    def factor_moments(self, level):
        return np.ones_like(np.asarray(level, dtype=float)), np.asarray(level, dtype=float)

    def factors(self, rng, shape):
        return rng.gamma(1.0 / self.level, self.level, shape)


@dataclass(frozen=True)
class FixedGain(IntensityFactor):
    """A known gain loss: every channel's intensity multiplied by ``g = 1 - level`` (no spread), e.g. the energy a
    notch filter removes from a distributed target's spectrum when the processor does not restore it
    (docs/theory/rfi.md). With E[g] = 1 - level and Var[g] = 0 the equations of ``IntensityFactor`` give
    E[e'_p] = m_p g - sigma_p level and Cov[e'_p, e'_q] = g^2 C_pq."""

    stacked_fields: ClassVar[dict] = {}

    def factor_moments(self, level):
        lv = np.asarray(level, dtype=float)
        return 1.0 - lv, np.zeros_like(lv)

    def factors(self, rng, shape):
        return np.full(shape, 1.0 - self.level)


@dataclass(frozen=True)
class LogNormalGain(IntensityFactor):
    """A gain error ``g = 10^(G/10)``, G ~ N(offset_db, sd_db^2) in dB: ln g ~ N(mu, s^2) with mu = offset_db
    ln(10)/10 and s = sd_db ln(10)/10; ``level`` = s^2 (the variance of ln g). Log-normal moments (Johnson, Kotz &
    Balakrishnan 1994, Continuous Univariate Distributions 1, eq. 14.8a):

        E[g] = exp(mu + s^2 / 2),      Var[g] = exp(2 mu + s^2) (exp(s^2) - 1).
    """

    stacked_fields: ClassVar[dict] = {"offset_db": 0}

    offset_db: float = 0.0

    @property
    def active(self) -> bool:
        return self.level != 0.0 or self.offset_db != 0.0

    def removed(self) -> Effect:
        return replace(self, level=0.0, offset_db=0.0, draws=None)

    def factor_moments(self, level):
        s2 = np.asarray(level, dtype=float)
        mu = self.offset_db * _LN10_10
        return np.exp(mu + s2 / 2.0), np.exp(2.0 * mu + s2) * np.expm1(s2)

    def factors(self, rng, shape):
        return np.exp(self.offset_db * _LN10_10 + math.sqrt(self.level) * rng.standard_normal(shape))


@dataclass(frozen=True)
class AddedPower(Effect):
    """Circular Gaussian noise of power ``N_p = level * scale_p`` added, independently, to each channel in each of
    the L looks of its estimate (e.g. a noise floor, residual interference, quantisation noise). With the signal
    looks ``s_k`` and noise looks ``n_k``, ``sigma_hat' = sigma_hat + nu``, ``nu = (1/L) sum(|n_k|^2 + 2 Re s_k
    n_k^*)``: E[nu] = N, Var[nu] = (N^2 + 2 a N) / L, uncorrelated with sigma_hat and across channels (the speckle
    and noise variance (sigma + N)^2 / L of Ahmed et al. 2014, eq. 21, less the signal's sigma^2 / L). So

        E[e'_p] = m_p + N_p (0 when the power is subtracted: ``subtracted``),
        Cov[e'_p, e'_q] = C_pq + delta_pq (N_p^2 + 2 a_p N_p) / L.

    Per realisation ``nu = N G + sqrt(2 N max(sigma_hat, 0) / L) Z``, G ~ Gamma(L, 1/L) (the mean of L exponential
    noise intensities), Z ~ N(0, 1) (the cross term, Gaussian given the signal)."""

    stacked_fields: ClassVar[dict] = {"scale": 1, "looks": 1}

    scale: tuple = (1.0,)
    looks: int = 1
    subtracted: bool = False

    def _power(self, level, values):
        return _lv(level, 1) * np.asarray(self.scale, dtype=float) * np.ones_like(values)

    def joint(self, mean, cov, values, level):
        n = self._power(level, values)
        new_mean = mean if self.subtracted else mean + n
        added = (n * n + 2.0 * (values + mean) * n) / self.looks
        return new_mean, cov + added[..., :, None] * np.eye(np.shape(values)[-1])

    def draw(self, rng, shape: tuple) -> Effect:
        if not self.active:
            return self
        return replace(self, draws=(rng.gamma(self.looks, 1.0 / self.looks, shape), rng.standard_normal(shape)))

    def sampled(self, relative, values) -> np.ndarray:
        n = self._power(self.level, values)
        estimate = np.maximum(values * (1.0 + relative), 0.0)
        gamma, z = self.draws
        nu = n * gamma + np.sqrt(2.0 * n * estimate / self.looks) * z
        return relative + (nu - n if self.subtracted else nu) / values


@dataclass(frozen=True)
class ExtraVariance(Effect):
    """A zero-mean random error of relative variance ``level`` (r^2), Gaussian, independent of everything else and
    across channels: ``e'_p = e_p + sigma_p r Z_p``. Variances of independent errors add (Papoulis & Pillai 2002,
    Probability, Random Variables and Stochastic Processes, eq. 7-44):

        E[e'_p] = m_p,      Cov[e'_p, e'_q] = C_pq + delta_pq sigma_p^2 r^2.
    """

    stacked_fields: ClassVar[dict] = {}

    def joint(self, mean, cov, values, level):
        added = _lv(level, 1) * values * values
        return mean + 0.0 * added, cov + added[..., :, None] * np.eye(np.shape(values)[-1])

    def draw(self, rng, shape: tuple) -> Effect:
        return replace(self, draws=(rng.standard_normal(shape),)) if self.active else self

    def sampled(self, relative, values) -> np.ndarray:
        return relative + math.sqrt(self.level) * self.draws[0]


__all__ = ["AddedPower", "Effect", "ExtraVariance", "FixedGain", "GammaFactor", "IntensityFactor", "LogNormalGain"]
