"""Exact impulse-response properties of the weighting window, the arbiter of eqs. (25) and (29).

The window of Ahmed et al. (2014), Section II-D-1, has pedestal eta: ``w(f) = eta + (1 - eta) cos^2(pi f)``
on |f| <= 1/2 (f in units of the bandwidth): eta = 1 uniform, 0.08 Hamming, 0 Hann. Its impulse response
is ``h(t) = a sinc(t) + b (sinc(t - 1) + sinc(t + 1))`` with ``a = (1 + eta) / 2``, ``b = (1 - eta) / 4``
(t in units of 1/B, ``sinc(t) = sin(pi t) / (pi t)``).
"""

from __future__ import annotations

import numpy as np


def impulse_response(t, eta):
    """h(t) of the window with pedestal eta (module docstring)."""
    a, b = (1.0 + eta) / 2.0, (1.0 - eta) / 4.0
    return a * np.sinc(t) + b * (np.sinc(t - 1.0) + np.sinc(t + 1.0))


def resolution_width(eta) -> float:
    """-3 dB width of |h|^2 (units of 1/B)."""
    peak = impulse_response(0.0, eta) ** 2
    from scipy import optimize  # imported here: it costs a second at start-up

    half = optimize.brentq(lambda t: impulse_response(t, eta) ** 2 - 0.5 * peak, 1e-9, 1.5, xtol=1e-14)
    return 2.0 * half


def window_broadening(eta) -> float:
    """Exact broadening factor: -3 dB width relative to the uniform window (compare eq. 25)."""
    return resolution_width(eta) / resolution_width(1.0)


def window_islr_db(eta, mainlobe_widths: float = 2.0) -> float:
    """Integrated sidelobe ratio (dB): energy outside +-``mainlobe_widths`` -3 dB widths over the energy
    inside. The total energy is exact (Parseval: int w^2 df); the main lobe is integrated numerically."""
    total = (eta**2 + eta * (1 - eta) + 3.0 * (1 - eta) ** 2 / 8.0)  # int_{-1/2}^{1/2} w(f)^2 df
    edge = mainlobe_widths * resolution_width(eta)
    from scipy import integrate  # imported here, as above

    main, _ = integrate.quad(lambda t: impulse_response(t, eta) ** 2, -edge, edge, limit=400, epsabs=1e-14)
    return float(10.0 * np.log10((total - main) / main))
