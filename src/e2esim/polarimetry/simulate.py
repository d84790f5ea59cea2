"""Simulated calibration data through the full system model ``M = A R F S F T + N``.

Quegan et al. (2018), eq. (11); Men et al. (2021), eq. (1). Everything goes through
``e2esim.polarimetry.system_model`` (``measured_matrix`` for pixels, ``distortion_operator`` for the
4x4 operator that maps the scattering vector (hh, hv, vh, vv) to the measured one); nothing here is a
second system model.

Three levels of simulation, each exact in distribution:

* pixels: a quad-pol image of a distributed target (``simulate_scene``), any size, one system
  realisation;
* sufficient statistics: the 4x4 sample covariance of ``looks`` independent measured vectors, drawn
  directly from its complex Wishart distribution (``sample_measured_covariance``), vectorised over any
  number of system realisations: what a Monte Carlo over windows needs, without touching the pixels;
* chirp: an image whose Faraday rotation follows ``Omega(f) = Omega0 (f0 / f)^2`` across the range
  spectrum (``simulate_chirp_scene``), for the slope estimator of eq. (12).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.instrument.system_errors import SystemErrorSamples
from e2esim.polarimetry.system_model import RECIPROCAL_EMBEDDING, distortion_operator, measured_matrix
from e2esim.scene.covariance import ScatteringCovariance


@dataclass(frozen=True)
class SystemState:
    """Realisation(s) of the system: what the radar and the ionosphere do to the scattering matrix.

    delta : crosstalk (delta1..delta4), shape (..., 4), complex.
    f : channel imbalance (f1, f2), shape (..., 2), complex.
    omega : one-way Faraday rotation (rad), shape (...).
    gain : complex gain ``A e^{j phi}``, shape (...).
    The leading shapes broadcast together (one state, or one per Monte Carlo realisation).
    """

    delta: np.ndarray
    f: np.ndarray
    omega: np.ndarray
    gain: np.ndarray

    @classmethod
    def ideal(cls, omega=0.0) -> SystemState:
        """No crosstalk, no channel imbalance, unit gain, Faraday rotation ``omega`` (rad)."""
        omega = np.asarray(omega, dtype=float)
        shape = omega.shape
        return cls(np.zeros(shape + (4,), complex), np.ones(shape + (2,), complex), omega, np.ones(shape, complex))

    @classmethod
    def from_samples(cls, samples: SystemErrorSamples, omega) -> SystemState:
        """From ``SystemErrorModel.sample`` draws (real amplitude gain) and Faraday angles (rad)."""
        return cls(np.asarray(samples.delta), np.asarray(samples.f), np.asarray(omega, dtype=float),
                   np.asarray(samples.gain).astype(complex))

    @property
    def shape(self) -> tuple:
        return np.broadcast_shapes(self.delta.shape[:-1], self.f.shape[:-1], np.shape(self.omega), np.shape(self.gain))

    def operator(self) -> np.ndarray:
        """The 4x4 operator ``A (T^T kron R)(F^T kron F)``, shape ``shape + (4, 4)``."""
        k = distortion_operator(self.delta, self.f, self.omega)
        return np.asarray(self.gain)[..., None, None] * k


@dataclass(frozen=True)
class QuadPolImage:
    """A measured quad-pol image: the four complex channels, each of shape (ny, nx).

    ``hv`` is transmit h, receive v: the (row 1, column 0) element of ``[[hh, vh], [hv, vv]]``
    (docs/conventions.md).
    """

    hh: np.ndarray
    hv: np.ndarray
    vh: np.ndarray
    vv: np.ndarray

    def __post_init__(self):
        shapes = {np.shape(c) for c in (self.hh, self.hv, self.vh, self.vv)}
        if len(shapes) != 1:
            raise PhysicsInputError(f"the four channels must have the same shape, got {sorted(shapes)}")

    @property
    def shape(self) -> tuple:
        return np.shape(self.hh)

    def vector(self) -> np.ndarray:
        """Channels stacked on a last axis in the order (hh, hv, vh, vv)."""
        return np.stack([self.hh, self.hv, self.vh, self.vv], -1)

    @classmethod
    def from_vector(cls, m: np.ndarray) -> QuadPolImage:
        return cls(m[..., 0], m[..., 1], m[..., 2], m[..., 3])


def reciprocal_covariance4(scene) -> np.ndarray:
    """The 4x4 covariance of (S_hh, S_hv, S_vh, S_vv) of a reciprocal scene (S_vh = S_hv)."""
    c3 = scene.matrix if isinstance(scene, ScatteringCovariance) else np.asarray(scene, dtype=complex)
    e = RECIPROCAL_EMBEDDING
    return e @ c3 @ e.T


def measured_covariance(scene, state: SystemState, noise_power: float = 0.0) -> np.ndarray:
    """Population covariance ``<m m^H> = K C4 K^H + sigma_n I`` of the measured vector (hh, hv, vh, vv).

    scene : ScatteringCovariance (or 3x3 array), m^2/m^2. state : system realisation(s).
    noise_power : sigma_n, noise power in each measured channel (m^2/m^2). Shape ``state.shape + (4, 4)``.
    """
    k = state.operator()
    c4 = reciprocal_covariance4(scene)
    cov = k @ c4 @ np.swapaxes(k.conj(), -1, -2)
    return cov + noise_power * np.eye(4)


def complex_wishart(rng: np.random.Generator, cov: np.ndarray, looks: int) -> np.ndarray:
    """Sample covariance of ``looks`` independent CN(0, cov) vectors, without drawing them.

    ``looks * C_hat`` is complex Wishart CW_p(looks, cov): drawn by the Bartlett decomposition
    ``W = G T T^H G^H`` with ``G G^H = cov``, T lower triangular, ``|T_ii|^2 ~ Gamma(looks - i)`` and
    ``T_ij ~ CN(0, 1)`` below the diagonal (the 3x3 version is ``ScatteringCovariance.sample_covariance``).
    cov : shape (..., p, p), Hermitian positive semi-definite. Returns shape (..., p, p).
    """
    cov = np.asarray(cov, dtype=complex)
    p = cov.shape[-1]
    batch = cov.shape[:-2]
    root = matrix_root(cov)
    if looks < p:
        xi = (rng.standard_normal(batch + (looks, p)) + 1j * rng.standard_normal(batch + (looks, p))) / np.sqrt(2)
        x = xi @ np.swapaxes(root, -1, -2)
        return np.einsum("...ki,...kj->...ij", x, x.conj()) / looks
    t = np.zeros(batch + (p, p), dtype=complex)
    for i in range(p):
        t[..., i, i] = np.sqrt(rng.gamma(looks - i, 1.0, batch))
        for j in range(i):
            t[..., i, j] = (rng.standard_normal(batch) + 1j * rng.standard_normal(batch)) / np.sqrt(2)
    g = root @ t
    return g @ np.swapaxes(g.conj(), -1, -2) / looks


def matrix_root(cov: np.ndarray) -> np.ndarray:
    """G with G G^H = cov: Cholesky where possible, eigen-decomposition for singular matrices."""
    try:
        return np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        w, u = np.linalg.eigh(cov)
        return u * np.sqrt(np.clip(w, 0.0, None))[..., None, :]


def sample_measured_covariance(
    rng: np.random.Generator, scene, state: SystemState, noise_power: float, looks: int
) -> np.ndarray:
    """Sample covariance of ``looks`` measured vectors of a distributed target, one per realisation.

    Exact in distribution (Wishart), cost independent of ``looks``. Shape ``state.shape + (4, 4)``.
    """
    if looks < 1:
        raise PhysicsInputError(f"looks must be >= 1, got {looks}")
    return complex_wishart(rng, measured_covariance(scene, state, noise_power), looks)


def _reciprocal_matrices(vectors: np.ndarray) -> np.ndarray:
    """(..., 3) vectors (hh, hv, vv) -> (..., 2, 2) matrices [[hh, hv], [hv, vv]] (S_vh = S_hv)."""
    hh, hv, vv = vectors[..., 0], vectors[..., 1], vectors[..., 2]
    return np.stack([np.stack([hh, hv], -1), np.stack([hv, vv], -1)], -2)


def _noise(rng, shape, noise_power):
    return np.sqrt(noise_power / 2) * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape))


def simulate_scene(
    rng: np.random.Generator, scene: ScatteringCovariance, shape: tuple, state: SystemState, noise_power: float = 0.0
) -> QuadPolImage:
    """Quad-pol image of ``shape`` independent pixels of a distributed target, one system realisation.

    Pixels ``S ~ CN(0, C)`` (Men et al. 2021, Section IV step 1), measured through
    ``measured_matrix`` (Quegan et al. 2018, eq. 11) with independent noise CN(0, sigma_n) per channel.
    """
    if state.shape != ():
        raise PhysicsInputError("simulate_scene takes one system realisation (SystemState of shape ())")
    s = _reciprocal_matrices(scene.sample(rng, tuple(shape)))
    m = measured_matrix(s, state.delta, state.f, state.omega, state.gain)
    m = m + _noise(rng, m.shape, noise_power)
    return QuadPolImage(m[..., 0, 0], m[..., 1, 0], m[..., 0, 1], m[..., 1, 1])


def subband_frequencies(centre_hz: float, bandwidth_hz: float, n: int) -> np.ndarray:
    """Centres of ``n`` equal, contiguous sub-bands splitting the band ``centre +- bandwidth/2`` (Hz)."""
    edges = centre_hz - bandwidth_hz / 2 + bandwidth_hz * np.arange(n + 1) / n
    return 0.5 * (edges[1:] + edges[:-1])


def faraday_at_frequency(omega0, centre_hz: float, frequency_hz) -> np.ndarray:
    """``Omega(f) = Omega0 (f0 / f)^2``: Faraday rotation scales as 1/f^2 (Quegan et al. 2018, eq. 3)."""
    return np.asarray(omega0, dtype=float)[..., None] * (centre_hz / np.asarray(frequency_hz, dtype=float)) ** 2


def simulate_chirp_scene(
    rng: np.random.Generator,
    scene: ScatteringCovariance,
    shape: tuple,
    state: SystemState,
    centre_hz: float,
    bandwidth_hz: float,
    noise_power: float = 0.0,
    delta_slope: np.ndarray | None = None,
) -> QuadPolImage:
    """Quad-pol image whose Faraday rotation varies across the range spectrum (seed 003, eq. 12).

    Each azimuth line is built in the range-frequency domain: ``nx`` frequency bins spanning the band
    (sampling at the bandwidth), independent scattering coefficients CN(0, C) per bin (a white
    distributed target), the system model at each bin with ``Omega(f) = Omega0 (f0/f)^2`` (``state.omega``
    is Omega0 at the centre frequency), white noise, then an orthonormal inverse FFT to the SLC.
    delta_slope : optional change of each crosstalk term per Hz (shape (4,), complex): crosstalk
        ``delta + delta_slope (f - f0)``, the frequency-dependent crosstalk that biases eq. (12).
    """
    if state.shape != ():
        raise PhysicsInputError("simulate_chirp_scene takes one system realisation (SystemState of shape ())")
    ny, nx = shape
    freq = centre_hz + bandwidth_hz * np.fft.fftfreq(nx)  # bin k of an FFT of length nx
    omega = faraday_at_frequency(state.omega, centre_hz, freq)  # (nx,)
    delta = np.broadcast_to(state.delta, (nx, 4)).astype(complex)
    if delta_slope is not None:
        delta = delta + np.asarray(delta_slope, dtype=complex)[None, :] * (freq - centre_hz)[:, None]
    k = SystemState(delta, np.broadcast_to(state.f, (nx, 2)), omega, np.broadcast_to(state.gain, (nx,))).operator()
    ke = k @ RECIPROCAL_EMBEDDING  # (nx, 4, 3)
    spectra = scene.sample(rng, (ny, nx))  # (ny, nx, 3)
    m = np.einsum("fij,yfj->yfi", ke, spectra)
    m = m + _noise(rng, m.shape, noise_power)
    slc = np.fft.ifft(m, axis=1, norm="ortho")
    return QuadPolImage.from_vector(slc)
