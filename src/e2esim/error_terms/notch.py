"""A notched spectrum and what it does to the image: the impulse response of a range (or azimuth) spectrum with a
part of its band removed by RFI mitigation, computed, not guessed (docs/theory/rfi.md).

The processed spectrum is H(f) = W(f) (1 - N(f)) over the band |f| <= B/2: W the processing window (rectangular
here: e2esim's error models assume an unweighted spectrum) and N the notch, 1 on the removed part (a fraction
``fraction`` of the band, at its centre or at one edge). On a grid of ``BINS`` frequency bins (a partly removed bin
keeps the rest of its weight) the impulse response is the inverse DFT, zero-padded ``OVERSAMPLE`` times
(Cumming & Wong 2005, Digital Processing of SAR Data, Section 2.6, eqs. 2.36-2.41, for the point-target metrics):

    h(t) = sum_k H_k exp(2 pi i f_k t),
    peak loss         |h_max|^2 / |h0_max|^2            (h0: the unnotched response; (1 - f)^2 for a binary notch)
    resolution ratio  3-dB width of |h|^2 / that of |h0|^2
    PSLR              largest sidelobe / peak of |h|^2 (dB), sidelobes beyond the first minima of the main lobe
    ISLR              sidelobe energy / main-lobe energy (dB).

For distributed targets (speckle), two integrals of H settle what the requirement sees:

    energy ratio  g   = sum |H_k|^2 / sum |W_k|^2                  (Parseval: the mean image intensity, uncompensated)
    looks factor  eta = (sum |H_k|^2)^2 / (K sum |H_k|^4)  /  the same of W

the second being the number of independent intensity samples per unit length relative to the full band: the speckle
correlation length of an intensity image is the integral of the squared intensity autocorrelation, |R(tau)|^2 with
R the Fourier transform of |H|^2, over R(0)^2 (Goodman 2007, Speckle Phenomena in Optics, Chapters 4 and 5;
Parseval turns both into sums over the spectrum). For a rectangular window and a binary notch g = eta = 1 - f,
wherever the notch sits.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

BINS = 4000
"""Frequency bins across the band (a fraction that is a multiple of 1/4000, 0.025 %, is exact; any other is
exact to 1/BINS in its energy and looks)."""
OVERSAMPLE = 32
"""Zero-padding factor of the inverse DFT (the time step is 1 / (OVERSAMPLE B))."""
POSITIONS = ("centre", "edge")
"""Where the notch sits in the band."""


@dataclass(frozen=True)
class NotchResponse:
    """What a notch of ``fraction`` of the band at ``position`` does (module docstring). Ratios are linear; the
    sidelobe ratios in dB."""

    fraction: float
    position: str
    energy_ratio: float
    looks_factor: float
    peak_loss_db: float
    resolution_ratio: float
    pslr_db: float
    islr_db: float


def notched_spectrum(fraction: float, position: str = "centre", bins: int = BINS) -> np.ndarray:
    """|H_k| (bins,) of the band with ``fraction`` (0 <= f < 1) removed at ``position`` ("centre" or "edge"); a bin
    partly inside the notch keeps the share of it outside."""
    if not 0.0 <= fraction < 1.0:
        raise ValueError(f"notched fraction {fraction!r} is outside [0, 1)")
    if position not in POSITIONS:
        raise ValueError(f"notch position {position!r} is not one of {', '.join(POSITIONS)}")
    edges = np.linspace(-0.5, 0.5, bins + 1)  # bin edges, in units of the bandwidth
    low, high = (-fraction / 2.0, fraction / 2.0) if position == "centre" else (0.5 - fraction, 0.5)
    removed = np.clip(np.minimum(edges[1:], high) - np.maximum(edges[:-1], low), 0.0, None) * bins
    return 1.0 - removed


def impulse_power(spectrum: np.ndarray, oversample: int = OVERSAMPLE) -> np.ndarray:
    """|h(t)|^2 of ``spectrum`` (bins centred on 0 frequency), zero-padded ``oversample`` times, t = 0 in the
    middle of the returned array."""
    n = spectrum.size
    padded = np.zeros(n * oversample, complex)
    padded[:n] = spectrum
    padded = np.roll(padded, -(n // 2))  # bin of frequency 0 at index 0
    h = np.fft.fftshift(np.fft.ifft(padded))
    return np.abs(h) ** 2


def _main_lobe(power: np.ndarray, peak: int) -> tuple:
    """First indices left and right of ``peak`` where |h|^2 stops falling (the main lobe's first minima)."""
    d = np.diff(power)
    right = peak + 1 + int(np.argmax(d[peak + 1:] >= 0)) if np.any(d[peak + 1:] >= 0) else power.size - 1
    left_d = d[:peak][::-1]  # rises towards the peak; a minimum where it stops rising going left
    left = peak - 1 - int(np.argmax(left_d <= 0)) if np.any(left_d <= 0) else 0
    return left, right


def _width_3db(power: np.ndarray, peak: int) -> float:
    """Width (samples, linearly interpolated) of the main lobe at half its peak power."""
    half = power[peak] / 2.0
    r = peak + int(np.argmax(power[peak:] < half))
    l_ = peak - int(np.argmax(power[:peak + 1][::-1] < half))
    right = r - 1 + (power[r - 1] - half) / (power[r - 1] - power[r])
    left = l_ + 1 - (power[l_ + 1] - half) / (power[l_ + 1] - power[l_])
    return right - left


def _lobe_metrics(power: np.ndarray) -> tuple:
    """(peak, 3-dB width, PSLR dB, ISLR dB) of an impulse response's power."""
    peak = int(np.argmax(power))
    left, right = _main_lobe(power, peak)
    main = power[left:right + 1].sum()
    side = np.r_[power[:left], power[right + 1:]]
    return (float(power[peak]), float(_width_3db(power, peak)), float(10.0 * np.log10(side.max() / power[peak])),
            float(10.0 * np.log10(side.sum() / main)))


def _looks(spectrum: np.ndarray) -> float:
    p = spectrum ** 2
    return float(p.sum() ** 2 / (p.size * (p * p).sum()))


@lru_cache(maxsize=1)
def _full_band() -> tuple:
    """(spectrum, looks, peak, 3-dB width) of the unnotched band: a constant, computed once."""
    full = notched_spectrum(0.0)
    peak, width, _, _ = _lobe_metrics(impulse_power(full))
    return full, _looks(full), peak, width


def notch_response(fraction: float, position: str = "centre") -> NotchResponse:
    """The ``NotchResponse`` of a notch of ``fraction`` of the band at ``position`` (module docstring; about 20 ms:
    a module computes it once per setting)."""
    full, looks0, peak0, width0 = _full_band()
    notched = notched_spectrum(float(fraction), position)
    peak, width, pslr, islr = _lobe_metrics(impulse_power(notched))
    return NotchResponse(float(fraction), position, float((notched ** 2).sum() / (full ** 2).sum()),
                         _looks(notched) / looks0, float(10.0 * np.log10(peak / peak0)), width / width0, pslr, islr)


__all__ = ["BINS", "OVERSAMPLE", "POSITIONS", "NotchResponse", "impulse_power", "notch_response", "notched_spectrum"]
