"""Monte Carlo of the full system model, Men et al. (2021), Section IV: a fast exact path and a
brute-force pixel-level reference.

The paper's design: a scene of L independent scattering vectors drawn from the covariance (step 1);
M joint realisations of system errors and Faraday rotation, each applied to every pixel, with N
independent noise realisations per pixel (step 2); the error of ``sigma_hv_hat = mean_k |S_hv_hat(k)|^2``
against the scene's own ``sigma_hv`` (eq. 17) over the M x N measured scenes (step 3).

Fast path, exact in distribution, cost O(M N) instead of O(L M N):

* ``S_hv_hat(k) = a . s(k) + nu(k)`` where ``a`` (3,) depends only on the system-error realisation and
  ``nu = (N_hv + N_vh)/2 ~ CN(0, sigma_n/2)``. So the signal part of ``sigma_hv_hat`` is the quadratic
  form ``q = a C_hat a^H`` in the scene's sample covariance ``C_hat`` (3x3).
* ``L C_hat`` is complex Wishart: drawn directly (Bartlett), never the L vectors.
* Given the scene and ``a``, ``sum_k |a.s(k) + nu(k)|^2`` is ``(sigma_nu^2/2)`` times a noncentral
  chi-square with 2L degrees of freedom and noncentrality ``2 L q / sigma_nu^2`` (the noise is circular
  Gaussian, so its component along the signal and the rest are independent).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.distortion import normality
from e2esim.faraday.distribution import FaradayDistribution
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.polarimetry.system_model import (
    ESTIMATOR_WEIGHTS,
    RECIPROCAL_CHANNELS,
    effective_weight_parts,
    estimator_noise_factor,
    measured_matrix,
    to_vector,
)
from e2esim.scene.covariance import ScatteringCovariance

METHODS = ("fast", "brute_force")
_BRUTE_FORCE_CHUNK = 2_000_000  # pixel x realisation products held in memory at once


@dataclass(frozen=True)
class MonteCarloErrors:
    """Simulated errors of the backscattering-coefficient estimates.

    errors : channel -> array (M, N) of ``sigma_pq_hat - sigma_pq_reference`` (m^2/m^2): M system-error
        and FR realisations, N noise realisations each.
    reference : channel -> the sigma_pq each error is taken against, shape () (one fixed scene) or (M,).
    looks, realisations, noise_realisations : L, M, N. method : "fast" or "brute_force".
    """

    errors: dict
    reference: dict
    looks: int
    realisations: int
    noise_realisations: int
    method: str

    @property
    def hv(self) -> np.ndarray:
        return self.errors["hv"]


def simulate(
    scene: ScatteringCovariance,
    system: SystemErrorModel,
    faraday: FaradayDistribution,
    rng: np.random.Generator,
    looks: int,
    realisations: int,
    noise_realisations: int = 1,
    reference: str = "scene",
    method: str = "fast",
    channels: tuple = ("hv",),
    scene_vectors: np.ndarray | None = None,
) -> MonteCarloErrors:
    """Simulate the estimation errors of sigma_pq under the full model (1) of Men et al. (2021).

    reference : "scene": one scene for all realisations, errors against its own sigma_pq (eq. 17), as in
        the paper; "population": a new scene for every system-error realisation, errors against the
        covariance's sigma_pq (speckle over L looks included).
    scene_vectors : optional (L, 3) scattering vectors of a given scene ("scene" reference only), so
        that the fast path and the brute force can be compared on the same scene.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if reference not in ("scene", "population"):
        raise ValueError(f"reference must be 'scene' or 'population', got {reference!r}")
    for ch in channels:
        if ch not in ESTIMATOR_WEIGHTS:
            raise ValueError(f"unknown channel {ch!r}; expected one of {tuple(ESTIMATOR_WEIGHTS)}")
    if scene_vectors is not None and reference != "scene":
        raise ValueError("scene_vectors can only be given with reference='scene'")
    # Same draw order in both methods: system errors and FR first, then scene, then noise.
    errs = system.sample(rng, realisations)
    omega = faraday.sample(rng, realisations)
    run = _simulate_fast if method == "fast" else _simulate_brute_force
    errors, ref = run(scene, system, errs, omega, rng, looks, noise_realisations, reference, channels, scene_vectors)
    return MonteCarloErrors(errors, ref, looks, realisations, noise_realisations, method)


def _simulate_fast(scene, system, errs, omega, rng, looks, n_noise, reference, channels, scene_vectors):
    m = omega.shape[0]
    if reference == "scene":
        if scene_vectors is not None:
            c_hat = np.einsum("ki,kj->ij", scene_vectors, scene_vectors.conj()) / scene_vectors.shape[0]
            looks = scene_vectors.shape[0]
        else:
            c_hat = scene.sample_covariance(rng, looks)
    else:
        c_hat = scene.sample_covariance(rng, looks, m)
    errors, ref = {}, {}
    for ch in channels:
        parts = effective_weight_parts(errs.delta, errs.f, omega, ch)  # (3, 2, M): a's elements' parts
        if system.has_gain_error:
            parts *= errs.gain  # a real gain times a complex is its two parts times the gain (bit for bit)
        q = hermitian_form(parts, c_hat)  # a new array: the steps below work in place
        np.clip(q, 0.0, None, out=q)  # a C a^H >= 0; clip rounding noise only
        nu2 = system.noise_power * estimator_noise_factor(ch)
        if nu2 > 0:
            q *= 2 * looks  # the noncentrality 2 L q / nu2, the same for each noise realisation
            q /= nu2
            nonc = q[:, None] if n_noise == 1 else np.repeat(q[:, None], n_noise, axis=1)
            sigma_hat = rng.noncentral_chisquare(2 * looks, nonc)
            sigma_hat *= nu2 / (2 * looks)
        else:
            sigma_hat = np.repeat(q[:, None], n_noise, axis=1)
        idx = RECIPROCAL_CHANNELS.index(ch)
        ref[ch] = np.real(c_hat[..., idx, idx]) if reference == "scene" else _population_sigma(scene, ch)
        sigma_hat -= ref[ch][:, None] if np.ndim(ref[ch]) else ref[ch]
        errors[ch] = sigma_hat
    return errors, ref


def hermitian_form(parts: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Re(a C a^H) per realisation, from the parts (3, 2, M) of rows ``a`` (``effective_weight_parts``), for a
    Hermitian C (3, 3) or (M, 3, 3): ``sum_i C_ii |a_i|^2 + sum_{i<j} 2 Re(a_i C_ij a_j^*)``, added in the order
    (0,0), (0,1), (0,2), (1,1), (1,2), (2,2), in real arithmetic (several times faster than a three-operand
    einsum, the same value to rounding). The products are formed in place in one reused buffer: a smaller working
    set, fewer cache misses."""
    cr, ci = _by_element(c.real), _by_element(c.imag)
    work = np.empty((3,) + parts.shape[1:])  # a pair's two products for the pairs (0,1), (0,2), (1,2); then squares
    np.multiply(parts[0], parts[1:3], out=work[:2])  # ar_i ar_j, ai_i ai_j
    np.multiply(parts[1], parts[2], out=work[2])
    cross = np.add(work[:, 0], work[:, 1])  # Re(a_i a_j^*)
    np.multiply(parts[0, ::-1], parts[1:3], out=work[:2])  # ai_i ar_j, ar_i ai_j
    np.multiply(parts[1, ::-1], parts[2], out=work[2])
    im = work[:, 0]
    im -= work[:, 1]  # Im(a_i a_j^*)
    cross *= cr[_UPPER]
    im *= ci[_UPPER]
    cross -= im
    cross *= 2  # 2 Re(a_i C_ij a_j^*) = 2 (Re C_ij Re(a_i a_j^*) - Im C_ij Im(a_i a_j^*))
    np.square(parts, out=work)
    power = work[:, 0]
    power += work[:, 1]  # |a_i|^2
    power *= cr[_DIAGONAL]
    q = power[0] + cross[0]
    for term in (cross[1], power[1], cross[2], power[2]):
        q += term
    return q


_DIAGONAL = (np.arange(3), np.arange(3))
_UPPER = ((0, 0, 1), (1, 2, 2))


def _by_element(c: np.ndarray) -> np.ndarray:
    """(..., 3, 3) -> (3, 3, ...) with trailing axes of one for a single (3, 3), to broadcast over realisations."""
    return np.moveaxis(c, (-2, -1), (0, 1)) if c.ndim > 2 else c[:, :, None]


def _simulate_brute_force(scene, system, errs, omega, rng, looks, n_noise, reference, channels, scene_vectors):
    """Pixel by pixel: M = gain R F S F T + N for every pixel, realisation and noise draw (eq. 1)."""
    m = omega.shape[0]
    if reference == "scene":
        s = scene_vectors if scene_vectors is not None else scene.sample(rng, looks)
        looks = s.shape[0]
        fixed_scene = reciprocal_matrices(s)  # (L, 2, 2)
    sigma_n = system.noise_power
    sums = {ch: np.zeros((m, n_noise)) for ch in channels}
    per_chunk = max(1, _BRUTE_FORCE_CHUNK // max(looks, 1))
    for start in range(0, m, per_chunk):
        sl = slice(start, min(start + per_chunk, m))
        k = sl.stop - sl.start
        if reference == "scene":
            true = fixed_scene[None]  # (1, L, 2, 2)
        else:
            true = reciprocal_matrices(scene.sample(rng, (k, looks)))  # (k, L, 2, 2)
        signal = measured_matrix(
            true,
            errs.delta[sl, None, :],
            errs.f[sl, None, :],
            omega[sl, None],
            gain=errs.gain[sl, None],
        )  # (k, L, 2, 2)
        for j in range(n_noise):
            noise = np.sqrt(sigma_n / 2) * (
                rng.standard_normal(signal.shape) + 1j * rng.standard_normal(signal.shape)
            )
            meas = to_vector(signal + noise)  # (k, L, 4) in (hh, hv, vh, vv)
            for ch in channels:
                est = meas @ ESTIMATOR_WEIGHTS[ch]
                sums[ch][sl, j] = np.mean(np.abs(est) ** 2, axis=1)
    errors, ref = {}, {}
    for ch in channels:
        idx = RECIPROCAL_CHANNELS.index(ch)
        if reference == "scene":
            ref[ch] = np.mean(np.abs(s[:, idx]) ** 2)  # eq. (17)
        else:
            ref[ch] = _population_sigma(scene, ch)
        errors[ch] = sums[ch] - ref[ch]
    return errors, ref


def reciprocal_matrices(vectors: np.ndarray) -> np.ndarray:
    """(..., 3) reciprocal vectors (hh, hv, vv) -> (..., 2, 2) matrices [[hh, hv], [hv, vv]]."""
    hh, hv, vv = vectors[..., 0], vectors[..., 1], vectors[..., 2]
    return np.stack([np.stack([hh, hv], -1), np.stack([hv, vv], -1)], -2)


def _population_sigma(scene: ScatteringCovariance, channel: str) -> float:
    idx = RECIPROCAL_CHANNELS.index(channel)
    return float(np.real(scene.matrix[idx, idx]))


def gaussianity(errors: np.ndarray) -> dict:
    """How close the error distribution is to a Gaussian (Men et al. 2021, Fig. 2).

    Returns the sample skewness and excess kurtosis, the D'Agostino-Pearson K^2 p-value, and the
    Kolmogorov-Smirnov distance to the Gaussian with the sample mean and SD (``e2esim.distortion.normality``).
    """
    x = np.asarray(errors, dtype=float).ravel()
    mu, sd = x.mean(), x.std(ddof=1)
    result = {
        "skewness": normality.skewness(x),
        "excess_kurtosis": normality.kurtosis(x) - 3,
        "ks_distance": normality.ks_distance_normal(x, mu, sd) if sd > 0 else 0.0,
    }
    result["normaltest_pvalue"] = normality.normaltest_pvalue(x) if x.size >= 20 and sd > 0 else float("nan")
    return result
