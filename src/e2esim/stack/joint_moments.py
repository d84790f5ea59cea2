"""Analytic mean vector and covariance matrix of the HH, HV and VV errors of a multi-pass estimate.

The multi-channel counterpart of ``e2esim.stack.analytic`` (ground-cancellation.md, Section 3.2): the errors
e_p = G sigma_hat_p - sigma_p of the three channels of one estimator (single date, multi-date average or ground
cancelled), sigma_p = tr(Q Y_p) the estimator's value for the undistorted, noise-free stack. At every Faraday-
rotation node the kernel ``e2esim.stack.channel_forms`` gives the mean and covariance of the channels' quadratic
forms over the system errors; then, as ``stack.analytic`` does for HV and co-pol Section 5 for one pass:

* Faraday rotation: the same nodes as ``stack.analytic`` (exact over Omega_0, cubature over the pass
  differences), law of total covariance (the covariance of the conditional means is a term of its own); when the
  co-polarised channels are corrected with estimates, times the cubature nodes of their residuals dW_n
  (``StackFaraday.residual_nodes``, ground-cancellation.md Section 3.3);
* the passes' own gain factors: Cov over eta of the conditional means sum eta_n eta_m Q_mn Y_nm^pp (exact), and
  M scaled by E[eta_n eta_m] in the conditional covariance (eq. 15);
* the gain common to all passes, co-pol eq. (5.2); noise of power sigma_n per channel and pass, sigma_nu,p^2 =
  sigma_n (1, 1/2, 1), independent between channels (co-pol eq. 2.4, also after the per-pass correction):
  bias sigma_nu,p^2 tr Q;
* L looks: reference "scene", on the diagonal (2 sigma_nu,p^2 g1 tr(Q^2 Y^pp) + sigma_nu,p^4 tr Q^2) / L (eq. 16);
  "population", plus the speckle E tr(Q Y^pq Q Y^qp) / L, on the diagonal as ``stack.analytic`` (exact for one
  combination, first order in the errors otherwise), off the diagonal tr(Q Ybar^pq Q Ybar^qp) / L with Ybar the
  mean over errors and rotation (its O(V / L) part left out, as co-pol eq. 5.4).

For HV every part equals ``stack_hv_moments`` (tested to 1e-12).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from e2esim.blas_threads import single_blas_thread
from e2esim.distortion.channel_moments import unit_covariances
from e2esim.distortion.polarimetric_moments import NOISE_FACTORS
from e2esim.stack.analytic import difference_levels, evaluation_levels, memoised, pass_nodes
from e2esim.stack.channel_forms import channel_node_polynomials
from e2esim.stack.combination import PassCombination
from e2esim.stack.faraday import StackFaraday
from e2esim.stack.quadratic_form import monomials
from e2esim.stack.residual_fourier import PLANS, evaluate_at, kept_coefficients, residual_coefficients
from e2esim.stack.scene import StackScene
from e2esim.stack.system import StackSystemErrors


@dataclass(frozen=True)
class StackJointMoments:
    """Mean vectors (..., 3) and covariance matrices (..., 3, 3) of the errors of (hh, hv, vv) (channels in that
    order, ``RECIPROCAL_CHANNELS``), with their parts
    (m^2/m^2, (m^2/m^2)^2). Bias parts add up to ``mean``, covariance parts to ``covariance``.

    values : (3,) sigma_p. bias_distortion : E q - sigma (system errors, Faraday rotation, the passes' own gains).
    bias_noise, bias_gain : noise and common gain. cov_distortion : E over the rotation of the conditional
    covariance; cov_pass_gain : what the passes' own gains add; cov_faraday_spread : the covariance of the
    conditional means over the rotation; cov_gain : common gain; cov_finite_looks : noise (and speckle for the
    population reference) over the L looks. expected_covariance : (..., 3, 3) the mean of the estimated combined
    covariance (gain and noise included).
    """

    mean: np.ndarray
    covariance: np.ndarray
    values: np.ndarray
    bias_distortion: np.ndarray
    bias_noise: np.ndarray
    bias_gain: np.ndarray
    cov_distortion: np.ndarray
    cov_pass_gain: np.ndarray
    cov_faraday_spread: np.ndarray
    cov_gain: np.ndarray
    cov_finite_looks: np.ndarray
    expected_covariance: np.ndarray


def joint_node_terms(scene: StackScene, errors: StackSystemErrors, faraday: StackFaraday,
                     combination: PassCombination, difference_sd: float, correct_copol: bool,
                     population_cross: bool = False, memo=None, signal: bool = True, mean_only: bool = False) -> dict:
    """The kernel's coefficients at the Faraday-rotation nodes of one difference SD (rad), with the nodes'
    weights and the passes' gain products: what ``stack_joint_moments`` evaluates at any level (cached by the
    error model per difference SD, and across cases by ``memo``, ``stack.analytic.memoised``). With a residual
    rotation of the co-polarised correction (up to 3 passes) and a memo kept over many rows of one geometry (a
    solve's search, ``KernelMemo.repeated_geometry``) the kernel's values at the residual's nodes come from its
    trigonometric polynomials in the residual (``e2esim.stack.residual_fourier``, eq. 28, built once and found
    again for any residual, and kept between runs in the memo's ``store`` where it has one), equal to the
    node-by-node values to rounding; signal : whether the moments read ``y0`` (else it may be None); mean_only :
    the covariance's coefficients left zero (``channel_node_polynomials``)."""
    nodes = pass_nodes(scene, errors, faraday, difference_sd)
    omega, omega_hat = nodes.pop("omega"), None
    inputs = (scene.blocks(), combination.matrix, errors.pass_correlation(scene.passes),
              unit_covariances(errors.system), nodes["pair"], population_cross)
    if correct_copol:  # corrected with Omega_hat = Omega - dW: the nodes of Omega times those of dW
        residual, weights = faraday.residual_nodes(scene.passes)
        if faraday.residual is not None and scene.passes in PLANS and getattr(memo, "repeated_geometry", False):
            store = getattr(memo, "store", None)  # kept between runs too: the array cache of the front doors
            keep = None if store is None else functools.partial(kept_coefficients, store)
            out = evaluate_at(memoised(memo, residual_coefficients, inputs[0], inputs[1], omega, *inputs[2:],
                                       signal, keep=keep), residual, (nodes["weights"], weights))
            nodes["weights"] = np.outer(nodes["weights"], weights).ravel()
            out.update(nodes, summed=True)  # cov, trq2y and csys summed over the nodes with their weights
            return out
        omega = np.repeat(omega, len(weights), axis=0)
        omega_hat = omega - np.tile(residual, (len(nodes["weights"]), 1))
        nodes["weights"] = np.outer(nodes["weights"], weights).ravel()
    out = memoised(memo, channel_terms, inputs[0], inputs[1], omega, omega_hat, *inputs[2:], signal,
                   *((True,) if mean_only else ()), expansions=memo)
    out.update(nodes)
    return out


def channel_terms(blocks, q, omega, omega_hat, r, gammas, gain_pair, population_cross, signal: bool,
                  mean_only: bool = False, expansions=None) -> dict:
    """``channel_node_polynomials``, its ``y0`` left out (None) where ``signal`` is False: the moments then do not
    read it, and it is the largest of the terms (G N^2 9 complex, 8.6 MB at 7 passes), so the kernel memo keeps
    the rest without it (it held it, and a tomographic run's memo, full, evicted node terms it then computed
    again). The same numbers either way; a caller that reads ``y0`` asks with ``signal`` and gets its own entry."""
    out = channel_node_polynomials(blocks, q, omega, omega_hat, r, gammas, gain_pair, population_cross, mean_only,
                                   expansions)
    if not signal:
        out["y0"] = None
    return out


@single_blas_thread  # batches of small products: e2esim.blas_threads
def stack_joint_moments(scene: StackScene, errors: StackSystemErrors, faraday: StackFaraday,
                        combination: PassCombination, looks: int | None = None, reference: str = "scene",
                        correct_copol: bool = True, crosstalk_level=None, imbalance_level=None, noise_power=None,
                        difference_variance=None, cache: dict | None = None,
                        totals_only: bool = False, memo=None, mean_only: bool = False,
                        values=None) -> StackJointMoments | tuple:
    """Joint moments of the (hh, hv, vv) errors (module docstring), levels replaced where given (broadcast
    together, as ``stack_hv_moments``). correct_copol : every pass's co-polarised channels rotated back by its
    own Faraday rotation before the passes are combined (the operational order), else not corrected.
    cache : a dict kept by the caller for the node terms of each sigma_D. totals_only : return (mean,
    covariance) only. memo : the run's ``KernelMemo`` (or None), node terms shared by value across cases.
    mean_only : the means alone are read (the covariance's parts without the kernel's covariance; the means the same,
    bit for bit). values : the estimator's values tr(Q Y_p) of the three channels where the caller has them
    (``StackModelBase.channel_values``), else computed."""
    xs, es, ns, dv, rank_one, need_cross = evaluation_levels(errors, faraday, combination, reference, looks,
                                                             crosstalk_level, imbalance_level, noise_power,
                                                             difference_variance)
    shape, q = xs.shape, combination.matrix
    cache = {} if cache is None or mean_only else cache
    vec, mat = shape + (3,), shape + (3, 3)
    mu, spread_m, v, veta, expected = (np.zeros(vec), np.zeros(mat), np.zeros(mat), np.zeros(mat),
                                       np.zeros(mat, complex))
    tr_q2y, tr_qyqy, csys, off = np.zeros(vec), np.zeros(vec), np.zeros(vec), np.zeros(mat)
    for value in difference_levels(dv):
        key = (float(value), bool(correct_copol), need_cross)
        if key not in cache or (cache[key]["y0"] is None and _needs_signal(cache[key], need_cross, reference, looks)):
            signal = errors.pass_gain_log_sd > 0 or need_cross or (reference == "population" and looks is not None)
            t = joint_node_terms(scene, errors, faraday, combination, float(np.sqrt(value)), correct_copol,
                                 need_cross, memo, signal, mean_only)
            if not _needs_signal(t, need_cross, reference, looks):
                t["y0"] = None  # the largest of the terms (G N^2 9 complex), not read here: not kept in the cache
            t["mean_diagonal"] = np.real(np.diagonal(t["mean"], axis1=-2, axis2=-1))  # (6, G, 3): E q_p
            cache[key] = t
        t = cache[key]
        sel = dv == value
        mono = monomials(xs[sel], es[sel])  # (6, S)
        w = t["weights"]
        if totals_only:  # the diagonal alone (the same sums over the monomials, to the bit): no expected covariance
            node_mean = np.einsum("ks,kgp->sgp", mono, t["mean_diagonal"])  # (S, G, 3)
        else:
            node_matrix = np.einsum("ks,kgpq->sgpq", mono, t["mean"])  # E[sum Q eta eta A C A^H | Omega]
            node_mean = np.real(np.diagonal(node_matrix, axis1=-2, axis2=-1))  # (S, G, 3)
            expected[sel] = np.einsum("sgpq,g->spq", node_matrix, w)
        mu[sel] = np.einsum("sgp,g->sp", node_mean, w)
        spread_m[sel] = np.einsum("sgp,sgq,g->spq", node_mean, node_mean, w)
        if t.get("summed"):  # over the nodes already (``residual_fourier.SUMMED``)
            v[sel] = np.einsum("ks,kpq->spq", mono, t["cov"])
            tr_q2y[sel] = np.einsum("ks,kp->sp", mono, t["trq2y"])
        else:
            v[sel] = np.einsum("ks,kgpq,g->spq", mono, t["cov"], w)
            tr_q2y[sel] = np.einsum("ks,kgp,g->sp", mono, t["trq2y"], w)
        if _needs_signal(t, need_cross, reference, looks):
            y0 = np.einsum("ks,kgnmpq->sgnmpq", mono, t["y0"])  # passes' signal covariances, no gain factors
            if t["cov4"] is not None:  # Cov over the passes' own gains of the conditional means
                kappa = np.diagonal(q.T[None, None, :, :, None, None] * y0, axis1=-2, axis2=-1)  # (S, G, N, N, 3)
                kappa = kappa.reshape(kappa.shape[:2] + (-1, 3))
                cov4 = t["cov4"].reshape(kappa.shape[2], kappa.shape[2])
                veta[sel] = np.einsum("sgxp,sgxq,g->spq", kappa, cov4 @ kappa, w).real
            ybar = y0 if t["pair"] is None else y0 * t["pair"][None, None, :, :, None, None]
            if need_cross:
                qy = np.einsum("mn,sgnkp->sgmkp", q, np.diagonal(ybar, axis1=-2, axis2=-1))
                tr_qyqy[sel] = np.einsum("sgmkp,sgkmp,g->sp", qy, qy, w).real
                csys[sel] = (np.einsum("ks,kp->sp", mono, t["csys"]) if t.get("summed") else
                             np.einsum("ks,kgp,g->sp", mono, t["csys"], w))
            if reference == "population" and looks is not None:  # off the diagonal: tr(Q Ybar^pq Q Ybar^qp)
                ym = np.einsum("sgnmpq,g->snmpq", ybar, w)
                qy = np.einsum("ab,sbcpq->sacpq", q, ym)
                off[sel] = np.einsum("sacpq,scaqp->spq", qy, qy).real
    values = np.array([combination.value(scene.channel_matrix(i)) for i in range(3)] if values is None else values)
    spread = spread_m - mu[..., :, None] * mu[..., None, :]
    idx = np.arange(3)
    spread[..., idx, idx] = np.clip(spread[..., idx, idx], 0.0, None)
    signal_cov = v + veta + spread
    g1, g2 = errors.common_gain_moments
    bias_gain = (g1 - 1.0) * mu
    mumu = mu[..., :, None] * mu[..., None, :]
    cov_gain = (g2 - 1.0) * signal_cov + (g2 - g1**2) * mumu
    nu2 = ns[..., None] * NOISE_FACTORS  # sigma_nu,p^2 in each pass's estimate
    tr_q, tr_q2 = combination.traces
    finite = np.zeros(mat)
    if looks is not None:
        finite[..., idx, idx] = (2 * nu2 * g1 * tr_q2y + nu2**2 * tr_q2) / looks
        if reference == "population":
            if rank_one:  # one combination: exactly E[q_p q_q] on the diagonal
                speckle = np.diagonal(signal_cov, axis1=-2, axis2=-1) + mu**2
            else:
                speckle = tr_qyqy + csys
            off[..., idx, idx] = speckle
            finite = finite + g2 * off / looks
    bias_noise = nu2 * tr_q
    mean = mu - values + bias_noise + bias_gain
    covariance = signal_cov + cov_gain + finite
    if totals_only:
        return mean, covariance
    expected_covariance = g1 * expected + (nu2 * tr_q)[..., :, None] * np.eye(3)
    return StackJointMoments(mean, covariance, values, mu - values, bias_noise, bias_gain, v, veta, spread, cov_gain,
                             finite, expected_covariance)


def _needs_signal(terms: dict, need_cross: bool, reference: str, looks: int | None) -> bool:
    """Whether the moments read the passes' signal covariances ``y0``: for the passes' own gains, the speckle cross
    term of a combination of rank > 1, or the population reference's finite looks."""
    return terms["cov4"] is not None or need_cross or (reference == "population" and looks is not None)


__all__ = ["StackJointMoments", "channel_terms", "joint_node_terms", "stack_joint_moments"]
