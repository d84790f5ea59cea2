"""Pixel-level simulation of a stack and ground cancellation of the measured images: the brute-force reference.

For one realisation of the system errors and Faraday rotation of every pass: draw the joint scattering vectors
of all passes pixel by pixel from the stack covariance (eq. 4), measure each pass through the full system model
``M = g R F S F T + N`` (``measured_matrix``, Quegan et al. 2018 eq. 11), optionally correct each pass's
Faraday rotation for the co-polarised channels, form the per-pass estimates (hh, (hv + vh)/2, vv), and
*then* cancel the ground on these measured images as the processor does: I_r = sum_n w_rn I_n, and average
sum_r c_r |I_r|^2 over the pixels (BPS AGB ATBD eqs. 3.4-3.12). No step uses the fast path's algebra, so the
tests compare the two in distribution.
"""

from __future__ import annotations

import numpy as np

from e2esim.polarimetry.system_model import RECIPROCAL_CHANNELS, faraday_matrix, measured_matrix, to_vector
from e2esim.stack.combination import PassCombination
from e2esim.stack.montecarlo import ESTIMATES, StackMonteCarloErrors
from e2esim.stack.scene import StackScene


def measured_stack_images(scene_vectors: np.ndarray, delta, f, omega, gain, noise_power: float,
                          rng: np.random.Generator, correct_copol: bool = True) -> np.ndarray:
    """Per-pass estimates (pixels, N, 3) of (hh, hv, vv) from the measured quad-pol images of every pass.

    scene_vectors : (pixels, N, 3) true (S_hh, S_hv, S_vv) of every pass. delta (N, 4), f (N, 2), omega (N,),
    gain (N,) : the system of every pass.
    """
    hh, hv, vv = (scene_vectors[..., i] for i in range(3))
    s = np.stack([np.stack([hh, hv], -1), np.stack([hv, vv], -1)], -2)  # (pixels, N, 2, 2)
    m = measured_matrix(s, delta, f, omega, gain.astype(complex))
    m = m + np.sqrt(noise_power / 2) * (rng.standard_normal(m.shape) + 1j * rng.standard_normal(m.shape))
    if correct_copol:
        rot = faraday_matrix(-np.asarray(omega, float))
        m = rot @ m @ rot  # Quegan et al. (2018), eq. (4), each pass with its own Faraday rotation
    return to_vector(m) @ ESTIMATES.T


def ground_cancel(images: np.ndarray, combination: PassCombination) -> np.ndarray:
    """The combined covariance sum_r c_r mean_pixels(I_r I_r^H) of images (pixels, N, 3): I_r = sum_n w_rn I_n."""
    combos = np.einsum("rn,knc->rkc", combination.weights, images)  # (R, pixels, 3)
    return np.einsum("r,rki,rkj->ij", combination.coefficients, combos, combos.conj()) / images.shape[0]


def simulate_stack_images(scene: StackScene, errors, faraday, combination: PassCombination,
                          rng: np.random.Generator, looks: int, realisations: int, reference: str = "scene",
                          correct_copol: bool = True, scene_vectors: np.ndarray | None = None) -> StackMonteCarloErrors:
    """Brute-force Monte Carlo (module docstring); same outputs as ``simulate_stack`` (one noise draw each).
    scene_vectors : the (L, N, 3) vectors of the one scene ("scene" reference), or None to draw them."""
    n = scene.passes
    delta, f, gain = errors.sample(rng, realisations, n)
    omega = faraday.sample(rng, realisations, n)
    fixed = None
    if reference == "scene":
        fixed = scene.sample(rng, looks) if scene_vectors is None else np.asarray(scene_vectors)
    combined = np.zeros((realisations, 1, 3, 3), complex)
    for j in range(realisations):
        s = fixed if fixed is not None else scene.sample(rng, looks)
        images = measured_stack_images(s, delta[j], f[j], omega[j], gain[j], errors.system.noise_power, rng,
                                       correct_copol)
        combined[j, 0] = ground_cancel(images, combination)
    if fixed is not None:
        ideal = ground_cancel(fixed, combination)
    else:
        ideal = combination.combined_covariance(scene.blocks())
    errs = {ch: np.real(combined[..., i, i]) - np.real(ideal[i, i]) for i, ch in enumerate(RECIPROCAL_CHANNELS)}
    refs = {ch: np.asarray(np.real(ideal[i, i])) for i, ch in enumerate(RECIPROCAL_CHANNELS)}
    return StackMonteCarloErrors(errs, refs, looks, realisations, 1, "brute_force", combined)
