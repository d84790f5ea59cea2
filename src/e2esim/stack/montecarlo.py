"""Exact Monte Carlo of a multi-pass estimate for every channel: the full system model on every pass, then the
passes combined (single date, multi-date average, ground cancellation) as the processor does.

Each realisation draws the system errors of every pass (``StackSystemErrors``, eq. 8), the Faraday rotation of
every pass (``StackFaraday``, eq. 6) and, per pass, the measured vector m_n = g_n K_n s_n + n_n of Men et al.
(2021), eq. (1) (K_n = (T_n^T kron R_n)(F_n^T kron F_n)); the co-polarised channels may be corrected for each
pass's Faraday rotation, F(-Omega_hat_n) M F(-Omega_hat_n) (Quegan et al. 2018, eq. 4) with the true rotation or
an estimate of it (``StackFaraday.residual``), which leaves the symmetrised HV unchanged. The per-pass estimates
z_n = (M_hh, (M_hv + M_vh)/2, M_vv) form the 3N-vector z = A s + nu.

Fast path, exact in distribution (cost independent of the looks L), as ``e2esim.distortion.montecarlo``:

* reference "population": the sample covariance W of L vectors z is complex Wishart with covariance
  A C A^H + D (D = sigma_n diag(1, 1/2, 1) per pass), drawn directly;
* reference "scene": one scene, its sample covariance C_hat drawn once; given it, the noisy sample covariance
  is the noncentral complex Wishart of co-pol eq. (7.1) in 3N dimensions (ground-cancellation.md, eq. 18), drawn
  by issue 12's ``covariance_montecarlo.noncentral_wishart`` with the factor K = A F, F F^H = L C_hat.

Every estimate is then sum_r c_r sum_nm w_rn w_rm^* W_nm: the combined (for ground cancellation the
ground-cancelled) 3 x 3 covariance of (hh, hv, vv), kept for a multi-channel estimator; its diagonal are the
channel estimates, whose errors are taken against the estimator's value for the sample scene ("scene") or for
the covariance ("population"). The noncentral Wishart computes only the entries of W with a non-zero weight
Q_mn (``read_entries``): the others would enter the sum multiplied by an exact 0. Every draw is still made, in
the same order, so the numbers are those of the full W bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from e2esim.blas_threads import single_blas_thread
from e2esim.distortion.covariance_montecarlo import noncentral_wishart
from e2esim.distortion.montecarlo import MonteCarloErrors
from e2esim.errors import PhysicsInputError
from e2esim.polarimetry.simulate import SystemState, complex_wishart, matrix_root
from e2esim.polarimetry.system_model import (
    ESTIMATOR_WEIGHTS,
    RECIPROCAL_CHANNELS,
    batched_kron,
    faraday_matrix,
)
from e2esim.stack.combination import PassCombination
from e2esim.stack.faraday import StackFaraday
from e2esim.stack.scene import StackScene
from e2esim.stack.system import StackSystemErrors

ESTIMATES = np.stack([ESTIMATOR_WEIGHTS[c] for c in RECIPROCAL_CHANNELS])
"""3 x 4: the per-pass estimates (hh, hv, vv) from the measured (hh, hv, vh, vv): M_hh, (M_hv + M_vh)/2, M_vv."""
NOISE_FACTORS = np.sum(ESTIMATES**2, axis=1)
"""Noise power of each estimate per unit noise power per measured channel: (1, 1/2, 1)."""


@dataclass(frozen=True)
class StackMonteCarloErrors(MonteCarloErrors):
    """``MonteCarloErrors`` of the channels (hh, hv, vv) plus the combined covariances (M, N_noise, 3, 3)."""

    combined: np.ndarray = field(default=None, repr=False)


def faraday_correction(omega: np.ndarray) -> np.ndarray:
    """vec(F(-Omega) M F(-Omega)) = (F(-Omega)^T kron F(-Omega)) vec M: the correcting operator (..., 4, 4).

    ``distortion_operator`` with no crosstalk and no imbalance, without its identity distortion factor: a product
    with the identity is exact, so the numbers are the same bit for bit (tested), at a third of the cost."""
    rot = faraday_matrix(-np.asarray(omega, float))
    return batched_kron(np.swapaxes(rot, -1, -2), rot)


def pass_operators(delta, f, omega, gain, correct_copol: bool, omega_hat=None) -> np.ndarray:
    """A_n: the 3 x 3 maps from (S_hh, S_hv, S_vv) of each pass to its estimates (..., 3, 3); the co-polarised
    channels corrected with ``omega_hat`` (None: the true ``omega``) when ``correct_copol``."""
    k = _embedded(SystemState(delta, f, omega, gain.astype(complex)).operator())
    if correct_copol:  # the symmetrised HV row is unchanged by the correction, whatever omega_hat (tested)
        k = faraday_correction(omega if omega_hat is None else omega_hat) @ k
    return _estimates(k)


def _embedded(k: np.ndarray) -> np.ndarray:
    """k @ RECIPROCAL_EMBEDDING (..., 4, 3) by its columns k_hh, k_hv + k_vh, k_vv: the product's weights are exact
    0s and 1s, so each column of the product is one of these bit for bit (tested), without a batch of matrix
    products."""
    return np.stack([k[..., 0], k[..., 1] + k[..., 2], k[..., 3]], -1)


def _estimates(k: np.ndarray) -> np.ndarray:
    """ESTIMATES @ k (..., 3, 3) by its rows k_hh, k_hv / 2 + k_vh / 2, k_vv: the weights are exact 0s, 1s and
    halves (a halving is exact), so bit for bit the product (tested)."""
    return np.stack([k[..., 0, :], 0.5 * k[..., 1, :] + 0.5 * k[..., 2, :], k[..., 3, :]], -2)


def _block_diagonal(a: np.ndarray) -> np.ndarray:
    """(..., N, 3, 3) -> (..., 3N, 3N) block-diagonal."""
    n = a.shape[-3]
    out = np.zeros(a.shape[:-3] + (3 * n, 3 * n), complex)
    for i in range(n):
        out[..., 3 * i:3 * i + 3, 3 * i:3 * i + 3] = a[..., i, :, :]
    return out


@single_blas_thread  # batches of small products: e2esim.blas_threads
def simulate_stack(scene: StackScene, errors: StackSystemErrors, faraday: StackFaraday,
                   combination: PassCombination, rng: np.random.Generator, looks: int, realisations: int,
                   noise_realisations: int = 1, reference: str = "scene", correct_copol: bool = True,
                   scene_vectors: np.ndarray | None = None) -> StackMonteCarloErrors:
    """Simulate the errors of the combined estimates of (hh, hv, vv) (module docstring).

    scene_vectors : optional (L, N, 3) scattering vectors of the one scene ("scene" reference), so that the
    fast path and the pixel-level simulation (``e2esim.stack.images``) can be compared on the same scene.
    """
    if reference not in ("scene", "population"):
        raise ValueError(f"reference must be 'scene' or 'population', got {reference!r}")
    n = scene.passes
    if reference == "scene" and looks < 3 * n:
        raise PhysicsInputError(f"the fast Monte Carlo of one scene needs at least 3N = {3 * n} looks, got {looks}")
    # draw order: system errors, Faraday rotation, its estimates' residuals (when corrected with them), scene, noise
    delta, f, gain = errors.sample(rng, realisations, n)
    omega = faraday.sample(rng, realisations, n)
    omega_hat = faraday.corrections(rng, omega) if correct_copol else None
    big = _block_diagonal(pass_operators(delta, f, omega, gain, correct_copol, omega_hat))  # (M, 3N, 3N)
    if noise_realisations > 1:  # (one: no copy of M (3N x 3N) operators)
        big = np.repeat(big, noise_realisations, axis=0)
    d = np.tile(errors.system.noise_power * NOISE_FACTORS, n)  # noise power of every estimate
    if reference == "population":
        cov = big @ scene.matrix @ np.swapaxes(big.conj(), -1, -2) + np.diag(d)
        w = complex_wishart(rng, cov, looks)
        c_ref = scene.matrix
    else:
        if scene_vectors is None:
            c_ref = complex_wishart(rng, scene.matrix, looks)
        else:
            x = np.asarray(scene_vectors).reshape(looks, 3 * n)
            c_ref = x.T @ x.conj() / looks
        factor = np.moveaxis(big @ matrix_root(looks * c_ref), 0, -1)  # K = A F, F F^H = L C_hat: (3N, 3N, M)
        w = noncentral_wishart(rng, factor, np.sqrt(d), looks, read_entries(combination))  # (3N, 3N, M)
        w = w.reshape(n, 3, n, 3, -1).transpose(4, 0, 1, 2, 3)  # (M, N, 3, N, 3): a view, _combine copies once
    combined = _combine(combination, w.reshape(-1, n, 3, n, 3))
    ideal = _combine(combination, c_ref.reshape(n, 3, n, 3)[None])[0]
    combined = combined.reshape(realisations, noise_realisations, 3, 3)
    errs = {ch: np.real(combined[..., i, i]) - np.real(ideal[i, i]) for i, ch in enumerate(RECIPROCAL_CHANNELS)}
    refs = {ch: np.asarray(np.real(ideal[i, i])) for i, ch in enumerate(RECIPROCAL_CHANNELS)}
    return StackMonteCarloErrors(errs, refs, looks, realisations, noise_realisations, "fast", combined)


def read_entries(combination: PassCombination) -> np.ndarray:
    """The (3N, 3N) mask of the entries of W that ``_combine`` reads with a non-zero weight: W[n, :, m, :] where
    Q_mn != 0 (Q Hermitian, so the mask is symmetric). The others enter its sums as products with an exact 0,
    which add nothing whatever W holds there, so they need not be computed (0 in the single-date estimate's 48 of
    49 pass pairs of a 7-pass stack, 42 of the multi-date average's)."""
    return np.kron(combination.matrix.T != 0, np.ones((3, 3), bool))


def _combine(combination: PassCombination, w: np.ndarray) -> np.ndarray:
    """sum_r c_r sum_nm w_rn w_rm^* W[n, :, m, :] = sum_nm Q_mn W[n, :, m, :] for W of shape (..., N, 3, N, 3),
    Q = ``combination.matrix``: one matrix-vector product over the N^2 pass pairs (about 8x faster than the
    four-operand einsum at 7 passes; the reordered sum moves the numbers by rounding only, docs/number-changes.md).
    Each output is the same length-N^2 dot product whatever the number of leading cases (bit for bit per case)."""
    n = w.shape[-4]
    lead = w.shape[:-4]
    pairs = np.moveaxis(w, (-4, -2), (-2, -1)).reshape(-1, n * n)  # (... * 9, N^2): rows (i, j), columns (n, m)
    return (pairs @ combination.matrix.T.reshape(n * n)).reshape(lead + (3, 3))

