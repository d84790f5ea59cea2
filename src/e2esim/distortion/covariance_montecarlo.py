"""Monte Carlo of the full estimated covariance of (S_hh, S_hv, S_vv): a fast exact path and a brute-force
pixel-level reference (docs/theory/co-pol-error.md, sec. 7).

The design is Men et al. (2021), Section IV, for all channels at once: a scene of L looks; M realisations of
system errors, Faraday rotation (and, when the co-polarised channels are corrected, of the estimate used);
N noise realisations each; the 3x3 sample covariance of the estimated vectors
``(S_hat_hh, (S_hat_hv + S_hat_vh)/2, S_hat_vv)`` over the L looks.

Fast path, exact in distribution and independent of L. For one realisation the estimated vector of look k is
``y_k = A s_k + nu_k`` (A from ``expansion.estimator_matrix``, nu_k ~ CN(0, Sigma_nu), Sigma_nu = sigma_n
diag(1, 1/2, 1) before and after a correction, which rotates the four noise terms orthogonally). Given the
scene, the L x 3 matrix of the y_k has mean rank <= 3 and i.i.d. rows, so a unitary rotation of the look axis
puts the whole mean into three rows (co-pol eq. 7.1):

    sum_k y_k y_k^H = sum_{j=1}^{3} (m_j + w_j)(m_j + w_j)^H + Sigma_nu^(1/2) B B^H Sigma_nu^(1/2),

a noncentral complex Wishart: m_j the columns of A K with K K^H = L C_hat (the scene's sample covariance,
itself complex Wishart CW_3(L, C), drawn by Bartlett), w_j ~ CN(0, Sigma_nu), B the Bartlett factor of
CW_3(L - 3, I). The brute force multiplies out ``M = gain R F S F T + N`` and the correction per pixel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.distortion.expansion import estimate_channels, estimator_entries
from e2esim.distortion.faraday_correction import FaradayCorrection
from e2esim.distortion.montecarlo import METHODS, reciprocal_matrices
from e2esim.distortion.polarimetric_moments import NOISE_FACTORS
from e2esim.polarimetry.system_model import faraday_matrix, measured_matrix

_BRUTE_FORCE_CHUNK = 1_000_000  # pixel x realisation products held in memory at once
_MIN_BARTLETT_LOOKS = 6  # the noise Wishart of L - 3 degrees of freedom needs L - 3 >= 3


@dataclass(frozen=True)
class CovarianceSamples:
    """Simulated estimated covariances.

    covariance : (M, N, 3, 3) complex sample covariance of the estimated (hh, hv, vv) over the looks.
    reference : (3, 3) the covariance the errors are taken against: the scene's own sample covariance
        (``scene``) or the population covariance (``population``).
    looks, realisations, noise_realisations : L, M, N. method : "fast" or "brute_force".
    """

    covariance: np.ndarray
    reference: np.ndarray
    looks: int
    realisations: int
    noise_realisations: int
    method: str

    @property
    def errors(self) -> np.ndarray:
        """(M, N, 3): sigma_hat_p - sigma_p for (hh, hv, vv), m^2/m^2."""
        return np.real(np.diagonal(self.covariance - self.reference, axis1=-2, axis2=-1))


def simulate_covariance(scene, system, faraday, rng: np.random.Generator, looks: int, realisations: int,
                        noise_realisations: int = 1, reference: str = "scene", method: str = "fast",
                        correction: FaradayCorrection | None = None,
                        scene_vectors: np.ndarray | None = None) -> CovarianceSamples:
    """Simulate the estimated covariance under the full model (Men et al. 2021, eq. 1 and Section IV).

    reference : "scene" (one scene for every realisation, errors against its own sample covariance, eq. 17) or
        "population" (a new scene per realisation, errors against the covariance). correction : how the
        co-polarised channels treat Faraday rotation (default: not corrected). scene_vectors : (L, 3)
        vectors of a given scene ("scene" only), so that both methods can be compared on the same scene.
    Draw order, the same in both methods: system errors, Omega, the correction's estimate, scene, noise.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if reference not in ("scene", "population"):
        raise ValueError(f"reference must be 'scene' or 'population', got {reference!r}")
    if scene_vectors is not None and reference != "scene":
        raise ValueError("scene_vectors can only be given with reference='scene'")
    correction = correction or FaradayCorrection()
    errs = system.sample(rng, realisations)
    omega = faraday.sample(rng, realisations)
    omega_hat = correction.estimate(rng, omega)
    sigma_nu = system.noise_power * NOISE_FACTORS  # noise power of each estimated channel
    if method == "fast":
        a = estimator_entries(errs.delta, errs.f, omega, omega_hat, errs.gain)  # (3, 3, M)
        cov, ref, looks = _fast(scene, a, sigma_nu, rng, looks, noise_realisations, reference, scene_vectors)
    else:
        cov, ref, looks = _brute_force(scene, errs, omega, omega_hat, system.noise_power, rng, looks,
                                       noise_realisations, reference, scene_vectors)
    return CovarianceSamples(cov, ref, looks, realisations, noise_realisations, method)


def _fast(scene, a, sigma_nu, rng, looks, n_noise, reference, scene_vectors):
    """a : (3, 3, M) entries of A per realisation (``estimator_entries``)."""
    m = a.shape[-1]
    if scene_vectors is not None:
        looks = scene_vectors.shape[0]
    if looks < _MIN_BARTLETT_LOOKS:  # tiny windows: the looks themselves are cheap
        s = scene_vectors if scene_vectors is not None else scene.sample(
            rng, looks if reference == "scene" else (m, looks))
        return _small_window(s, np.moveaxis(a, -1, 0), sigma_nu, rng, n_noise, reference, scene)
    if reference == "scene":
        if scene_vectors is not None:
            c_hat = np.einsum("ki,kj->ij", scene_vectors, scene_vectors.conj()) / looks
        else:
            c_hat = scene.sample_covariance(rng, looks)
        ref = c_hat
        factor = np.linalg.cholesky(looks * c_hat)[:, :, None]  # (3, 3, 1)
    else:
        c_hat = scene.sample_covariance(rng, looks, m)
        ref = np.asarray(scene.matrix)
        factor = np.moveaxis(np.linalg.cholesky(looks * c_hat), 0, -1)  # (3, 3, M)
    # K = A F with F F^H = L C_hat, so K K^H = A L C_hat A^H (co-pol eq. 7.1); entry by entry over M
    k = np.array([[sum(a[p, c] * factor[c, j] for c in range(3)) for j in range(3)] for p in range(3)])
    sd = np.sqrt(sigma_nu)
    out = np.empty((m, n_noise, 3, 3), dtype=complex)
    for j in range(n_noise):
        out[:, j] = np.moveaxis(noncentral_wishart(rng, k, sd, looks), -1, 0)
    return out, ref, looks


def noncentral_wishart(rng: np.random.Generator, factor: np.ndarray, noise_sd: np.ndarray, looks: int,
                       entries: np.ndarray | None = None) -> np.ndarray:
    """(1/L) sum_k y_k y_k^H over L looks of y_k = x_k + nu_k, nu_k ~ CN(0, diag(noise_sd^2)) independent of the
    signal, given the signal's scatter factor: co-pol eq. (7.1) in any dimension p, exact and at a cost
    independent of L.

    factor : K (p, p, M) with K K^H = sum_k x_k x_k^H (e.g. A F with F F^H = L C_hat). noise_sd : (p,).
    looks : L >= p. A unitary rotation of the look axis puts the signal into p rows:
    sum_j (k_j + w_j)(k_j + w_j)^H + D^1/2 B B^H D^1/2, w_j ~ CN(0, D), B B^H ~ CW_p(L - p, I). Returns (p, p, M).
    entries : optional (p, p) symmetric boolean mask of the entries the caller reads (None: all); the others are
    returned as 0. Every draw is still made, in the same order, so the generator's stream and every computed entry
    are those of the full matrix bit for bit: only the unread products are skipped (a single-date estimate of a
    7-pass stack reads 9 of the 441).
    """
    p, m = factor.shape[0], factor.shape[-1]
    sd = np.asarray(noise_sd, dtype=float)
    # in place: the numbers of (factor + sd w) and (gram + sd sd^T B B^H) / L bit for bit, without their temporaries
    # (megabytes for the 3N-dimensional stacks)
    v = _complex_normal(rng, (p, p, m))
    v *= sd[:, None, None]
    v += factor  # columns m_j + w_j
    total = _gram(v, entries)
    noise = _bartlett_gram(rng, looks - p, m, p, entries)
    scale = np.outer(sd, sd)[:, :, None]
    for rows, cols in _spans(entries, p):  # the same operations on every entry computed; the others stay 0
        part = noise[rows, cols]
        part *= scale[rows, cols]
        out = total[rows, cols]
        out += part
        out /= looks
    return total


def _spans(entries: np.ndarray | None, p: int) -> list:
    """(row slice, column slice) pairs covering the True entries of a (p, p) mask (None: one pair, everything):
    per row, from its first to its last True column."""
    if entries is None:
        return [(slice(None), slice(None))]
    spans = []
    for i in range(p):
        cols = np.flatnonzero(entries[i])
        if cols.size:
            spans.append((slice(i, i + 1), slice(cols[0], cols[-1] + 1)))
    return spans


def _small_window(s, a, sigma_nu, rng, n_noise, reference, scene):
    """Windows of fewer than 6 looks: the estimated vectors of every look, drawn directly."""
    looks = s.shape[-2]
    signal = np.einsum("mpc,kc->mkp" if s.ndim == 2 else "mpc,mkc->mkp", a, s)  # (M, L, 3)
    out = np.empty((a.shape[0], n_noise, 3, 3), dtype=complex)
    for j in range(n_noise):
        y = signal + np.sqrt(sigma_nu) * _complex_normal(rng, signal.shape)
        out[:, j] = np.einsum("mkp,mkq->mpq", y, y.conj()) / looks
    ref = np.einsum("ki,kj->ij", s, s.conj()) / looks if reference == "scene" else np.asarray(scene.matrix)
    return out, ref, looks


def _brute_force(scene, errs, omega, omega_hat, sigma_n, rng, looks, n_noise, reference, scene_vectors):
    """Pixel by pixel: M = gain R F S F T + N, rotated back by F(-W_hat) when corrected (eq. 1)."""
    m = omega.shape[0]
    if reference == "scene":
        s = scene_vectors if scene_vectors is not None else scene.sample(rng, looks)
        looks = s.shape[0]
        fixed = reciprocal_matrices(s)[None]  # (1, L, 2, 2)
        ref = np.einsum("ki,kj->ij", s, s.conj()) / looks
    else:
        ref = np.asarray(scene.matrix)
    out = np.empty((m, n_noise, 3, 3), dtype=complex)
    per_chunk = max(1, _BRUTE_FORCE_CHUNK // max(looks, 1))
    for start in range(0, m, per_chunk):
        sl = slice(start, min(start + per_chunk, m))
        true = fixed if reference == "scene" else reciprocal_matrices(scene.sample(rng, (sl.stop - sl.start, looks)))
        signal = measured_matrix(true, errs.delta[sl, None, :], errs.f[sl, None, :], omega[sl, None],
                                 gain=errs.gain[sl, None])  # (k, L, 2, 2)
        back = None if omega_hat is None else faraday_matrix(-omega_hat[sl])[:, None]
        for j in range(n_noise):
            meas = signal + np.sqrt(sigma_n / 2) * _complex_normal(rng, signal.shape, unit=False)
            if back is not None:
                meas = back @ meas @ back
            y = estimate_channels(meas)  # (k, L, 3)
            out[sl, j] = np.einsum("mkp,mkq->mpq", y, y.conj()) / looks
    return out, ref, looks


def _complex_normal(rng, shape, unit: bool = True) -> np.ndarray:
    """CN(0, 1) draws (``unit=False``: real and imaginary parts each N(0, 1), power 2): the real parts drawn
    first, then the imaginary, written into one complex array. The numbers of ``(x + 1j y) / sqrt(2)`` bit for bit
    (numpy's complex division by sqrt(2) + 0j multiplies each part by 1 / sqrt(2)), without its complex
    temporaries."""
    z = np.empty(shape, dtype=complex)
    for part in (z.real, z.imag):
        part[...] = rng.standard_normal(shape)
        if unit:
            part *= 1.0 / np.sqrt(2.0)
    return z


def _bartlett_gram(rng, dof: int, size: int, p: int = 3, entries: np.ndarray | None = None) -> np.ndarray:
    """B B^H ~ CW_p(dof, I), shape (p, p, size), by the Bartlett decomposition: B lower triangular,
    |B_ii|^2 ~ Gamma(dof - i), B_ij ~ CN(0, 1) below the diagonal, row by row (as
    ``ScatteringCovariance.sample_covariance``); for dof < p, the gram of dof CN(0, I) vectors. entries: the
    (p, p) symmetric mask of the entries computed, the others 0 (None: all); every draw is made either way."""
    if dof < p:
        z = _complex_normal(rng, (p, max(dof, 0), size))
        return _gram(z, entries)
    d = [np.sqrt(rng.gamma(dof - i, 1.0, size)) for i in range(p)]
    below = iter(_complex_normal(rng, (p * (p - 1) // 2, size)))
    b = [[next(below) for _ in range(i)] + [d[i]] for i in range(p)]  # row i: B_i0 .. B_ii
    bc = [[x.conj() for x in row[:-1]] for row in b]  # their conjugates, once each
    g = np.empty((p, p, size), dtype=complex) if entries is None else np.zeros((p, p, size), dtype=complex)
    for i in range(p):
        if entries is None or entries[i, i]:
            g[i, i] = sum(np.abs(b[i][k]) ** 2 for k in range(i)) + d[i] ** 2
        for j in range(i):
            if entries is None or entries[i, j]:
                g[i, j] = sum(b[i][k] * bc[j][k] for k in range(j)) + b[i][j] * d[j]
                g[j, i] = g[i, j].conj()
    return g


def _gram(x: np.ndarray, entries: np.ndarray | None = None) -> np.ndarray:
    """x x^H for x of shape (p, J, size), entry by entry over contiguous vectors: (p, p, size); only the
    ``entries`` of a (p, p) symmetric mask, the others 0 (None: all)."""
    p = x.shape[0]
    # the conjugates of the rows read (all, or those of a column of ``entries``)
    xc = x.conj() if entries is None else {j: x[j].conj() for j in np.flatnonzero(entries.any(0))}
    g = np.empty((p, p, x.shape[-1]), dtype=complex) if entries is None else np.zeros((p, p, x.shape[-1]), complex)
    for i in range(p):
        for j in range(i, p):
            if entries is not None and not entries[i, j]:
                continue
            g[i, j] = (x[i] * xc[j]).sum(0)
            if j != i:
                g[j, i] = g[i, j].conj()
    return g


