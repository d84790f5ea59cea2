"""Statistics for comparing the Monte Carlo with the analytic moments (Men et al. 2021, eq. 18, Table II).

The relative differences of eq. (18) come with their sampling standard errors, so "agreement" is a
statistical statement: ``|difference| <= k * standard error``. The errors of the M system-error
realisations are independent; the N noise realisations of one system-error realisation are not, so the
standard errors are computed over the M rows (delta method for the variance).
"""

from __future__ import annotations

import numpy as np


def sample_moments(errors: np.ndarray) -> dict:
    """Mean, variance and their standard errors from an (M, N) array of simulated errors."""
    e = np.asarray(errors, dtype=float)
    if e.ndim == 1:
        e = e[:, None]
    m = e.shape[0]
    centre = e.mean()
    d = e - centre  # centred for numerical stability
    r1, r2 = d.mean(axis=1), (d**2).mean(axis=1)
    mu1, mu2 = r1.mean(), r2.mean()
    variance = mu2 - mu1**2
    cov = np.cov(np.stack([r1, r2]), ddof=1) if m > 1 else np.zeros((2, 2))
    var_of_var = (cov[1, 1] + 4 * mu1**2 * cov[0, 0] - 4 * mu1 * cov[0, 1]) / m
    return {
        "mean": float(centre + mu1),
        "variance": float(variance),
        "mean_se": float(np.sqrt(cov[0, 0] / m)),
        "variance_se": float(np.sqrt(max(var_of_var, 0.0))),
        "samples": int(e.size),
        "realisations": int(m),
    }


def compare_with_analytic(analytic_mean: float, analytic_variance: float, errors: np.ndarray,
                          looks: int | None = None, fixed_scene: bool = False) -> dict:
    """Relative differences (MC - analytic) / analytic of the bias and variance, eq. (18a-b), with SEs.

    fixed_scene : the Monte Carlo used one scene of ``looks`` pixels for all realisations (the paper's
        design). Its sample covariance differs from the population one by O(1/sqrt(L)), which shifts
        the simulated variance by up to about 2/sqrt(L) relative (the variance is quadratic in the scene
        powers); this is added to the variance's uncertainty. (The bias is dominated by noise, whose
        mean the scene does not change.)
    """
    s = sample_moments(errors)
    bias_se = s["mean_se"] / abs(analytic_mean)
    var_se = s["variance_se"] / analytic_variance
    if fixed_scene and looks:
        var_se = float(np.hypot(var_se, 2.0 / np.sqrt(looks)))
    return {
        "bias_rel_diff": (s["mean"] - analytic_mean) / analytic_mean,
        "bias_rel_se": float(bias_se),
        "var_rel_diff": (s["variance"] - analytic_variance) / analytic_variance,
        "var_rel_se": float(var_se),
    }


def sample_covariance_moments(errors: np.ndarray) -> dict:
    """Mean vector and covariance matrix of simulated channel errors (M, N, C), with standard errors.

    As ``sample_moments`` for several channels: rows (system-error realisations) are independent, the N
    noise draws of a row are not, so the standard errors come from the M row statistics
    ``r1 = mean_n d``, ``r2 = mean_n d d^T`` (delta method for the covariance).
    """
    e = np.asarray(errors, dtype=float)
    if e.ndim == 2:
        e = e[:, None, :]
    m = e.shape[0]
    centre = e.reshape(-1, e.shape[-1]).mean(0)
    d = e - centre
    r1 = d.mean(1)  # (M, C)
    r2 = np.einsum("mnp,mnq->mpq", d, d) / e.shape[1]  # (M, C, C)
    mu = r1.mean(0)
    cov = r2.mean(0) - np.outer(mu, mu)
    z = r2 - mu[None, None, :] * r1[:, :, None] - mu[None, :, None] * r1[:, None, :]
    return {
        "mean": centre + mu,
        "covariance": cov,
        "mean_se": r1.std(0, ddof=1) / np.sqrt(m),
        "covariance_se": z.std(0, ddof=1) / np.sqrt(m),
        "realisations": m,
    }
