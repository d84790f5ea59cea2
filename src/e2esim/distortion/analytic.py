"""Analytic mean and variance of the error in sigma_hv, with their contributions.

Two forms:

* ``"paper"``: Men et al. (2021), eqs. (11) and (12) with the Faraday-rotation moments of eq. (9)
  plugged in, exactly as published (with the (12a) typo corrected, see docs/errata.md).
* ``"complete"`` (default): the same terms plus the O(V^2) terms eq. (12) misses
  (``e2esim.distortion.second_order``), computed at fixed Omega and averaged over the Faraday-rotation
  distribution exactly (``FaradayDistribution.even_quadrature``: every term is a polynomial of degree <= 4 in
  cos 2 Omega, averaged exactly by five nodes), with the law of total variance:
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
from e2esim.faraday.distribution import EVEN_NODES, FaradayDistribution
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
    check_settings(form, reference)
    return moments_of(MomentInputs.of(scene, system, faraday, form), form, looks, reference,
                      crosstalk_level, imbalance_level, noise_power)


def check_settings(form: str, reference: str) -> None:
    if form not in FORMS:
        raise ValueError(f"form must be one of {FORMS}, got {form!r}")
    if reference not in REFERENCES:
        raise ValueError(f"reference must be one of {REFERENCES}, got {reference!r}")


@dataclass(frozen=True)
class MomentInputs:
    """What ``moments_of`` needs from a scene, a system-error model and a Faraday-rotation distribution, as
    arrays with a leading case shape C: () for one case, (B,) for a block of B sweep cases (``stack``).

    terms : ``SceneTerms`` (fields of shape C). structure : (V_i C+(4,), C_13 C, C_24 C, V_eps_i C+(2,),
    C_eps12 C), the correlation structure at unit levels (``SystemErrorModel.unit_structure``). levels :
    (V_delta, V_eps, sigma_n), shape C. gain : (E|A|^2, E|A|^4), shape C. averaging : the quadrature
    weights over Omega, C+(G,), for the complete form; the trig moments of eq. (9) (shape C each) for the
    paper form. no_rotation, no_gain_error : shape C, where Omega is 0 without spread and where the system has
    no absolute gain error (the sources an error model cannot remove there).
    """

    terms: SceneTerms
    structure: tuple
    levels: tuple
    gain: tuple
    averaging: object
    no_rotation: object = False
    no_gain_error: object = False

    @classmethod
    def of(cls, scene, system, faraday, form: str) -> MomentInputs:
        averaging = faraday.trig_moments() if form == "paper" else faraday.even_quadrature()[1]
        return cls(SceneTerms.from_covariance(scene), system.unit_structure,
                   (system.crosstalk_level, system.imbalance_level, system.noise_power),
                   system.gain_power_moments, averaging, no_rotation(faraday), not system.has_gain_error)

    @classmethod
    def stack(cls, rows: list) -> MomentInputs:
        """The inputs of several cases (each with C = ()) as one block, C = (len(rows),)."""
        first = rows[0]

        def column(get):
            return np.array([get(r) for r in rows])

        terms = SceneTerms(*(column(lambda r, f=f.name: getattr(r.terms, f)) for f in fields(SceneTerms)))
        structure = tuple(column(lambda r, i=i: r.structure[i]) for i in range(len(first.structure)))
        levels = tuple(column(lambda r, i=i: r.levels[i]).astype(float) for i in range(3))
        gain = tuple(column(lambda r, i=i: r.gain[i]).astype(float) for i in range(2))
        if isinstance(first.averaging, dict):
            averaging = {k: column(lambda r, k=k: r.averaging[k]) for k in first.averaging}
        else:
            averaging = column(lambda r: r.averaging)
        return cls(terms, structure, levels, gain, averaging, column(lambda r: r.no_rotation),
                   column(lambda r: r.no_gain_error))

    def take(self, index) -> MomentInputs:
        """The rows ``index`` (an integer array) of a block."""
        terms = SceneTerms(*(getattr(self.terms, f.name)[index] for f in fields(SceneTerms)))
        averaging = ({k: v[index] for k, v in self.averaging.items()} if isinstance(self.averaging, dict)
                     else self.averaging[index])
        return MomentInputs(terms, tuple(x[index] for x in self.structure), tuple(x[index] for x in self.levels),
                            tuple(x[index] for x in self.gain), averaging, np.asarray(self.no_rotation)[index],
                            np.asarray(self.no_gain_error)[index])

    @staticmethod
    def concatenate(parts: list) -> MomentInputs:
        """Blocks of inputs one after the other (case axis (B,) each)."""
        first = parts[0]
        terms = SceneTerms(*(np.concatenate([getattr(p.terms, f.name) for p in parts]) for f in fields(SceneTerms)))
        averaging = ({k: np.concatenate([p.averaging[k] for p in parts]) for k in first.averaging}
                     if isinstance(first.averaging, dict) else np.concatenate([p.averaging for p in parts]))
        return MomentInputs(terms, *(tuple(np.concatenate([getattr(p, name)[i] for p in parts])
                                           for i in range(len(getattr(first, name))))
                                     for name in ("structure", "levels", "gain")), averaging,
                            *(np.concatenate([getattr(p, name) for p in parts]) for name in ("no_rotation",
                                                                                             "no_gain_error")))

    @property
    def case_ndim(self) -> int:
        return np.ndim(self.levels[0])


def no_rotation(faraday):
    """Whether the Faraday rotation is 0 without spread (its mean and SD are 0); element-wise where they are
    arrays."""
    return (faraday.mean_rad == 0.0) & (faraday.sd_rad == 0.0)


def _expand(x, extra: int, trailing: int = 0):
    """``x`` (case axes, then ``trailing`` component axes) with ``extra`` length-1 axes inserted after its case
    axes, so that it broadcasts against arrays of shape case + extra + components."""
    x = np.asarray(x)
    if extra == 0:
        return x
    cut = x.ndim - trailing
    return x.reshape(x.shape[:cut] + (1,) * extra + x.shape[cut:])


def moments_of(
    inputs: MomentInputs,
    form: str = "complete",
    looks=None,
    reference: str = "scene",
    crosstalk_level=None,
    imbalance_level=None,
    noise_power=None,
) -> HVErrorMoments:
    """``hv_error_moments`` of ``MomentInputs``: Men et al. (2021) eqs. (11)-(12) completed to second order
    (module docstring). Levels replace V_delta, V_eps, sigma_n; with a case axis they are aligned on it
    (shape C + E, E any further axes), and the result has shape C + E. Every case is computed element by
    element with the same operations, so a case in a block gets exactly the numbers it gets alone."""
    c = inputs.case_ndim
    given = [None if x is None else np.asarray(x, float) for x in (crosstalk_level, imbalance_level, noise_power)]
    extra = max([x.ndim - c for x in given if x is not None and x.ndim > 0] + [0])
    levels = [_expand(own, extra) if x is None else x for x, own in zip(given, inputs.levels)]
    case_zeros = _expand(np.zeros(np.shape(inputs.levels[0])), extra)
    # the system's levels apart from the noise: where they are the same for every case (a product's pixels share
    # one system), the system's moments below are computed once and broadcast, with the same operations per case
    xs, es = np.broadcast_arrays(*levels[:2], case_zeros)[:2]
    ns = np.broadcast_to(levels[2], np.broadcast_shapes(np.shape(levels[2]), case_zeros.shape))
    shape = np.broadcast_shapes(xs.shape, ns.shape)
    v, c13, c24, ve, ce12 = inputs.structure
    node = 1 if form == "complete" else 0  # the quadrature's node axis, last

    def case(x, trailing=0):
        return _expand(x, extra + node, trailing)

    t = inputs.terms
    terms = SceneTerms(case(t.sigma_hh), case(t.sigma_hv), case(t.sigma_vv), case(t.r), case(t.theta))
    structure = (case(v, 1), case(c13), case(c24), case(ve, 1), case(ce12))
    if form == "paper":
        trig = {k: case(m) for k, m in inputs.averaging.items()}
        parts = _conditional_parts(terms, trig, *_scaled_errors(*structure, xs, es), complete=False)
        spread = np.zeros(shape)
    else:
        trig = _trig_at_even_nodes()  # arrays over the node axis, which is last
        weights = _expand(inputs.averaging, extra, 1)
        node_parts = _conditional_parts(terms, trig, *_scaled_errors(*structure, xs[..., None], es[..., None]),
                                        complete=True)
        parts = {k: _average(x, weights) for k, x in node_parts.items()}
        mean_at_node = node_parts["bias_imbalance"] + node_parts["bias_crosstalk"] + node_parts["bias_higher_order"]
        spread = _average(mean_at_node**2, weights) - np.square(_average(mean_at_node, weights))
        spread = np.clip(spread, 0.0, None)  # exact value >= 0; negative weights leave rounding noise

    signal_mean = parts["bias_imbalance"] + parts["bias_crosstalk"] + parts["bias_higher_order"]
    signal_var = (
        parts["var_imbalance"] + parts["var_crosstalk"] + parts["var_interaction"] + parts["var_higher_order"] + spread
    )

    # Absolute gain |A|^2 = G, independent: sigma_hat = G q + noise, E[q] = sigma_hv + signal_mean.
    g1, g2 = (_expand(g, extra) for g in inputs.gain)
    q1 = _expand(t.sigma_hv, extra) + signal_mean
    bias_gain = (g1 - 1.0) * q1
    var_gain = (g2 - 1.0) * signal_var + (g2 - g1**2) * q1**2

    noise = ns * estimator_noise_factor("hv")  # sigma_n / 2
    finite = np.zeros(shape)
    if form == "complete" and looks is not None:
        looks = _expand(looks, extra)
        gq1 = g1 * q1
        gq2 = g2 * (signal_var + q1**2)
        if reference == "scene":
            # Noise over L looks, given the signal: Var = (sigma_nu^4 + 2 sigma_nu^2 G q) / L (noncentral chi^2).
            finite = (noise**2 + 2 * noise * gq1) / looks
        else:
            # Fresh speckle and noise: sigma_hat | q ~ (G q + sigma_nu^2) Gamma(L) / L.
            finite = (gq2 + 2 * noise * gq1 + noise**2) / looks

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
        sigma_hv=t.sigma_hv,
        form=form,
    )


def _average(values, weights):
    """The quadrature average over the node axis (last): an element-wise product and its sum over the nodes, the
    same operations for a case alone as for a case in a block. The sum is numpy's ``sum(-1)`` bit for bit: numpy
    adds fewer than 8 terms one by one from +0, and so does this, written out because numpy's reduction over so
    short an axis costs about three times these additions (a quarter of the analytic moments' time)."""
    products = values * weights
    n = products.shape[-1]
    if not 2 <= n < 8:
        return products.sum(-1)
    total = products[..., 0] + products[..., 1]
    for k in range(2, n):
        total += products[..., k]
    total += 0.0  # numpy starts from +0: a sum of -0 terms is +0
    return total


@functools.lru_cache(maxsize=1)
def _trig_at_even_nodes() -> dict:
    """``trig_at`` of the constant quadrature nodes ``EVEN_NODES`` (the same for every distribution): a constant
    computed once."""
    return trig_at(EVEN_NODES)


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
