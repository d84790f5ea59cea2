"""The multi-channel AGB estimate of the BIOMASS level-2 processor and its error from correlated channel errors
(docs/theory/co-pol-error.md, sec. 8).

Model (BIOMASS AGB ATBD, eqs. 4.8-4.10; Soja et al. 2021): one power law per channel,
``sigma0_pq = L_pq AGB^alpha_pq cos^n_pq(theta)``, linear in decibels. Estimate: the AGB minimising the
equal-weight least-squares cost in dB over the channels used, with the parameters fixed,

    J(w) = sum_pq (s_pq - l_pq - n_pq c - alpha_pq w)^2,   s = 10 lg sigma_hat, w = 10 lg AGB, c = 10 lg cos theta,

whose minimiser is the alpha^2-weighted mean of the per-channel estimates (ATBD eqs. 4.26, 4.31, 4.37):
``ln AGB_hat = sum_pq c_pq (ln sigma_hat_pq - ln L_pq - n_pq ln cos theta)``, ``c = alpha / (alpha . alpha)``.
That is ``LogLinearModel.invert`` with an identity residual covariance (``e2esim.retrieval.loglinear``).
With true powers on the model, the log AGB error is exactly

    y = ln(AGB_hat / AGB) = sum_pq c_pq ln(1 + x_pq),   x_pq = e_pq / sigma_pq     (co-pol eq. 8.2)

so the estimate is unbiased on error-free data. Its moments follow from the joint moments of the channel
errors by the delta method around the mean, for jointly Gaussian x with mean mu and covariance S
(co-pol eq. 8.3; g_p = 1 / (1 + mu_p), the derivatives of ln(1 + x) at mu):

    E y = sum_p c_p [ln(1 + mu_p) - g_p^2 S_pp / 2]                                 (to first order in S)
    Var y = sum_pq c_p c_q [g_p g_q S_pq + g_p^2 g_q^2 S_pq^2 / 2
                            + (g_p g_q^3 S_qq + g_p^3 g_q S_pp) S_pq]            (to second order in S)

The Monte Carlo applies the actual inversion to simulated powers.

A random-error budget (speckle and noise, temporal, calibration, area projection; Ahmed et al. 2014, eq. 20)
adds zero-mean relative errors r_p independent of the systematic ones, with covariance R = sum_g R_g
(``combine.channel_covariance``: speckle correlated between channels as the estimate's speckle correlation, the
other terms common to all channels), so y = sum c_p ln(1 + x_p + r_p) has the moments of eq. (8.3) with the
covariance S + R (co-pol eq. 8.4); the Monte Carlo adds correlated Gaussian draws of r to the simulated x.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.error_model import Contribution, DerivedErrorModel, Moments, MultiChannelErrorModel
from e2esim.errors import PhysicsInputError
from e2esim.retrieval.agb_error import AGBContribution
from e2esim.retrieval.combine import BUDGET_DESCRIPTIONS, channel_covariance, correlated_normal

CHANNELS = ("hh", "hv", "vv")

TABLE1_ALPHA = {
    # biome: (alpha_hh, alpha_hv, alpha_vv)
    "boreal": (0.8039, 1 / 2.2, 0.0612),
    "tropical": (0.8039, 1 / 1.9, 0.0612),
}
"""AGB exponents alpha_pq of the per-channel power laws. HV: 1/p with p = 2.2 (boreal) and 1.9 (tropical), the
exponents of Men et al. (2021), Table III (from Schlund et al. 2018). HH and VV: not published for the
prototype (Soja et al. 2021 and Banda et al. 2020 give no per-site values that could be read): fitted here by
log-log least squares to the three boreal forests of Men et al. (2021), Table I (residuals below 0.02 % for HH,
0.6 % for VV); the two tropical forests of Table I (338 and 341 t/ha) cannot determine an exponent, so the
boreal fit is used for them too. The fitted VV exponent is small: VV carries little AGB information."""

PROTOTYPE_AGB_RANGE_T_HA = (1.0, 600.0)
"""AGB bounds of the BIOMASS prototype's estimates (BioPAL configuration, Soja et al. 2021 style processor)."""


@dataclass(frozen=True)
class LogErrorMap:
    """y = ln(AGB_hat / AGB) -> relative AGB error q = e^y - 1 (the ``RelativeErrorMap`` interface used by
    ``AGBError`` and the requirements, for an error already on the log-AGB scale)."""

    def __call__(self, y):
        return np.expm1(np.asarray(y, dtype=float))

    def threshold(self, level: float, memo=None) -> float:
        """y at which q reaches ``level`` (> -1); in closed form (``memo`` is not needed)."""
        return float(np.log1p(level))

    def saturation_threshold(self) -> float:
        return np.inf

    def local_exponent(self) -> float:
        return 1.0


def log_agb_moments(weights, mean, covariance) -> tuple:
    """Co-pol eq. (8.3): mean and variance of y = sum c_p ln(1 + x_p) for jointly Gaussian relative errors x with
    mean (..., C) and covariance (..., C, C); weights c (C,)."""
    c = np.asarray(weights, dtype=float)
    mu = np.asarray(mean, dtype=float)
    s = np.asarray(covariance, dtype=float)
    d = np.diagonal(s, axis1=-2, axis2=-1)
    g = 1.0 / (1.0 + mu)
    mean_y = np.sum(c * (np.log1p(mu) - g**2 * d / 2), axis=-1)
    gp, gq = g[..., :, None], g[..., None, :]
    dp, dq = d[..., :, None], d[..., None, :]
    terms = gp * gq * s + (gp * gq) ** 2 * s**2 / 2 + (gp * gq**3 * dq + gp**3 * gq * dp) * s
    var_y = np.einsum("p,...pq,q->...", c, terms, c)
    return mean_y, var_y


class CombinedChannelsError(DerivedErrorModel):
    """The log-AGB error y of the multi-channel estimate as a single-channel ``ErrorModel`` (value 1: y is
    already relative): its moments by co-pol eq. (8.3) at any level, so that requirements give verdicts, margins,
    attribution and trade-off curves on the multi-channel AGB with the single-channel code."""

    channel = "agb"

    def __init__(self, source: MultiChannelErrorModel, weights):
        super().__init__(source)
        self.weights = np.asarray(weights, dtype=float)
        self._sigma = np.asarray(source.values, dtype=float)

    @property
    def value(self) -> float:
        return 1.0

    def reduce(self, joint) -> Moments:
        mu = np.asarray(joint.mean) / self._sigma
        cov = np.asarray(joint.covariance) / np.outer(self._sigma, self._sigma)
        mean, var = log_agb_moments(self.weights, mu, cov)
        return Moments(mean, np.clip(var, 0.0, None))  # far beyond the expansion's range it can turn negative

    def reduce_samples(self, relative: np.ndarray) -> np.ndarray:
        """y of the closed-form minimiser (co-pol eq. 8.2); NaN where a used channel's power is not positive."""
        with np.errstate(invalid="ignore", divide="ignore"):
            logs = np.log1p(np.where(relative > -1, relative, np.nan))
        used = self.weights != 0
        return np.sum(self.weights[used] * logs[..., used], axis=-1)

    def rebuilt(self, source: MultiChannelErrorModel) -> CombinedChannelsError:
        return CombinedChannelsError(source, self.weights)

    def contributions(self) -> dict:
        """Each source's share through the linear part of co-pol eq. (8.3) (additive), and ``nonlinearity``,
        the second-order remainder, so that they add up to ``current()``."""
        total = self.current()
        out, mean_sum, var_sum = {}, 0.0, 0.0
        scale = self.weights / self._sigma
        for name, c in self.source.joint_contributions().items():
            mean = float(scale @ np.asarray(c.mean))
            var = float(scale @ np.asarray(c.covariance) @ scale)
            out[name] = Contribution(mean, var, c.description)
            mean_sum, var_sum = mean_sum + mean, var_sum + var
        out["nonlinearity"] = Contribution(float(total.mean) - mean_sum, float(total.variance) - var_sum,
                                           "second-order terms of the logarithm (delta method, co-pol eq. 8.3)")
        return out


def budget_log_agb_error(view: CombinedChannelsError, budget, speckle_correlation, contributions, rng, relative):
    """The log-AGB error of the joint estimate with the random-error budget (module docstring, co-pol eq. 8.4).

    view : the systematic log-AGB error. budget : the case's ``BackscatterBudget`` (independent terms).
    speckle_correlation : (3, 3). contributions : the systematic ``AGBContribution``s of ``view``. rng : the
    case's generator. relative : simulated relative channel errors (M, N, 3) or None.
    Returns (moments or None, contributions with the budget's terms, relative errors with the budget's draws):
    each term's share is its linear part c^T R_g c, and ``nonlinearity`` takes the rest so that they add up.
    """
    if budget.combination != "independent":
        raise PhysicsInputError(f"the joint multi-channel estimate combines independent budget terms only, got "
                                f"combination {budget.combination!r}")
    c = view.weights
    covs = {g: channel_covariance(budget, g, speckle_correlation) for g in budget.groups}
    total_r = sum(covs.values())
    random_ = tuple(AGBContribution(g, "random", 0.0, float(c @ r @ c), BUDGET_DESCRIPTIONS[g])
                    for g, r in covs.items())
    moments = None
    if view.unavailable is None:
        joint = view.source.current_joint()
        sigma = np.asarray(view.source.values, dtype=float)
        cov = np.asarray(joint.covariance) / np.outer(sigma, sigma) + total_r
        mean, var = log_agb_moments(c, np.asarray(joint.mean) / sigma, cov)
        moments = Moments(mean, np.clip(var, 0.0, None))
    parts = [x for x in contributions if x.name != "nonlinearity"] + list(random_)
    if moments is not None:
        rest = AGBContribution("nonlinearity", "systematic", float(moments.mean) - sum(x.relative_mean for x in parts),
                               float(moments.variance) - sum(x.relative_variance for x in parts),
                               "second-order terms of the logarithm (delta method, co-pol eq. 8.3)")
        parts.append(rest)
    if relative is not None:
        relative = relative + correlated_normal(rng, relative.shape[:-1], total_r)
    return moments, tuple(parts), relative
