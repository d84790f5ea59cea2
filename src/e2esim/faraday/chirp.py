"""Faraday rotation from the chirp: sub-band Bickel-Bates estimates and the slope estimator of eq. (12).

Quegan et al. (2018), Section 5.2: Omega is inversely proportional to f^2 (eq. 3), so across the chirp
``dOmega/df ~ -2 Omega0 / f0`` (eq. 12), and the slope of the Faraday rotation estimated in sub-bands
gives ``Omega0 = -(f0 / 2) dOmega/df``, "almost unaffected by cross-talk" if the crosstalk does not change
across the band. isce3 implements the continuous version (``FaradayRotEstBickelBates(use_slope_freq=True)``,
after Papathanassiou & Kim 2017): FFT in range, cross-spectrum of the circular channels, linear fit of
its phase / 4 against RF frequency. Here the band is split into ``n`` contiguous sub-bands.

Precision. K sub-bands of a window of L independent samples have L/K samples each; with the sub-band
Bickel-Bates variance ``v(L/K)`` (``faraday_theory``) the least-squares slope has variance
``v(L/K) / sum_k (f_k - f_mean)^2``, and ``SD(Omega0) = (f0/2) SD(slope)``. For large L/K, ``v = 1/(16 SNR L/K)``
and ``sum (f_k - f_mean)^2 = K B^2 (1 - 1/K^2) / 12``, so ``SD(Omega0) ~ (sqrt(3)/4) (f0/B) / sqrt(SNR L)``,
almost independent of K: for BIOMASS (f0/B = 72.5) about 31 / sqrt(SNR L) rad, 180 times the
Bickel-Bates SD of the full band.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.faraday.estimators import (
    AMBIGUITY_PERIOD,
    Z_A,
    Z_B,
    BickelBates,
    check_window,
)
from e2esim.faraday.theory import bickel_bates_variance
from e2esim.polarimetry.simulate import (
    QuadPolImage,
    SystemState,
    faraday_at_frequency,
    sample_measured_covariance,
    subband_frequencies,
)


@dataclass(frozen=True)
class ChirpFaradayEstimate:
    """Faraday rotation from the chirp slope, per window.

    omega0 : Omega at the centre frequency from the slope, eq. (12) (rad), shape (...).
    slope : dOmega/df (rad/Hz), shape (...). intercept : the fitted Omega at f0 (rad): the full-band
        Bickel-Bates estimate, with its crosstalk bias. subband_omega : (..., K) unwrapped sub-band
        estimates (rad). frequencies : (K,) sub-band centres (Hz). looks : samples per sub-band.
    """

    omega0: np.ndarray
    slope: np.ndarray
    intercept: np.ndarray
    subband_omega: np.ndarray
    frequencies: np.ndarray
    looks: int


def fit_slope(subband_omega: np.ndarray, frequencies: np.ndarray, centre_hz: float):
    """Least-squares line through (f_k, Omega_k): returns (Omega0 by eq. 12, slope rad/Hz, intercept at f0).

    The sub-band estimates are unwrapped (period pi/2) before the fit; equal weights (equal sub-bands).
    """
    om = np.unwrap(np.asarray(subband_omega, dtype=float), period=AMBIGUITY_PERIOD, axis=-1)
    x = np.asarray(frequencies, dtype=float) - centre_hz
    xm = x.mean()
    ym = om.mean(axis=-1)
    slope = np.sum((x - xm) * (om - ym[..., None]), axis=-1) / np.sum((x - xm) ** 2)
    intercept = ym - slope * xm
    return -0.5 * centre_hz * slope, slope, intercept, om


class ChirpSlopeEstimator:
    """Omega0 from the slope of sub-band Bickel-Bates estimates across the chirp (eq. 12).

    centre_hz, bandwidth_hz : the chirp (BIOMASS: 435 MHz, 6 MHz). subbands : number K of sub-bands (>= 2).
    """

    name = "chirp_slope"

    def __init__(self, centre_hz: float, bandwidth_hz: float, subbands: int = 4):
        if not (centre_hz > 0 and bandwidth_hz > 0 and bandwidth_hz < 2 * centre_hz):
            raise PhysicsInputError(
                f"need 0 < bandwidth < 2 x centre frequency, got centre {centre_hz!r} Hz, bandwidth {bandwidth_hz!r} Hz"
            )
        if int(subbands) != subbands or subbands < 2:
            raise PhysicsInputError(f"subbands must be an integer >= 2, got {subbands!r}")
        self.centre_hz = float(centre_hz)
        self.bandwidth_hz = float(bandwidth_hz)
        self.subbands = int(subbands)
        self.frequencies = subband_frequencies(self.centre_hz, self.bandwidth_hz, self.subbands)

    def from_subband_covariances(self, covs: np.ndarray, looks: int) -> ChirpFaradayEstimate:
        """From (..., K, 4, 4) sample covariances of the K sub-band images (``looks`` samples each)."""
        if covs.shape[-3:] != (self.subbands, 4, 4):
            raise PhysicsInputError(f"expected covariances of shape (..., {self.subbands}, 4, 4), got {covs.shape}")
        omega_k = BickelBates().from_covariance(covs, looks).omega
        omega0, slope, intercept, om = fit_slope(omega_k, self.frequencies, self.centre_hz)
        return ChirpFaradayEstimate(omega0, slope, intercept, om, self.frequencies, looks)

    def estimate(self, image: QuadPolImage, window: tuple | None = None) -> ChirpFaradayEstimate:
        """From an SLC image sampled at the bandwidth: per (azimuth, range) block, FFT in range, the
        cross-spectrum of the circular channels summed over azimuth and over the bins of each sub-band."""
        window = check_window(window, image.shape) or image.shape
        wy, wx = window
        if wx < 2 * self.subbands:
            raise PhysicsInputError(f"a range window of {wx} samples cannot be split into {self.subbands} sub-bands")
        ny, nx = image.shape[0] // wy, image.shape[1] // wx
        if ny == 0 or nx == 0:
            raise PhysicsInputError(f"window {window} is larger than the image {image.shape}")
        m = image.vector()[: ny * wy, : nx * wx]
        blocks = m.reshape(ny, wy, nx, wx, 4)
        za = np.fft.fft(blocks @ Z_A, axis=3)
        zb = np.fft.fft(blocks @ Z_B, axis=3)
        cross = (za * np.conj(zb)).sum(axis=1)  # (ny, nx, wx) summed over azimuth
        freq = self.bandwidth_hz * np.fft.fftfreq(wx)
        order = np.argsort(freq)
        groups = np.array_split(order, self.subbands)
        per_band = np.stack([cross[..., g].sum(axis=-1) for g in groups], -1)  # (ny, nx, K)
        frequencies = self.centre_hz + np.array([freq[g].mean() for g in groups])
        omega_k = np.angle(per_band) / 4
        omega0, slope, intercept, om = fit_slope(omega_k, frequencies, self.centre_hz)
        looks = wy * min(len(g) for g in groups)
        return ChirpFaradayEstimate(omega0, slope, intercept, om, frequencies, looks)


def sample_subband_covariances(
    rng: np.random.Generator,
    scene,
    state: SystemState,
    noise_power: float,
    looks: int,
    estimator: ChirpSlopeEstimator,
    delta_slope: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """Sample covariances of the K sub-band images of a window of ``looks`` samples (L/K each).

    ``state.omega`` is Omega0 at the centre frequency; sub-band k sees ``Omega0 (f0/f_k)^2``; distinct
    sub-bands of a white distributed target have independent speckle. delta_slope : crosstalk change
    per Hz (4,), complex. Returns ((..., K, 4, 4), looks per sub-band).
    """
    k = estimator.subbands
    per_band = looks // k
    if per_band < 1:
        raise PhysicsInputError(f"{looks} looks cannot be shared among {k} sub-bands")
    omega_k = faraday_at_frequency(state.omega, estimator.centre_hz, estimator.frequencies)  # (..., K)
    delta = np.asarray(state.delta)[..., None, :] * np.ones((k, 1))
    if delta_slope is not None:
        delta = delta + np.asarray(delta_slope, dtype=complex) * (estimator.frequencies - estimator.centre_hz)[:, None]
    sub = SystemState(delta, np.asarray(state.f)[..., None, :], omega_k, np.asarray(state.gain)[..., None])
    return sample_measured_covariance(rng, scene, sub, noise_power, per_band), per_band


def chirp_omega0_sd(snr: float, looks: int, estimator: ChirpSlopeEstimator, form: str = "exact") -> float:
    """Predicted SD (rad) of Omega0 from the slope: ``(f0/2) sqrt(v(L/K) / sum (f_k - f_mean)^2)``."""
    per_band = looks // estimator.subbands
    if per_band < 1:
        raise PhysicsInputError(f"{looks} looks cannot be shared among {estimator.subbands} sub-bands")
    v = bickel_bates_variance(snr, per_band, form)
    x = estimator.frequencies - estimator.frequencies.mean()
    return 0.5 * estimator.centre_hz * float(np.sqrt(v / np.sum(x**2)))


def locate_zero_crossing(position, omega, sd=None) -> tuple[float, float]:
    """Where a straight line through ``omega`` (rad) against ``position`` (e.g. latitude) crosses zero, and
    its standard error: locating the zero-Faraday-rotation line from estimates along a track (Quegan et al.
    2018, Sect. 5.2).

    Weighted least squares ``omega = a + b x`` (weights 1/sd^2; equal weights and the residual scatter when
    sd is None); ``x0 = -a/b`` with the delta-method variance
    ``(var a + x0^2 var b + 2 x0 cov(a, b)) / b^2``.
    """
    x = np.asarray(position, dtype=float)
    y = np.asarray(omega, dtype=float)
    if x.shape != y.shape or x.size < 3:
        raise PhysicsInputError("need at least three (position, omega) pairs of the same shape")
    w = np.ones_like(x) if sd is None else 1 / np.broadcast_to(np.asarray(sd, dtype=float), x.shape) ** 2
    design = np.stack([np.ones_like(x), x], -1)
    normal = design.T @ (w[:, None] * design)
    coef = np.linalg.solve(normal, design.T @ (w * y))
    cov = np.linalg.inv(normal)
    if sd is None:
        resid = y - design @ coef
        cov = cov * np.sum(resid**2) / (x.size - 2)
    a, b = coef
    if b == 0:
        raise PhysicsInputError("the fitted line has zero slope: no crossing")
    x0 = -a / b
    var = (cov[0, 0] + x0**2 * cov[1, 1] + 2 * x0 * cov[0, 1]) / b**2
    return float(x0), float(np.sqrt(var))
