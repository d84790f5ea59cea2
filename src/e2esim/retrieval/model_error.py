"""Model uncertainty of a power-law retrieval: its exponents and coefficients are not known exactly, and an AGB
estimate made with the retrieval's law where nature follows another is wrong away from where the law was
calibrated (docs/theory/retrieval.md, Section 7).

Per channel p, nature has sigma_p = L_p AGB^alpha_p (the forward form of Men et al. 2021, eq. 15, and of the
BIOMASS AGB ATBD, eq. 4.8). The retrieval uses exponents alpha_p^r = alpha_p - eps_p and coefficients calibrated at a
reference AGB W_ref (the centre of its calibration data), where its law is off by delta_p in ln sigma. Its log-AGB
estimate ln W_hat = sum_p c_p (ln sigma_hat_p - ln L_p^r), sum_p c_p alpha_p^r = 1 (one channel: c = p = 1/alpha;
the joint estimate: c = alpha / (alpha . alpha), ATBD eqs. 4.26-4.37), then has the error exactly

    y = ln(W_hat / W) = sum_p c_p ln(1 + x_p) + m,    m = sum_p c_p (eps_p D - delta_p),    D = ln(W / W_ref),   (7.1)

x_p the relative error of sigma_hat_p. Derivation: ln L_p^r = ln L_p + eps_p ln W_ref + delta_p (the retrieval's law
agrees with nature's at W_ref up to delta_p), so ln sigma_hat_p - ln L_p^r = ln(1 + x_p) + alpha_p^r ln W + eps_p D
- delta_p, and sum_p c_p alpha_p^r ln W = ln W. The model error m is linear in the parameter errors and independent
of the measurement errors x; for eps and delta zero-mean with covariances S_eps and S_delta (independent of each
other), the log-AGB error gains no bias and the variance

    Var m = c^T (D^2 S_eps + S_delta) c                                                                      (7.2)

exactly: it is zero at the calibration centre and grows with the squared log distance from it (the prediction band
of a regression, s^2 (1/n + (x - x_bar)^2 / S_xx), read for parameters known to a stated precision). This is
the ATBD's own propagation (eq. 4.36) with the covariance of level and exponent made explicit: the ATBD takes the
level and exponent errors as uncorrelated about w = 0 dB (1 t/ha), which puts its pivot at 1 t/ha. In the Monte
Carlo the error is applied exactly: every channel's relative power is scaled by e^(m alpha_p^r), which moves the
inversion's ln W_hat by m before any cap (``scale_factors``).

A single-channel power law sees m as an equivalent relative sigma error of variance Var m / p^2 (first order; the
Monte Carlo stays exact); the joint estimate, whose error is already y, adds Var m to its log-AGB variance.

Stated uncertainties (``stated_exponent_sd``; docs/theory/retrieval.md, Section 7, Table 7.1):

* HV exponent: relative SD 7.3 % = half the log difference of the two published pooled fits, p = 2.2 (boreal) and 1.9
  (tropical) of Schlund et al. (2018), quoted by Men et al. (2021), Section III-D, whose slopes Schlund et al.
  (abstract) report as not significantly different: the spread between published fits.
* HH and VV exponents of the biome (the Table I fits of ``e2esim.retrieval.multichannel.TABLE1_ALPHA``): no second
  published fit; the same relative SD is assumed (the fits' own standard errors, 1.6e-4 and 4.7e-3, measure only
  the three boreal forests of one campaign).
* Ground-cancelled HV and VV (``rvog``, alpha (1 + mu)): the published relative spread, carried through the stated
  model (the uncertainty of the assumed ground-to-volume ratios is not included).
* Ground-cancelled HH: the value is the volume's exponent, that of ground-cancelled HV (``volume``,
  e2esim.stack.multichannel_retrieval); its SD is the distance to the biome's HH exponent (``same``), the spread
  between the two rules that can hold: an assumption, stated.
* Coefficients: 0 by default: the retrieval's law is calibrated on reference data where it is anchored (the ATBD fits
  l per date and polarisation, Section 4.1.4.3); the statistical error of that calibration is the regression term.
"""

from __future__ import annotations

import math

import numpy as np

from e2esim.params import Param, ParamGroup
from e2esim.retrieval.agb_error import AGBContribution

MODEL_MODES = ("none", "stated")
HV_EXPONENT_RELATIVE_SD = 0.5 * math.log(2.2 / 1.9)
"""Relative SD of the HV power-law exponent: half the log difference of the pooled boreal (2.2) and tropical (1.9)
fits of Schlund et al. (2018), Men et al. (2021), Section III-D (0.0733)."""

REFERENCE_AGB_T_HA = {"boreal": (50.0 * 200.0 * 350.0) ** (1 / 3), "tropical": (338.0 * 341.0) ** 0.5}
"""AGB at which a biome's law is calibrated, W_ref: the geometric mean of the forests of Men et al. (2021), Table I,
that its exponents describe (151.8 t/ha boreal, the three forests the HH and VV exponents are fitted to; 339.5 t/ha
tropical, TropiSAR and AfriSAR)."""

DESCRIPTION = "uncertainty of the retrieval's exponents and coefficients away from its calibration (eq. 7.2)"


def model_uncertainty_group(default_mode: str, channels: int) -> ParamGroup:
    """The ``model_uncertainty`` section of a retrieval with ``channels`` exponents (1: a single power law; 3: hh, hv,
    vv), stated by default (``default_mode`` "stated") or not propagated ("none")."""
    length = channels if channels > 1 else None
    names = " for (hh, hv, vv)" if channels > 1 else ""
    stated = source_of(("hh", "hv", "vv") if channels > 1 else ("hv",), cancelled=channels > 1)
    params = (
        Param("mode", "str", "stated: the uncertainty of the exponents and coefficients is propagated as the AGB "
              "error's 'model' term (docs/theory/retrieval.md, Section 7); none: it is not", default=default_mode,
              choices=MODEL_MODES),
        Param("exponent_sd_percent", "float", f"relative SD of the exponent{names} (null: {stated})", default=None,
              unit="%", length=length, minimum=0.0, maximum=100.0, nullable=True),
        Param("coefficient_sd_percent", "float", f"relative SD of the calibrated coefficient{names} at the reference "
              "AGB, as a backscatter error (0: calibrated where it is anchored; its statistical error is the "
              "regression term)", default=(0.0,) * channels if channels > 1 else 0.0, unit="%", length=length,
              minimum=0.0, maximum=100.0),
        Param("reference_agb_t_ha", "float", "AGB at which the law is calibrated, W_ref (null: the biome's Table I "
              "forests, 151.8 t/ha boreal, 339.5 tropical)", default=None, unit="t/ha", exclusive_minimum=0.0,
              nullable=True),
    )
    if channels > 1:
        params += (Param("exponent_correlation", "float", "correlation of the exponent errors of the channels "
                         "(1: they move together, the larger error of the joint estimate)", default=1.0, minimum=0.0,
                         maximum=1.0),)
    return ParamGroup("model_uncertainty", "uncertainty of the retrieval model's exponents and coefficients, "
                      "propagated as a model-error term", params)


def log_distance(agb_t_ha: float, reference_agb_t_ha: float) -> float:
    """D = ln(W / W_ref) of eq. (7.1)."""
    return float(np.log(agb_t_ha / reference_agb_t_ha))


def model_log_variance(weights, exponent_sd, coefficient_sd, distance: float, correlation: float = 1.0) -> float:
    """Var m of eq. (7.2): weights c (C,), absolute SDs of the exponents (C,) and of the ln-sigma levels at the
    reference (C,), D = ln(W / W_ref); exponent errors correlated by ``correlation`` between channels, level errors
    independent."""
    c = np.atleast_1d(np.asarray(weights, dtype=float))
    s_eps = np.atleast_1d(np.asarray(exponent_sd, dtype=float))
    s_delta = np.atleast_1d(np.asarray(coefficient_sd, dtype=float))
    corr = np.full((c.size, c.size), float(correlation))
    np.fill_diagonal(corr, 1.0)
    cov = distance**2 * corr * np.outer(s_eps, s_eps) + np.diag(s_delta**2)
    return float(c @ cov @ c)


def log_contribution(variance: float) -> AGBContribution:
    """The model term of an error already on the log-AGB scale (the joint estimate): y gains variance ``variance``."""
    return AGBContribution("model", "model", 0.0, float(variance), DESCRIPTION)


def sigma_contribution(variance: float, exponent: float) -> AGBContribution:
    """The model term of a single power law AGB = A sigma^p as an equivalent relative sigma error (first order:
    y = p x, so Var x = Var m / p^2)."""
    return AGBContribution("model", "model", 0.0, float(variance) / exponent**2, DESCRIPTION)


def draw_log_errors(rng: np.random.Generator, shape, variance: float) -> np.ndarray:
    """Draws of m ~ N(0, variance), ``shape`` of them (eq. 7.1 is Gaussian for Gaussian parameter errors)."""
    return np.sqrt(max(variance, 0.0)) * rng.standard_normal(shape)


def scale_factors(m, alpha) -> np.ndarray:
    """e^(m alpha_p): the factor by which the model error scales channel p's relative power, so that the retrieval's
    inversion of the scaled powers is off by exactly m in ln AGB (sum_p c_p alpha_p = 1). ``m`` any shape, ``alpha``
    (C,): shape m.shape + (C,); a number alpha gives m.shape."""
    a = np.asarray(alpha, dtype=float)
    return np.exp(np.multiply.outer(np.asarray(m, dtype=float), a))


def stated_exponent_sd(alpha, channels=("hh", "hv", "vv"), cancelled_hh_spread: float | None = None) -> np.ndarray:
    """Absolute SDs of the exponents ``alpha`` of ``channels`` (module docstring): the published relative spread of
    the HV exponent for every channel, except a ground-cancelled HH (``cancelled_hh_spread``: the distance between
    its two rules, volume and same)."""
    alpha = np.atleast_1d(np.asarray(alpha, dtype=float))
    sd = HV_EXPONENT_RELATIVE_SD * alpha
    if cancelled_hh_spread is not None and "hh" in channels:
        sd[list(channels).index("hh")] = abs(float(cancelled_hh_spread))
    return sd


def source_of(channels=("hh", "hv", "vv"), cancelled: bool = False, given: bool = False) -> str:
    """Where the exponents' SDs come from, in words (the parameter's doc, which the report's assumptions show)."""
    if given:
        return "given in the scenario"
    text = ("HV 7.3 %, the spread between the published fits p = 2.2 and 1.9 (Schlund et al. 2018, Men et al. 2021 "
            "Sec. III-D)")
    if len(channels) > 1:
        text += "; HH, VV the same, assumed (no second published fit)"
    if cancelled and "hh" in channels:
        text += "; ground-cancelled HH the distance between its volume and same exponents, assumed"
    return text


def case_model_variance(si: dict, alpha, weights, agb_t_ha: float, biome, channels=("hh", "hv", "vv"),
                        cancelled_hh_spread: float | None = None) -> tuple:
    """(Var m, D, exponent SDs) of a case (eqs. 7.1-7.2) from the resolved ``model_uncertainty`` section ``si``
    (SI names), the retrieval's exponents ``alpha`` and weights c of ``channels``; None when the mode is none.
    Raises KeyError when the reference AGB is null and the biome has none."""
    if si["mode"] == "none":
        return None
    alpha = np.atleast_1d(np.asarray(alpha, dtype=float))
    given = si["exponent_sd_fraction"]
    if given is None:
        exponent_sd = stated_exponent_sd(alpha, channels, cancelled_hh_spread)
    else:
        exponent_sd = np.atleast_1d(np.asarray(given, dtype=float)) * alpha
    coefficient_sd = np.atleast_1d(np.asarray(si["coefficient_sd_fraction"], dtype=float))
    reference = si["reference_agb_t_ha"]
    if reference is None:
        reference = REFERENCE_AGB_T_HA[biome]
    distance = log_distance(agb_t_ha, reference)
    variance = model_log_variance(weights, exponent_sd, coefficient_sd, distance, si.get("exponent_correlation", 1.0))
    return variance, distance, exponent_sd
