"""Standard errors of what a Monte Carlo reports: means, root-mean-squares, proportions and quantiles.

The samples of a relative AGB error come as an (M, N) array flattened row by row: M independent realisations
of the system errors, each with N noise realisations that share it (``simulation.noise_realisations``; N = 1
by default). Every estimator here is therefore computed from the M realisation means, the standard error of
a mean from clustered data (cluster-robust: Cochran 1977, Section 9.2; for N = 1 the ordinary s / sqrt(M)):

* mean: ``SE = sd_g(mean of realisation g) / sqrt(M)``;
* proportion (exceedance probability, saturated fraction): the same for the indicator, which for N = 1 is the
  binomial ``sqrt(p (1 - p) / M)`` (with M - 1);
* root-mean-square ``R = sqrt(m2)``, m2 = mean q^2: the delta method, ``SE(R) = SE(m2) / (2 R)``;
* quantile q_P: the order-statistic interval (Woodruff 1952): the confidence interval of the empirical
  distribution function at q_P, ``P +- z SE(F)``, mapped back through the empirical quantile function,
  ``[Q(P - z SE(F)), Q(P + z SE(F))]`` with z = 1.96; its half-width / z is reported as the standard error.
  ``SE(F) = sqrt(P (1 - P) / (M N)) sqrt(deff)``: the binomial standard error of the empirical distribution
  function of M N samples, times the design effect deff of the clustering (the ratio of the clustered to the
  independent variance of the indicator at q_P; 1 for N = 1). For independent samples this is the classical
  distribution-free interval from the binomial distribution of the number of samples below q_P (David &
  Nagaraja 2003, Section 7.1). Distribution-free, it needs no estimate of the density at q_P, which the
  asymptotic formula ``sqrt(P (1 - P) / n) / f(q_P)`` does, and which is poorly known in the tails (the
  99.865 % quantile of 4000 samples has five samples beyond it). Where P + z SE(F) passes 1 the upper end is
  the largest sample, and the interval (and the standard error) is then a lower bound.
"""

from __future__ import annotations

import numpy as np

Z95 = 1.959963984540054
"""Two-sided 95 % standard normal quantile: the interval of a quantile is P +- Z95 SE(F)."""


def realisation_means(values: np.ndarray, realisations: int) -> np.ndarray:
    """(M,) means of the values of each realisation (``values`` flat, row by row; M = ``realisations``, or every
    value its own realisation when 0 or when M does not divide the number of values)."""
    v = np.asarray(values, dtype=float).reshape(-1)
    if realisations and v.size % realisations == 0:
        return v.reshape(realisations, -1).mean(axis=1)
    return v


def mean_standard_error(values: np.ndarray, realisations: int = 0) -> float:
    """Standard error of the mean of ``values`` (cluster-robust over realisations)."""
    g = realisation_means(values, realisations)
    return float(np.std(g, ddof=1) / np.sqrt(g.size)) if g.size > 1 else float("inf")


def rmse_standard_error(values: np.ndarray, realisations: int = 0) -> float:
    """Standard error of sqrt(mean(values^2)) by the delta method."""
    v = np.asarray(values, dtype=float)
    rms = float(np.sqrt(np.mean(v**2)))
    if rms == 0:
        return 0.0
    return mean_standard_error(v**2, realisations) / (2.0 * rms)


def proportion_standard_error(indicator: np.ndarray, realisations: int = 0) -> float:
    """Standard error of the fraction of True in ``indicator`` (cluster-robust; binomial for one value per
    realisation)."""
    return mean_standard_error(np.asarray(indicator, dtype=float), realisations)


def quantile_interval(values: np.ndarray, probability, realisations: int = 0, z: float = Z95):
    """(lower, upper, standard error) of the empirical quantiles at ``probability`` (any shape): the
    order-statistic (Woodruff) interval of the module docstring; each of the shape of ``probability``."""
    v = np.asarray(values, dtype=float).reshape(-1)
    p = np.asarray(probability, dtype=float)
    n = v.size
    q = np.quantile(v, p)
    below = v[:, None] <= np.ravel(q)[None, :]  # (n, k) indicators at each quantile
    iid = below.var(axis=0)
    if realisations and n % realisations == 0 and n // realisations > 1:
        groups = below.reshape(realisations, -1, below.shape[1]).mean(axis=1)
        clustered = groups.var(axis=0) / realisations  # variance of the mean indicator over realisations
        deff = np.where(iid > 0, clustered / np.where(iid > 0, iid / n, 1.0), 1.0)
    else:
        deff = np.ones(below.shape[1])
    se_f = np.sqrt(np.ravel(p) * (1.0 - np.ravel(p)) / n * deff)
    lower = np.quantile(v, np.clip(np.ravel(p) - z * se_f, 0.0, 1.0)).reshape(p.shape)
    upper = np.quantile(v, np.clip(np.ravel(p) + z * se_f, 0.0, 1.0)).reshape(p.shape)
    return lower, upper, (upper - lower) / (2.0 * z)
