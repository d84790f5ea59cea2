"""Analytic mean and variance of the error of a multi-pass HV estimate (single date, multi-date, ground cancelled).

The estimate is sigma_hat = (1/L) sum_k y_k^H Q y_k + noise (``e2esim.stack.combination``) and its error
e = G sigma_hat - sigma against sigma = tr(Q Y_hv), the estimator's value for the undistorted, noise-free stack
(ground-cancellation.md, Section 3). Given the Faraday rotation of every pass the kernel
(``e2esim.stack.quadratic_form``) gives the mean and variance of q = E_speckle[y^H Q y] over the system errors;
then, as in the complete single-pass form (``e2esim.distortion.analytic``):

* Faraday rotation: exact average over Omega_0 and the degree-5 cubature over the pass differences
  (``e2esim.stack.faraday``), law of total variance (the spread of the conditional mean is a term of its own);
* the passes' own gain factors eta_n (lognormal): exact for the mean and for the spread of the conditional mean
  (E[prod eta] in closed form), and to O(beta^2 V) for the conditional variance (eq. 15);
* the gain common to all passes: exact, as Men et al. (2021) with an absolute gain (noise added after it);
* noise of power sigma_n per channel and pass, sigma_nu^2 = sigma_n / 2 in each HV estimate (Men et al. 2021,
  eq. 3): bias sigma_nu^2 tr Q ("the noise of the combined passes");
* L looks (eq. 16): reference "scene" (one scene, error against its own value): (2 sigma_nu^2 tr(Q^2 Y)
  + sigma_nu^4 tr Q^2) / L; "population" (a new scene per realisation, speckle included): plus
  E tr(Q Y Q Y) / L, exact for a single combination (rank-one Q) and to first order in the errors otherwise.
"""

from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass, fields

import numpy as np

from e2esim.blas_threads import single_blas_thread
from e2esim.memo_keys import digest_update
from e2esim.polarimetry.system_model import estimator_noise_factor
from e2esim.stack.combination import PassCombination
from e2esim.stack.faraday import StackFaraday
from e2esim.stack.quadratic_form import MONOMIALS, monomials, node_polynomials
from e2esim.stack.scene import StackScene
from e2esim.stack.system import StackSystemErrors

REFERENCES = ("scene", "population")
_HV_NOISE_FACTOR = estimator_noise_factor("hv")  # sigma_n / 2 in each pass's HV estimate


@dataclass(frozen=True)
class StackHVMoments:
    """Mean and variance of the error of a multi-pass HV estimate (m^2/m^2 and (m^2/m^2)^2), with their parts.

    Bias parts add up to ``mean``, variance parts to ``variance``; all broadcast to the levels' shape.
    value : sigma, the estimator's value without errors. bias_distortion : E[q] - sigma (system errors and
    Faraday rotation, the passes' own gains included). bias_noise, bias_gain : noise and common gain.
    var_distortion : E over Faraday rotation of the conditional variance; var_pass_gain : what the passes' own
    gains add to it; var_faraday_spread : the variance of the conditional mean over the Faraday rotation of
    the passes; var_gain : common gain; var_finite_looks : noise (and speckle for the population reference)
    over the L looks.
    """

    mean: np.ndarray
    variance: np.ndarray
    value: float
    bias_distortion: np.ndarray
    bias_noise: np.ndarray
    bias_gain: np.ndarray
    var_distortion: np.ndarray
    var_pass_gain: np.ndarray
    var_faraday_spread: np.ndarray
    var_gain: np.ndarray
    var_finite_looks: np.ndarray

    @property
    def sd(self) -> np.ndarray:
        return np.sqrt(self.variance)

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def pass_gain_products(passes: int, beta: float) -> tuple[np.ndarray, np.ndarray]:
    """E[eta_n eta_m] (N x N) and Cov(eta_n eta_m, eta_k eta_l) (N^4) for eta_n = exp(beta z_n), z iid N(0, 1):
    E[prod eta] = exp(beta^2 / 2 sum_p count_p^2)."""
    idx = np.arange(passes)
    pair_counts = (idx[:, None, None] == idx[None, None, :]).astype(float) + (idx[None, :, None] == idx[None, None, :])
    pair = np.exp(0.5 * beta**2 * np.sum(pair_counts**2, axis=-1))  # counts of each pass p in (n, m)
    counts = (pair_counts[:, :, None, None, :] + pair_counts[None, None, :, :, :])
    quad = np.exp(0.5 * beta**2 * np.sum(counts**2, axis=-1))
    return pair, quad - pair[:, :, None, None] * pair[None, None, :, :]


def evaluation_levels(errors: StackSystemErrors, faraday: StackFaraday, combination: PassCombination,
                      reference: str, looks: int | None, crosstalk_level=None, imbalance_level=None, noise_power=None,
                      difference_variance=None) -> tuple:
    """(V_delta, V_epsilon, sigma_n, sigma_D^2) broadcast together, the case's own where None; then (rank one,
    first-order speckle cross term needed) of eq. (16): a single combination has the exact E[q^2]; a
    combination of rank > 1 against the population needs the kernel's ``csys``. Checks the reference."""
    if reference not in REFERENCES:
        raise ValueError(f"reference must be one of {REFERENCES}, got {reference!r}")
    system = errors.system
    levels = np.broadcast_arrays(
        np.asarray(system.crosstalk_level if crosstalk_level is None else crosstalk_level, float),
        np.asarray(system.imbalance_level if imbalance_level is None else imbalance_level, float),
        np.asarray(system.noise_power if noise_power is None else noise_power, float),
        np.asarray(faraday.difference_sd**2 if difference_variance is None else difference_variance, float))
    rank_one = combination.weights.shape[0] == 1
    return (*levels, rank_one, reference == "population" and looks is not None and not rank_one)


def difference_levels(dv: np.ndarray) -> np.ndarray:
    """The distinct difference variances of ``dv`` (``np.unique``), the one value itself where ``dv`` holds one (a
    root finding's step asks one level at a time: the sort is most of the moments' own time there)."""
    return dv.reshape(-1)[:1] if dv.size == 1 else np.unique(dv)


def node_terms(scene: StackScene, errors: StackSystemErrors, faraday: StackFaraday, combination: PassCombination,
               difference_sd: float, population_cross: bool = False, memo=None, mean_only: bool = False) -> dict:
    """The kernel's coefficients at the Faraday-rotation nodes of one difference SD (rad), with the nodes'
    weights: what ``stack_hv_moments`` evaluates at any crosstalk, channel-imbalance and noise levels. Cached
    by the error model per difference SD, and across cases by ``memo`` (``memoised``). mean_only : the variance's
    coefficients left zero (``node_polynomials``)."""
    nodes = pass_nodes(scene, errors, faraday, difference_sd)
    out = memoised(memo, node_polynomials, scene.blocks(), combination.matrix, nodes.pop("omega"),
                   errors.pass_correlation(scene.passes), errors.kernel_structure, nodes["pair"], population_cross,
                   nodes["pair"] is not None or population_cross, *((True,) if mean_only else ()))
    out.update(nodes)
    return out


def memoised(memo, kernel, *inputs, keep=None, **helpers) -> dict:
    """``kernel(*inputs, **helpers)`` (a dict of arrays), found in ``memo`` (the run's ``KernelMemo``, or None) by the
    content of ``inputs`` (arrays by dtype, shape and bytes; dicts, tuples, numbers and None by value): the cases of
    a sweep with one geometry (scene, errors, rotation nodes, combination) share their node terms. ``helpers`` are
    not part of the key: what cannot change the result (the memo the kernel keeps its own parts in). A new dict is
    returned each time; its arrays are the kernel's, never written to. keep : where the memo does not hold it,
    ``keep(digest, make)`` gives the value instead of ``make()`` (a store kept between runs, found again by the
    inputs' digest; ``e2esim.stack.residual_fourier.kept_coefficients``)."""
    if memo is None:
        return kernel(*inputs, **helpers)
    digest = hashlib.sha256(kernel.__qualname__.encode())
    digest_update(digest, inputs)
    key = (kernel.__module__, digest.hexdigest())
    found = memo.get(key)
    if found is None:
        make = functools.partial(kernel, *inputs, **helpers)
        found = make() if keep is None else keep(key[1], make)
        memo[key] = found
    return dict(found)


class NodeTermTable(dict):
    """The ``cache`` of ``stack_hv_moments`` and ``stack_joint_moments`` for the models of one structure: their node
    terms by difference SD, kept in the run's ``KernelMemo`` under ``key`` (``("stack node terms", structure)``,
    ``structure`` a ``value_key`` of everything the node terms read apart from the difference SD and the flags of
    each entry's own key), so every model of that structure (a case's variants that change a level or the
    difference SD, the cases of one geometry) finds what any of them computed, bit for bit the same. Each entry
    added counts the table's bytes again in the memo's bound."""

    def __init__(self, memo, key: tuple):
        super().__init__()
        self.memo, self.key = memo, key

    def __setitem__(self, key, value) -> None:
        super().__setitem__(key, value)
        self.memo[self.key] = self  # its bytes counted again (the least recently used leave when over the bound)

    def __reduce__(self):  # the memo's, not the model's: sent to another process it is an empty dict there
        return (dict, ())

    @classmethod
    def of(cls, memo, structure: str, keep: int) -> NodeTermTable:
        """The table of ``structure`` in ``memo``, a new one when not kept (at most ``keep`` tables stay)."""
        key = ("stack node terms", structure)
        return memo.recall(key, lambda: cls(memo, key), keep=keep)


def pass_nodes(scene: StackScene, errors: StackSystemErrors, faraday: StackFaraday, difference_sd: float) -> dict:
    """``omega`` (K, N) and ``weights`` (K,): the Faraday-rotation nodes of one difference SD (rad); ``pair`` and
    ``cov4``: E[eta_n eta_m] and Cov(eta_n eta_m, eta_k eta_l) of the passes' own gain factors (None without)."""
    n = scene.passes
    omega, weights = faraday.nodes(n, difference_sd)
    beta = errors.pass_gain_log_sd
    pair, cov4 = pass_gain_products(n, beta) if beta > 0 else (None, None)
    return {"omega": omega, "weights": weights, "pair": pair, "cov4": cov4}


@single_blas_thread  # batches of small products: e2esim.blas_threads
def stack_hv_moments(scene: StackScene, errors: StackSystemErrors, faraday: StackFaraday,
                     combination: PassCombination, looks: int | None = None, reference: str = "scene",
                     crosstalk_level=None, imbalance_level=None, noise_power=None, difference_variance=None,
                     cache: dict | None = None, memo=None, mean_only: bool = False,
                     value: float | None = None) -> StackHVMoments:
    """Mean and variance of the multi-pass HV error (module docstring), levels replaced where given.

    crosstalk_level, imbalance_level : V_delta, V_epsilon. noise_power : sigma_n (m^2/m^2).
    difference_variance : sigma_D^2 (rad^2), the variance of the Faraday-rotation difference of two passes.
    All broadcast together. cache : a dict kept by the caller for the node terms of each sigma_D. memo : the run's
    ``KernelMemo`` (or None), node terms shared by value across cases. mean_only : the mean alone is read (the
    variance's parts are zero, the kernel's variance left out): the mean is the same, bit for bit. value : the
    estimator's value tr(Q Y_hv) where the caller has it (``StackModelBase.channel_values``), else computed.
    """
    xs, es, ns, dv, rank_one, need_cross = evaluation_levels(errors, faraday, combination, reference, looks,
                                                             crosstalk_level, imbalance_level, noise_power,
                                                             difference_variance)
    shape, q = xs.shape, combination.matrix
    cache = {} if cache is None or mean_only else cache
    parts = {k: np.zeros(shape) for k in ("mu", "mu2", "v", "veta", "tr_q2y", "tr_qyqy", "csys")}
    for level in difference_levels(dv):
        key = (float(level), need_cross)
        if key not in cache:
            cache[key] = node_terms(scene, errors, faraday, combination, float(np.sqrt(level)), need_cross, memo,
                                    mean_only)
        t = cache[key]
        sel = dv == level
        mono = monomials(xs[sel], es[sel])  # (6, S)
        w = t["weights"]
        mu = np.einsum("ks,kg->sg", mono, t["mean"])
        parts["mu"][sel] = np.einsum("sg,g->s", mu, w)
        parts["mu2"][sel] = np.einsum("sg,g->s", mu**2, w)
        parts["v"][sel] = np.einsum("ks,kg,g->s", mono, t["var"], w)
        parts["tr_q2y"][sel] = np.einsum("ks,kg,g->s", mono, t["trq2y"], w)
        if t["y0"] is not None:
            y0 = np.einsum("ks,kgnm->sgnm", mono, t["y0"])  # passes' signal covariance without gain factors
            if t["cov4"] is not None:  # Var over the passes' own gains of the conditional mean sum eta eta kappa
                kappa = (q.T * y0).reshape(y0.shape[:2] + (-1,))  # (S, G, N^2)
                cov4 = t["cov4"].reshape(kappa.shape[-1], kappa.shape[-1])
                veta = np.real(np.sum((kappa @ cov4) * kappa, axis=-1))
                parts["veta"][sel] = np.einsum("sg,g->s", veta, w)
            if need_cross:
                ybar = y0 if t["pair"] is None else y0 * t["pair"]
                qy = np.einsum("mn,sgnk->sgmk", q, ybar)
                parts["tr_qyqy"][sel] = np.einsum("sg,g->s", np.real(np.einsum("sgmk,sgkm->sg", qy, qy)), w)
                parts["csys"][sel] = np.einsum("ks,kg,g->s", mono, t["csys"], w)
    value = combination.value(scene.channel_matrix(1)) if value is None else value
    signal_mean = parts["mu"]
    spread = np.clip(parts["mu2"] - signal_mean**2, 0.0, None)
    var_dist = parts["v"]
    signal_var = var_dist + parts["veta"] + spread
    g1, g2 = errors.common_gain_moments
    bias_gain = (g1 - 1.0) * signal_mean
    var_gain = (g2 - 1.0) * signal_var + (g2 - g1**2) * signal_mean**2
    nu2 = ns * _HV_NOISE_FACTOR
    tr_q, tr_q2 = combination.traces
    finite = np.zeros(shape)
    if looks is not None:
        finite = (2 * nu2 * g1 * parts["tr_q2y"] + nu2**2 * tr_q2) / looks
        if reference == "population":
            # E tr(Q Y Q Y): exact for one combination (= E[q^2]), first order in the errors otherwise
            speckle = (signal_var + signal_mean**2) if rank_one else parts["tr_qyqy"] + parts["csys"]
            finite = finite + g2 * speckle / looks
    bias_noise = nu2 * tr_q + np.zeros(shape)
    z = np.zeros(shape)
    return StackHVMoments(
        mean=signal_mean - value + bias_noise + bias_gain, variance=signal_var + var_gain + finite, value=value,
        bias_distortion=signal_mean - value, bias_noise=bias_noise, bias_gain=bias_gain + z,
        var_distortion=var_dist, var_pass_gain=parts["veta"], var_faraday_spread=spread, var_gain=var_gain + z,
        var_finite_looks=finite + z)


__all__ = ["MONOMIALS", "REFERENCES", "StackHVMoments", "difference_levels", "evaluation_levels", "memoised",
           "node_terms", "pass_nodes", "stack_hv_moments"]
