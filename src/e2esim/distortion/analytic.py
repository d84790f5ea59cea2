"""Analytic mean and variance of the error in sigma_hv, with their contributions.

Two forms:

* ``"paper"``: Men et al. (2021), eqs. (11) and (12) with the Faraday-rotation moments of eq. (9)
  plugged in, exactly as published (with the (12a) typo corrected, see docs/errata.md).
* ``"complete"`` (default): the same terms plus the O(V^2) terms eq. (12) misses
  (``e2esim.distortion.second_order``), computed at fixed Omega and averaged over the Faraday-rotation
  distribution exactly (``FaradayDistribution.quadrature``), with the law of total variance:
  ``Var e = E_Omega[Var(e | Omega)] + Var_Omega[E(e | Omega)]``. Eq. (12) instead inserts moments of
  Omega into a formula derived at fixed Omega, which drops the second part and treats X, Y, B as
  Gaussian when they are Gaussian mixtures over Omega; the difference is small for SD(Omega) = 5 deg
  and grows with it. ``complete`` also adds the finite-window noise (and, for ``reference="population"``,
  speckle) variance when ``looks`` is given.

An absolute gain error (|A|^2 lognormal, independent of everything else, noise added after the gain;
Quegan et al. 2018 eq. 11) is applied to both forms exactly.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, fields

import numpy as np

from e2esim.distortion.first_order import (
    SceneTerms,
    bias_terms,
    crosstalk_moments,
    imbalance_moments,
    trig_at,
    variance_terms,
)
from e2esim.distortion.second_order import bias_correction, product_moments, variance_correction
from e2esim.faraday.distribution import FaradayDistribution
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.polarimetry.system_model import estimator_noise_factor
from e2esim.scene.covariance import ScatteringCovariance

FORMS = ("complete", "paper")
REFERENCES = ("scene", "population")


@dataclass(frozen=True)
class HVErrorMoments:
    """Mean and variance of ``e = sigma_hv_hat - sigma_hv`` (m^2/m^2 and (m^2/m^2)^2), split by source.

    Bias parts add up to ``mean``; variance parts add up to ``variance``. All fields broadcast to the
    shape of the level scales the kernel was called with (scalars for one case).

    bias_imbalance, bias_crosstalk : Men et al. (2021) eq. (11), Appendix C split.
    bias_noise : sigma_n / 2 (eq. 11).
    bias_higher_order : fourth-order terms (``complete`` only).
    bias_gain : change of the mean due to an absolute gain error.
    var_imbalance, var_crosstalk, var_interaction : eqs. (A4), (A5), (A6).
    var_higher_order : O(V^2) terms missing from eq. (12) (``complete`` only).
    var_faraday_spread : Var over Omega of the conditional mean (``complete`` only).
    var_finite_looks : noise (and speckle, for the population reference) over a window of ``looks``.
    var_gain : change of the variance due to an absolute gain error.
    """

    mean: np.ndarray
    variance: np.ndarray
    bias_imbalance: np.ndarray
    bias_crosstalk: np.ndarray
    bias_noise: np.ndarray
    bias_higher_order: np.ndarray
    bias_gain: np.ndarray
    var_imbalance: np.ndarray
    var_crosstalk: np.ndarray
    var_interaction: np.ndarray
    var_higher_order: np.ndarray
    var_faraday_spread: np.ndarray
    var_finite_looks: np.ndarray
    var_gain: np.ndarray
    sigma_hv: float
    form: str

    @property
    def sd(self) -> np.ndarray:
        return np.sqrt(self.variance)

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def hv_error_moments(
    scene: ScatteringCovariance,
    system: SystemErrorModel,
    faraday: FaradayDistribution,
    form: str = "complete",
    looks: int | None = None,
    reference: str = "scene",
    crosstalk_level=None,
    imbalance_level=None,
    noise_power=None,
) -> HVErrorMoments:
    """Mean and variance of the sigma_hv error for one scene, system-error model and FR distribution.

    form : "complete" or "paper" (module docstring).
    looks : number of independent samples L averaged in sigma_hv_hat (eq. 17); None for L -> infinity.
        Only the ``complete`` form uses it.
    reference : "scene" (error against the scene's own sigma_hv, eq. 17, as in the paper's simulation) or
        "population" (error against the covariance's sigma_hv, so speckle over L looks counts too).
    crosstalk_level, imbalance_level, noise_power : replace the system model's V_delta, V_eps or sigma_n
        (any broadcastable shapes; the correlation structure is kept): used to trace trade-off curves
        and margins with one vectorised call.
    """
    if form not in FORMS:
        raise ValueError(f"form must be one of {FORMS}, got {form!r}")
    if reference not in REFERENCES:
        raise ValueError(f"reference must be one of {REFERENCES}, got {reference!r}")
    terms = SceneTerms.from_covariance(scene)
    xs, es, ns = np.broadcast_arrays(
        np.asarray(system.crosstalk_level if crosstalk_level is None else crosstalk_level, float),
        np.asarray(system.imbalance_level if imbalance_level is None else imbalance_level, float),
        np.asarray(system.noise_power if noise_power is None else noise_power, float),
    )
    v, c13, c24, ve, ce12 = system.unit_structure  # the correlation structure; levels come from xs, es

    if form == "paper":
        trig = faraday.trig_moments()
        args = _scaled_errors(v, c13, c24, ve, ce12, xs, es)
        parts = _conditional_parts(terms, trig, *args, complete=False)
        spread = np.zeros(xs.shape)
    else:
        nodes, weights = faraday.quadrature()
        trig = _trig_at_nodes(nodes.tobytes())  # arrays over the node axis, which is last
        args = _scaled_errors(v, c13, c24, ve, ce12, xs[..., None], es[..., None])
        node_parts = _conditional_parts(terms, trig, *args, complete=True)
        parts = {k: x @ weights for k, x in node_parts.items()}  # average over the node axis
        mean_at_node = node_parts["bias_imbalance"] + node_parts["bias_crosstalk"] + node_parts["bias_higher_order"]
        spread = (mean_at_node**2) @ weights - (mean_at_node @ weights) ** 2
        spread = np.clip(spread, 0.0, None)  # exact value >= 0; negative weights leave rounding noise

    signal_mean = parts["bias_imbalance"] + parts["bias_crosstalk"] + parts["bias_higher_order"]
    signal_var = (
        parts["var_imbalance"] + parts["var_crosstalk"] + parts["var_interaction"] + parts["var_higher_order"] + spread
    )

    # Absolute gain |A|^2 = G, independent: sigma_hat = G q + noise, E[q] = sigma_hv + signal_mean.
    g1, g2 = system.gain_power_moments
    q1 = terms.sigma_hv + signal_mean
    bias_gain = (g1 - 1.0) * q1
    var_gain = (g2 - 1.0) * signal_var + (g2 - g1**2) * q1**2

    noise = ns * estimator_noise_factor("hv")  # sigma_n / 2
    finite = np.zeros(xs.shape)
    if form == "complete" and looks is not None:
        gq1 = g1 * q1
        gq2 = g2 * (signal_var + q1**2)
        if reference == "scene":
            # Noise over L looks, given the signal: Var = (sigma_nu^4 + 2 sigma_nu^2 G q) / L (noncentral chi^2).
            finite = (noise**2 + 2 * noise * gq1) / looks
        else:
            # Fresh speckle and noise: sigma_hat | q ~ (G q + sigma_nu^2) Gamma(L) / L.
            finite = (gq2 + 2 * noise * gq1 + noise**2) / looks

    shape = xs.shape
    z = np.zeros(shape)
    bias_noise = np.broadcast_to(noise, shape) + z
    mean = signal_mean + bias_noise + bias_gain
    variance = signal_var + var_gain + finite
    return HVErrorMoments(
        mean=mean + z,
        variance=variance + z,
        bias_imbalance=parts["bias_imbalance"] + z,
        bias_crosstalk=parts["bias_crosstalk"] + z,
        bias_noise=bias_noise,
        bias_higher_order=parts["bias_higher_order"] + z,
        bias_gain=bias_gain + z,
        var_imbalance=parts["var_imbalance"] + z,
        var_crosstalk=parts["var_crosstalk"] + z,
        var_interaction=parts["var_interaction"] + z,
        var_higher_order=parts["var_higher_order"] + z,
        var_faraday_spread=spread + z,
        var_finite_looks=finite + z,
        var_gain=var_gain + z,
        sigma_hv=terms.sigma_hv,
        form=form,
    )


@functools.lru_cache(maxsize=8)
def _trig_at_nodes(nodes: bytes) -> dict:
    """``trig_at`` of quadrature nodes (given as bytes, to be hashable): the nodes are the same for every
    distribution, so this is computed once."""
    return trig_at(np.frombuffer(nodes, dtype=float))


def _scaled_errors(v, c13, c24, ve, ce12, xs, es):
    return v * xs[..., None], c13 * xs, c24 * xs, ve * es[..., None], ce12 * es


def _conditional_parts(terms, trig, v, c13, c24, ve, ce12, complete: bool) -> dict:
    xt = crosstalk_moments(v, c13, c24, trig)
    ci = imbalance_moments(ve, ce12, trig)
    bias = bias_terms(terms, xt, ci)
    var = variance_terms(terms, xt, ci)
    if complete:
        products = product_moments(v, c13, c24, ve, ce12)
        bias_ho = bias_correction(terms, products, trig)
        var_ho = variance_correction(terms, products, trig)
    else:
        bias_ho = var_ho = np.zeros_like(np.real(bias["imbalance"]))
    return {
        "bias_imbalance": bias["imbalance"],
        "bias_crosstalk": bias["crosstalk"],
        "bias_higher_order": bias_ho,
        "var_imbalance": var["imbalance"],
        "var_crosstalk": var["crosstalk"],
        "var_interaction": var["interaction"],
        "var_higher_order": var_ho,
    }
