"""Distribution of the relative AGB error implied by an error in sigma_hv.

Men et al. (2021), Section V-B: the sigma_hv error e is close to Gaussian (Fig. 2), so exceedance
probabilities follow from its mean b and SD sigma_e (eq. 19); through the power law (eqs. 15-16) the
relative AGB error ``q = (1 + e / sigma_hv)^p - 1`` is a monotone function of e, so its quantiles are
the images of the quantiles of e. Monte Carlo samples of e give the same quantities without the
Gaussian approximation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

from e2esim.retrieval.power_law import agb_relative_error, sigma_relative_error

_HERMITE_NODES, _HERMITE_WEIGHTS = np.polynomial.hermite_e.hermegauss(64)
_HERMITE_WEIGHTS = _HERMITE_WEIGHTS / np.sqrt(2 * np.pi)  # probabilists' Hermite: weights sum to 1


def standard_normal_quantile(probability):
    """z with P(Z <= z) = probability (e.g. 0.99865 -> 3.00, Men et al. 2021, Table III)."""
    return special.ndtri(probability)


@dataclass(frozen=True)
class AGBError:
    """Relative AGB error ``q = AGB_hat / AGB - 1`` implied by the sigma_hv error.

    exponent : power-law exponent p. sigma_hv : true sigma_hv (m^2/m^2).
    error_mean, error_sd : mean and SD of the sigma_hv error e (m^2/m^2) from the analytic model, or
        None. samples : Monte Carlo relative AGB errors (flat array), or None.
    """

    exponent: float
    sigma_hv: float
    error_mean: float | None = None
    error_sd: float | None = None
    samples: np.ndarray | None = None

    @classmethod
    def from_sigma_errors(cls, exponent, sigma_hv, error_mean=None, error_sd=None, relative_samples=None):
        """From the analytic mean/SD of e (m^2/m^2) and/or Monte Carlo relative errors e / sigma_hv."""
        samples = None
        if relative_samples is not None:
            samples = agb_relative_error(np.ravel(relative_samples), exponent)
        return cls(exponent, sigma_hv, error_mean, error_sd, samples)

    def has(self, basis: str) -> bool:
        return (self.error_mean is not None) if basis == "analytic" else (self.samples is not None)

    # Quantiles, exceedance, RMSE ----------------------------------------------------------
    def quantile(self, probability, basis: str = "analytic"):
        """Relative AGB error q_P with P(q <= q_P) = probability."""
        probability = np.asarray(probability, dtype=float)
        if basis == "analytic":
            e = self.error_mean + standard_normal_quantile(probability) * self.error_sd
            return agb_relative_error(e / self.sigma_hv, self.exponent)
        return np.quantile(self.samples, probability)

    def exceedance(self, bound, side: str = "over", basis: str = "analytic"):
        """P(q > bound) for side "over" (bound > 0), P(q < -bound) for side "under" (bound > 0)."""
        level = bound if side == "over" else -bound
        if basis == "analytic":
            threshold = sigma_relative_error(level, self.exponent) * self.sigma_hv  # f sigma_hv, eq. (19)
            z = (threshold - self.error_mean) / self.error_sd if self.error_sd > 0 else np.inf * np.sign(
                threshold - self.error_mean
            )
            return float(special.ndtr(-z) if side == "over" else special.ndtr(z))
        return float(np.mean(self.samples > level) if side == "over" else np.mean(self.samples < level))

    def rmse(self, basis: str = "analytic") -> float:
        """Root-mean-square relative AGB error sqrt(E[q^2]) (bias and spread together)."""
        if basis == "analytic":
            e = self.error_mean + self.error_sd * _HERMITE_NODES
            q = agb_relative_error(e / self.sigma_hv, self.exponent)
            return float(np.sqrt(np.dot(_HERMITE_WEIGHTS, q**2)))
        return float(np.sqrt(np.mean(self.samples**2)))

    def mean(self, basis: str = "analytic") -> float:
        """Mean relative AGB error E[q]."""
        if basis == "analytic":
            e = self.error_mean + self.error_sd * _HERMITE_NODES
            return float(np.dot(_HERMITE_WEIGHTS, agb_relative_error(e / self.sigma_hv, self.exponent)))
        return float(np.mean(self.samples))


def binomial_interval(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """Clopper-Pearson interval for a proportion (exceedance probability from Monte Carlo counts)."""
    from scipy import stats  # imported here: scipy.stats costs a second at start-up

    alpha = 1 - confidence
    lo = stats.beta.ppf(alpha / 2, successes, trials - successes + 1) if successes > 0 else 0.0
    hi = stats.beta.ppf(1 - alpha / 2, successes + 1, trials - successes) if successes < trials else 1.0
    return float(lo), float(hi)
