"""Terms that complete the error moments of Men et al. (2021) to second order in the system errors.

Expanding ``S_hv_hat = a . (S_hh, S_hv, S_vv)`` exactly (the operator of eq. 1 is at most quadratic in the
errors) gives, with ``U = d1 d4 - d2 d3``, ``W = d1 d4 + d2 d3`` and ``D = d2 eps2 + d4 eps1``:

    a_hh = X + B + (s/2) (c U - s D)
    a_hv = 1 + A + W / 2
    a_vv = Y + B + (c/2) (c D + s U)

(derivation in docs/theory/cross-pol-error.md; checked term by term against eq. 1 in the tests).
Men et al. eq. (3) keeps the first-order parts of ``a`` only. That leaves the mean (11) exact to
first order in the variances, but the variance (12) misses two terms of the same order, O(V^2), as the
terms it keeps:

* ``Var(sigma_hv Re W) = sigma_hv^2 E|W|^2 / 2``, the second-order crosstalk product in the HV
  coefficient (about 4 % of the crosstalk variance (12b) for the boreal 200 t/ha forest);
* ``2 Cov(2 sigma_hv Re A, third-order terms) = 2 sigma_hv Re(K) (sigma_hh s^4 + sigma_vv c^4
  - 2 R cos theta c^2 s^2)``, with ``K = [(C_e12* + V_e2)(V_2 + C_24) + (V_e1 + C_e12)(V_4 + C_24*)] / 4``,
  a channel-imbalance x crosstalk covariance.

The mean gains the fourth-order terms ``sum_ij C_ij E[a2_i a2_j*]`` (exact for Gaussian errors).
Everything here is conditional on Omega through ``trig``, like ``first_order``.
"""

from __future__ import annotations

import numpy as np

from e2esim.distortion.first_order import SceneTerms


def product_moments(v, c13, c24, ve, ce12) -> dict:
    """Second moments of the quadratic error products U, W, D (Gaussian, circular).

    ``E|d1 d4|^2 = V1 V4``, ``E|d2 d3|^2 = V2 V3``, ``E[d1 d4 (d2 d3)*] = C13 C24*`` (Isserlis).
    """
    v = np.asarray(v)
    ve = np.asarray(ve)
    p14, p23 = v[..., 0] * v[..., 3], v[..., 1] * v[..., 2]
    cross = np.real(c13 * np.conj(c24))
    return {
        "u2": p14 + p23 - 2 * cross,  # E|U|^2
        "w2": p14 + p23 + 2 * cross,  # E|W|^2
        "d2": v[..., 1] * ve[..., 1] + v[..., 3] * ve[..., 0] + 2 * np.real(c24 * np.conj(ce12)),  # E|D|^2
        "k": ((np.conj(ce12) + ve[..., 1]) * (v[..., 1] + c24) + (ve[..., 0] + ce12) * (v[..., 3] + np.conj(c24)))
        / 4,
    }


def bias_correction(scene: SceneTerms, m: dict, trig) -> np.ndarray:
    """Fourth-order part of the mean, ``sum_ij C_ij E[a2_i a2_j*]`` (m^2/m^2).

    ``E|a2_hh|^2 = (c^2 s^2 E|U|^2 + s^4 E|D|^2)/4``, ``E|a2_vv|^2 = (c^4 E|D|^2 + c^2 s^2 E|U|^2)/4``,
    ``E|a2_hv|^2 = E|W|^2 / 4``, ``E[a2_hh a2_vv*] = c^2 s^2 (E|U|^2 - E|D|^2)/4``. ``m`` from
    ``product_moments``.
    """
    hh2 = (trig["c2s2"] * m["u2"] + trig["s4"] * m["d2"]) / 4
    vv2 = (trig["c4"] * m["d2"] + trig["c2s2"] * m["u2"]) / 4
    hv2 = m["w2"] / 4
    hhvv = trig["c2s2"] * (m["u2"] - m["d2"]) / 4
    return (
        scene.sigma_hh * hh2
        + scene.sigma_vv * vv2
        + scene.sigma_hv * hv2
        + 2 * scene.r * np.cos(scene.theta) * hhvv
    )


def variance_correction(scene: SceneTerms, m: dict, trig) -> np.ndarray:
    """The O(V^2) variance terms missing from eq. (12) (module docstring), conditional on Omega; ``m`` from
    ``product_moments``."""
    bracket = (
        scene.sigma_hh * trig["s4"]
        + scene.sigma_vv * trig["c4"]
        - 2 * scene.r * np.cos(scene.theta) * trig["c2s2"]
    )
    return 0.5 * scene.sigma_hv**2 * m["w2"] + 2 * scene.sigma_hv * np.real(m["k"]) * bracket
