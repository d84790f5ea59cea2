"""Combine the error sources of sigma_hv into the relative AGB error the runner reports.

Three groups of sources, each kept as named ``AGBContribution`` records (relative sigma_hv errors
x = e / sigma_hv, mean and variance):

* systematic (the propagation's error model, ``backscatter.error``): its ``contributions()``, for the HV
  model of Men et al. (2021) ``system_distortions`` (the same system with no Faraday rotation),
  ``faraday_rotation`` (what the actual Faraday rotation adds to it; FR alone leaves the symmetrised HV
  unchanged, so it acts only through the distortions) and ``noise_bias`` (the sigma_n/2 bias of the noise in
  the HV estimate and its spread over the simulated looks). They add up to the model's mean and variance;
* random (``backscatter_error_budget``; Ahmed et al. 2014): ``speckle_noise``, ``temporal``,
  ``calibration``, ``area_projection`` at the product's scale, zero mean;
* regression: the uncertainty of the retrieval model's calibration (confidence or prediction band at the
  case's AGB), zero mean;
* model: the uncertainty of the retrieval's exponents and coefficients away from its calibration
  (``e2esim.retrieval.model_error``, docs/theory/retrieval.md eq. 7.2), zero mean.

The sources are independent, so the analytic total has the sum of the means and of the variances (for a
budget with ``combination: linear``, the budget's own total); its Monte Carlo adds to every systematic
sample one draw of the random and regression errors from the case's generator (the speckle-and-noise term
from a gamma law when the budget asks for it), and then applies one draw of the model error exactly, as the
factor e^(m / p) on the estimate's sigma (``model_error.scale_factors``). For the multi-channel log-linear model
the budget enters as an HV-equivalent error: the joint inversion weights channel errors by c_pq, speckle is
correlated between channels as |rho_pq|^2 (the intensity correlation of Gaussian scattering), and temporal,
calibration and area-projection errors are common to all channels.
"""

from __future__ import annotations

import numpy as np

from e2esim.retrieval.agb_error import AGBContribution, AGBError, RelativeErrorMap
from e2esim.retrieval.model_error import draw_log_errors, scale_factors
from e2esim.retrieval.sampling_error import proportion_standard_error

BUDGET_DESCRIPTIONS = {
    "speckle_noise": "speckle, thermal and multiplicative noise at the product's looks (Ahmed et al. 2014, eq. 21)",
    "temporal": "temporal variability unrelated to AGB (Ahmed et al. 2014, Section II-D-2)",
    "calibration": "random, pointing and DEM calibration errors (Ahmed et al. 2014, eq. 30)",
    "area_projection": "area-projection error from the DEM (Ahmed et al. 2014, eq. 36)",
}
_COMMON_MODE = ("temporal", "calibration", "area_projection")  # the same relative error in every channel


def systematic_contributions(model) -> tuple:
    """The systematic error of the propagation's error model (``backscatter.error``) as relative
    contributions, from its ``contributions()`` (for the HV model: system distortions, Faraday rotation and
    noise bias). Returns () when the model has no analytic moments."""
    if model.unavailable is not None:
        return ()
    s = model.value
    return tuple(AGBContribution(name, "systematic", c.mean / s, c.variance / s**2, c.description)
                 for name, c in model.contributions().items())


def budget_contributions(budget, channel_weights=None, scene=None, channel: str = "hv") -> tuple:
    """The budget's terms of eq. (20) as relative errors of ``channel`` (HV-equivalent for a multi-channel
    model)."""
    if budget is None:
        return ()
    out = []
    for g in budget.groups:
        if channel_weights is None:
            var = float(
                np.squeeze(budget.channel(channel).group_sd(g) ** 2 if budget.channels else budget.group_sd(g) ** 2)
            )
        else:
            var = float(channel_covariance(budget, g, intensity_correlation(scene.matrix)).dot(channel_weights)
                        .dot(channel_weights) / channel_weights[1] ** 2)
        out.append(AGBContribution(g, "random", 0.0, var, BUDGET_DESCRIPTIONS[g]))
    return tuple(out)


def intensity_correlation(matrix) -> np.ndarray:
    """|rho_ij|^2 of a covariance matrix: the correlation of the speckle of its channels' intensities (circular
    Gaussian scattering)."""
    c = np.asarray(matrix)
    d = np.sqrt(np.real(np.diag(c)))
    return np.abs(c) ** 2 / np.outer(d, d) ** 2


def channel_covariance(budget, group, speckle_correlation) -> np.ndarray:
    """3x3 covariance of the relative errors of (hh, hv, vv) for one term of eq. (20): speckle and noise
    correlated between channels by ``speckle_correlation`` (3x3), the other terms common to all channels."""
    sd = np.array([float(np.squeeze(budget.channel(ch).group_sd(group))) for ch in ("hh", "hv", "vv")])
    if group in _COMMON_MODE:
        return np.outer(sd, sd)
    return np.asarray(speckle_correlation) * np.outer(sd, sd)


def correlated_normal(rng: np.random.Generator, shape, cov) -> np.ndarray:
    """Draws of N(0, cov) (cov C x C, positive semi-definite), shape ``shape + (C,)``."""
    w, v = np.linalg.eigh(cov)
    root = v * np.sqrt(np.clip(w, 0.0, None))
    return rng.standard_normal(tuple(shape) + (cov.shape[0],)) @ root.T


def random_total_variance(budget, contributions) -> float:
    """Relative variance of the budget's total (the budget's combination rule for a single channel)."""
    if budget is None:
        return 0.0
    if budget.combination == "linear" and budget.channels:
        return float(np.sum([np.sqrt(max(c.relative_variance, 0.0)) for c in contributions]) ** 2)
    return float(sum(c.relative_variance for c in contributions))


def draw_random_errors(rng: np.random.Generator, shape, budget, contributions, regression_variance: float = 0.0,
                       channel_weights=None, scene=None) -> np.ndarray:
    """Monte Carlo draws of the random (budget) and regression relative HV errors, ``shape`` of them.

    Single channel, independent terms: the speckle-and-noise term from ``Gamma(k, 1/k) - 1`` with
    k = 1 / variance (gamma law) or Gaussian, the others Gaussian. Linear combination: one Gaussian with
    the budget's total variance (the terms move together). Multi-channel: correlated Gaussian channel
    errors converted to the HV-equivalent error of the joint inversion (exact map, module docstring);
    returns (HV error, product of the other channels' factors) then.
    """
    reg = (np.sqrt(regression_variance) * rng.standard_normal(shape) if regression_variance > 0
           else np.zeros(shape))
    if channel_weights is not None:
        if budget is None or not contributions:
            return reg, np.ones(shape)
        r_hv, others = _draw_multichannel(rng, shape, budget, channel_weights, scene)
        return r_hv + reg, others
    x = np.zeros(shape)
    if budget is not None and contributions:
        if budget.combination == "linear":
            x = np.sqrt(random_total_variance(budget, contributions)) * rng.standard_normal(shape)
        else:
            for c in contributions:
                v = max(c.relative_variance, 0.0)
                if v == 0:
                    continue
                if c.name == "speckle_noise" and budget.speckle_distribution == "gamma":
                    k = 1.0 / v
                    x = x + rng.gamma(k, 1.0 / k, shape) - 1.0
                else:
                    x = x + np.sqrt(v) * rng.standard_normal(shape)
    return x + reg


def _draw_multichannel(rng, shape, budget, weights, scene):
    gamma = intensity_correlation(scene.matrix)
    r = correlated_normal(rng, shape, sum(channel_covariance(budget, g, gamma) for g in budget.groups))
    others = np.ones(shape)
    for i in (0, 2):
        others = others * np.clip(1.0 + r[..., i], 1e-12, None) ** (weights[i] / weights[1])
    return r[..., 1], others


def systematic_agb_error(model, exponent: float) -> AGBError:
    """The relative AGB error from the propagation's error model alone, through the power law of
    ``exponent`` (no budget, no regression: the chain of Men et al. 2021)."""
    m = model.current() if model.unavailable is None else None
    return AGBError.from_sigma_errors(exponent, model.value, None if m is None else float(m.mean),
                                      None if m is None else float(m.sd), model.relative_samples(), error_model=model)


def combined_agb_error(case, exponent: float, mapping: RelativeErrorMap | None = None,
                       regression: AGBContribution | None = None, channel_weights=None,
                       model_term: AGBContribution | None = None) -> AGBError:
    """The relative AGB error of a case from all its sources (module docstring).

    exponent : power-law exponent (or local exponent of another model). mapping : the model's map from
    relative sigma errors to relative AGB errors (None: the power law). regression : the regression
    contribution, or None. channel_weights : (3,) joint-inversion weights of a multi-channel model.
    model_term : the model contribution of a power law (``model_error.sigma_contribution``), or None.
    """
    model = case["backscatter.error"]
    budget = case.get("backscatter.budget")
    scene = case["scene.covariance"]
    s = model.value
    systematic = systematic_contributions(model)
    random_ = budget_contributions(budget, channel_weights, scene)
    reg = (regression,) if regression is not None else ()
    contributions = systematic + random_ + reg + ((model_term,) if model_term is not None else ())
    reg_var = regression.relative_variance if regression is not None else 0.0
    model_var = model_term.relative_variance if model_term is not None else 0.0
    rand_var = random_total_variance(budget, random_)
    mean = sd = None
    if model.unavailable is None:
        m = model.current()
        mean = float(m.mean)
        var = float(m.variance) + s**2 * (rand_var + reg_var + model_var)
        sd = float(np.sqrt(max(var, 0.0)))
    relative = None
    sys_rel = model.relative_samples()
    if sys_rel is not None:
        drawn = draw_random_errors(case.rng, sys_rel.shape, budget, random_, reg_var, channel_weights, scene)
        if channel_weights is not None:
            r_hv, others = drawn
            relative = (1.0 + sys_rel + r_hv) * others - 1.0
        else:
            relative = sys_rel + drawn
        if model_term is not None:  # exact: the estimate's sigma scaled by e^(m / p), m = p x_model (eq. 7.1)
            m = draw_log_errors(case.rng, relative.shape, model_var * exponent**2)
            relative = (1.0 + relative) * scale_factors(m, 1.0 / exponent) - 1.0
    saturated = errors = ()
    if mapping is not None:
        reg_se = 0.0 if regression is None or regression.uncertainty is None else regression.uncertainty.standard_error
        saturated, errors = _saturation(mapping, mean, sd, s, relative, reg_se)
    return AGBError.from_sigma_errors(exponent, s, mean, sd, relative, mapping, contributions, saturated,
                                      error_model=model, saturated_standard_error=errors)


def _saturation(mapping, mean, sd, sigma, relative, variance_se: float = 0.0) -> tuple:
    """((basis, saturated fraction), ...), ((basis, its standard error), ...): the analytic one's from the
    standard error ``variance_se`` of the sampled relative variance (the regression), the Monte Carlo's from its
    sampling error (``e2esim.retrieval.sampling_error``) and that, in quadrature."""
    from scipy import special


    out, errors = [], []
    threshold = mapping.saturation_threshold()

    def analytic(sd_):
        if not np.isfinite(threshold):
            return 0.0
        if sd_ > 0:
            return float(special.ndtr(-(threshold * sigma - mean) / sd_))
        return float(mean >= threshold * sigma)

    terms_se = 0.0
    if mean is not None:
        out.append(("analytic", analytic(sd)))
        if variance_se > 0:
            shift = sigma**2 * variance_se
            terms_se = abs(analytic(np.sqrt(sd**2 + shift)) - analytic(np.sqrt(max(sd**2 - shift, 0.0)))) / 2
            errors.append(("analytic", terms_se))
    if relative is not None:
        hit = np.ravel(relative) >= threshold
        out.append(("montecarlo", float(np.mean(hit)) if np.isfinite(threshold) else 0.0))
        sampling = proportion_standard_error(hit, np.shape(relative)[0] if np.ndim(relative) > 1 else 0)
        errors.append(("montecarlo", float(np.hypot(sampling, terms_se)) if np.isfinite(threshold) else 0.0))
    return tuple(out), tuple(errors)
