"""First-order mean and variance of the error in sigma_hv: Men et al. (2021), eqs. (4)-(14), (A1)-(A6).

The error is ``e = sigma_hv_hat - sigma_hv`` with ``S_hv_hat = (M_hv + M_vh) / 2`` (eq. 2). To second
order in the system errors (eq. 5):

    e = sigma_hv (2 Re A + |A|^2) + P |B|^2 + 2 Re{B* [X (sigma_hh + R e^{j theta})
        + Y (sigma_vv + R e^{-j theta})]} + sigma_hh |X|^2 + sigma_vv |Y|^2
        + 2 Re{R e^{j theta} X Y*} + sigma_n / 2

with ``X = c^2 S13 - s^2 S24``, ``Y = c^2 S24 - s^2 S13``, ``A = (eps1 + eps2)/2``,
``B = c s (eps2 - eps1)/2``, ``P = sigma_hh + sigma_vv + 2 R cos theta`` (eq. 4), ``S13 = (delta1 +
delta3)/2``, ``S24 = (delta2 + delta4)/2``, ``c = cos Omega``, ``s = sin Omega``.

Every function takes a ``trig`` mapping ``{"c4", "s4", "c2s2", "cs"}``: either the moments over the
Faraday-rotation distribution (eq. 9, the paper's way) or the values at fixed Omega (arrays over
quadrature nodes, for the exact average in ``e2esim.distortion.analytic``). All inputs broadcast.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SceneTerms:
    """The covariance entries the formulas use (m^2/m^2): Men et al. (2021), Table I and eq. (4)."""

    sigma_hh: float
    sigma_hv: float
    sigma_vv: float
    r: float  # R = |<S_hh S_vv*>|
    theta: float  # phase of <S_hh S_vv*> (rad)

    @classmethod
    def from_covariance(cls, cov) -> SceneTerms:
        return cls(cov.sigma_hh, cov.sigma_hv, cov.sigma_vv, cov.hhvv_magnitude, cov.hhvv_phase_rad)

    @property
    def p(self) -> float:
        """``P = sigma_hh + sigma_vv + 2 R cos theta``, eq. (4)."""
        return self.sigma_hh + self.sigma_vv + 2 * self.r * np.cos(self.theta)


@dataclass(frozen=True)
class CrosstalkMoments:
    """Moments of X and Y: eqs. (6a-c) and (7a-b). ``cxy = <X Y*>`` is real."""

    v13: np.ndarray
    v24: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    cxy: np.ndarray


@dataclass(frozen=True)
class ImbalanceMoments:
    """Moments of A and B: eqs. (8a-c). ``cab = <A B*>`` is complex."""

    va: np.ndarray
    vb: np.ndarray
    cab: np.ndarray


def trig_at(omega) -> dict:
    """``trig`` mapping at fixed Omega (rad): cos^4, sin^4, cos^2 sin^2, cos sin."""
    c, s = np.cos(omega), np.sin(omega)
    return {"c4": c**4, "s4": s**4, "c2s2": (c * s) ** 2, "cs": c * s}


def crosstalk_moments(v, c13, c24, trig) -> CrosstalkMoments:
    """Eqs. (6)-(7). ``v`` = (V1, V2, V3, V4) on the last axis, ``c13 = <delta1 delta3*>``,
    ``c24 = <delta2 delta4*>``."""
    v = np.asarray(v)
    v13 = (v[..., 0] + v[..., 2] + 2 * np.real(c13)) / 4  # eq. (7a)
    v24 = (v[..., 1] + v[..., 3] + 2 * np.real(c24)) / 4  # eq. (7b)
    vx = trig["c4"] * v13 + trig["s4"] * v24  # eq. (6a)
    vy = trig["s4"] * v13 + trig["c4"] * v24  # eq. (6b)
    cxy = -trig["c2s2"] * (v13 + v24)  # eq. (6c)
    return CrosstalkMoments(v13, v24, vx, vy, cxy)


def imbalance_moments(ve, ce12, trig) -> ImbalanceMoments:
    """Eqs. (8a)-(8c). ``ve`` = (V_eps1, V_eps2) on the last axis, ``ce12 = <eps1 eps2*>``."""
    ve = np.asarray(ve)
    va = (ve[..., 0] + ve[..., 1] + 2 * np.real(ce12)) / 4  # eq. (8a)
    vb = trig["c2s2"] * (ve[..., 0] + ve[..., 1] - 2 * np.real(ce12)) / 4  # eq. (8b)
    cab = trig["cs"] / 4 * (ve[..., 1] - ve[..., 0] + 2j * np.imag(ce12))  # eq. (8c)
    return ImbalanceMoments(va, vb, cab)


def simplified_moments(v_delta, rho_delta, v_eps, rho_eps, trig) -> tuple[CrosstalkMoments, ImbalanceMoments]:
    """Equal variances and a common correlation coefficient: eqs. (13a-b) and (14a-c).

    Written with the trig moments of eq. (9), so ``(3 + <cos 4 Omega>)/8 = <c^4> + <s^4>`` and
    ``(1 - <cos 4 Omega>)/8 = <c^2 s^2>``.
    """
    rd = np.abs(rho_delta) * np.cos(np.angle(rho_delta))
    re_, im_ = np.real(rho_eps), np.imag(rho_eps)
    v = v_delta * (1 + rd) / 2  # V13 = V24
    vx = v * (trig["c4"] + trig["s4"])  # eq. (13a): V_delta/8 (1+|rho|cos) (3 + <cos 4 Omega>)
    cxy = -v * 2 * trig["c2s2"]  # eq. (13b): -V_delta/8 (1+|rho|cos) (1 - <cos 4 Omega>)
    va = v_eps / 2 * (1 + re_)  # eq. (14a)
    vb = trig["c2s2"] * v_eps / 2 * (1 - re_)  # eq. (14b)
    cab = 1j * trig["cs"] * v_eps / 2 * im_  # eq. (14c)
    return CrosstalkMoments(v, v, vx, vx, cxy), ImbalanceMoments(va, vb, cab)


def bias_terms(scene: SceneTerms, xt: CrosstalkMoments, ci: ImbalanceMoments) -> dict:
    """Mean error from channel imbalance and crosstalk, eq. (11) (= A2) without the noise term.

    Appendix C split: ``imbalance = sigma_hv V_A + P V_B``; ``crosstalk = sigma_hh V_X + sigma_vv V_Y
    + 2 R cos theta C_XY``. The noise term sigma_n/2 is added by the caller.
    """
    return {
        "imbalance": scene.sigma_hv * ci.va + scene.p * ci.vb,
        "crosstalk": scene.sigma_hh * xt.vx
        + scene.sigma_vv * xt.vy
        + 2 * scene.r * np.cos(scene.theta) * xt.cxy,
    }


def variance_terms(scene: SceneTerms, xt: CrosstalkMoments, ci: ImbalanceMoments) -> dict:
    """Variance of the error, eqs. (A4)-(A6) = (12a)-(12c), split as in Appendix C.

    ``imbalance`` (A4): ``sigma_hv^2 (V_A^2 + 2 V_A) + P^2 V_B^2 + 2 sigma_hv P |C_AB|^2``. Eq. (12a)
    as printed has ``2 V_B`` in place of ``2 V_A``; (A4), the derivation (Var(2 Re A) = 2 V_A for
    circular A) and the Discussion ("the 2 sigma_hv^2 V_A term in (12a)") all give ``2 V_A``
    (docs/errata.md).
    ``crosstalk`` (A5) = (12b); ``interaction`` (A6) = (12c).
    """
    hh, hv, vv, r, th, p = scene.sigma_hh, scene.sigma_hv, scene.sigma_vv, scene.r, scene.theta, scene.p
    vx, vy, cxy = xt.vx, xt.vy, xt.cxy
    rcos = r * np.cos(th)
    imbalance = hv**2 * (ci.va**2 + 2 * ci.va) + p**2 * ci.vb**2 + 2 * hv * p * np.abs(ci.cab) ** 2
    crosstalk = (
        hh**2 * vx**2
        + vv**2 * vy**2
        + 2 * r**2 * (vx * vy + cxy**2 * np.cos(2 * th))
        + 2 * hh * vv * cxy**2
        + 4 * rcos * cxy * (hh * vx + vv * vy)
    )
    interaction = (
        2
        * ci.vb
        * (
            vx * hh**2
            + vy * vv**2
            + 2 * cxy * hh * vv
            + 2 * rcos * (vx * hh + vy * vv + cxy * (hh + vv))
            + r**2 * (vx + vy + 2 * cxy * np.cos(2 * th))
        )
    )
    return {"imbalance": imbalance, "crosstalk": crosstalk, "interaction": interaction}
