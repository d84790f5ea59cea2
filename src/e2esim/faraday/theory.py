"""Accuracy of the Bickel-Bates Faraday-rotation estimator: variance over looks and SNR, bias from system errors.

Variance. With noise of equal power in the four channels, the circular channels ``z_a``, ``z_b`` of a
reciprocal target are jointly circular Gaussian with coherence ``gamma = 1 / (1 + 1/SNR)`` (Quegan et al.
2018, eq. 6) and phase 4 Omega, so ``4 Omega_hat`` is the phase of an L-look sample coherence and
``var(Omega_hat) = var(psi_L) / 16``. Three forms (``VARIANCE_FORMS``):

* ``"exact"``: the variance of the multilook phase distribution (Lee et al. 1994; the finite-sum form of
  Tough, Blacknell & Quegan 1995), integrated numerically; valid for any L and gamma;
* ``"asymptotic"``: its large-L limit, the Cramer-Rao bound ``(1 - gamma^2) / (2 L gamma^2) / 16``
  (Rogers & Quegan 2014);
* ``"printed"``: eq. (5) as printed in Quegan et al. (2018), ``(1/16)(1 - gamma^2) / (2 gamma L)``, which has
  gamma where the bound has gamma^2 and so understates the variance by the factor gamma (docs/errata.md;
  the simulation in tests/calibration/test_calibration_faraday.py is the arbiter).

Bias. The large-window limit of the estimate, ``arg(a^T C_M b*) / 4`` with ``C_M`` the population
covariance of the measured vector, is exact for any system errors (``bickel_bates_limit``); its
first-order expansion in crosstalk and channel imbalance (``bickel_bates_bias_first_order``) shows how
the bias depends on their amplitudes and phases (cf. Quegan & Lomas 2015, IEEE TGRS 53(8)).
"""

from __future__ import annotations

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.faraday.estimators import AMBIGUITY_PERIOD, Z_A, Z_B, wrap_error
from e2esim.polarimetry.simulate import SystemState, measured_covariance, reciprocal_covariance4
from e2esim.polarimetry.system_model import batched_kron, faraday_matrix

VARIANCE_FORMS = ("exact", "asymptotic", "printed")
_EXACT_MAX_LOOKS = 1000  # beyond, exact exceeds asymptotic by < 1 % for gamma >= 0.3 (~ (1 + 0.6 (1 - g^2)/g^2) / L)
_GRID = 8192  # points of the phase grid for the numerical variance
_FULL_PERIOD_LOOKS = 64  # up to here the phase density has heavy tails: integrate over the whole period
_HALF_WIDTH_SD = 20.0  # beyond, integrate over +-20 asymptotic SDs of the near-Gaussian peak


def bickel_bates_snr(scene, noise_power: float) -> float:
    """SNR of eq. (6): ``<|S_hh + S_vv|^2>`` over the sum of the four channel noise powers ``4 sigma_n``.

    scene : ScatteringCovariance (m^2/m^2). noise_power : sigma_n per channel (NESZ, linear).
    """
    c = scene.matrix
    co = float(np.real(c[0, 0] + c[2, 2] + 2 * c[0, 2]))
    return np.inf if noise_power == 0 else co / (4 * noise_power)


def bickel_bates_coherence(snr) -> np.ndarray:
    """``gamma = 1 / (1 + SNR^-1)``, Quegan et al. (2018), eq. (6)."""
    snr = np.asarray(snr, dtype=float)
    with np.errstate(divide="ignore"):
        return 1.0 / (1.0 + 1.0 / snr)


def phase_pdf(psi, looks: int, coherence: float) -> np.ndarray:
    """Density of the phase of an L-look sample coherence about the true phase (rad^-1), psi in [-pi, pi].

    Tough, Blacknell & Quegan (1995), finite sum for integer L (equivalent to Lee et al. 1994, eq. 20),
    evaluated in log space so that large L do not overflow.
    """
    rho = float(coherence)
    if not 0 <= rho < 1:
        raise PhysicsInputError(f"coherence must be in [0, 1), got {coherence!r}")
    b = rho * np.cos(np.asarray(psi, dtype=float))
    from scipy import special  # imported here: scipy.special and scipy.stats cost seconds at start-up

    gl = special.gammaln
    lq = np.log1p(-rho**2)
    lb = np.log1p(-b**2)
    c = gl(2 * looks - 1) - 2 * gl(looks) - 2 * (looks - 1) * np.log(2)
    out = np.exp(c + looks * lq - (looks + 0.5) * lb) * (2 * looks - 1) * b * (np.pi / 2 + np.arcsin(b))
    out = out + np.exp(c + looks * lq - looks * lb)
    if looks >= 2:
        r = np.arange(looks - 1)[:, None]
        log_terms = (
            gl(looks - 0.5) - gl(looks - 0.5 - r) + gl(looks - 1 - r) - gl(looks - 1)
            + looks * lq - (r + 2) * lb[None, :] + np.log1p((2 * r + 1) * b[None, :] ** 2) - np.log(2 * (looks - 1))
        )
        out = out + np.exp(special.logsumexp(log_terms, axis=0))
    return out / (2 * np.pi)


def phase_variance(looks: int, coherence: float, form: str = "exact") -> float:
    """Variance (rad^2) of the phase of an L-look sample coherence (the Bickel-Bates ``4 Omega_hat``)."""
    if form not in VARIANCE_FORMS:
        raise PhysicsInputError(f"form must be one of {VARIANCE_FORMS}, got {form!r}")
    if int(looks) != looks or looks < 1:
        raise PhysicsInputError(f"looks must be a positive integer, got {looks!r}")
    looks = int(looks)
    g = float(coherence)
    if not 0 < g <= 1:
        raise PhysicsInputError(f"coherence must be in (0, 1], got {coherence!r}")
    if g == 1:
        return 0.0
    if form == "printed":
        return (1 - g**2) / (2 * g * looks)  # eq. (5) times 16
    asymptotic = (1 - g**2) / (2 * looks * g**2)
    if form == "asymptotic" or looks > _EXACT_MAX_LOOKS:
        return asymptotic
    half = np.pi if looks <= _FULL_PERIOD_LOOKS else min(np.pi, _HALF_WIDTH_SD * np.sqrt(asymptotic))
    if half == np.pi:  # heavy tails: the whole period, where the periodic trapezoid rule is spectrally accurate
        psi = -np.pi + 2 * np.pi * np.arange(_GRID) / _GRID
        p = phase_pdf(psi, looks, g)
        return float(np.sum(psi**2 * p) / np.sum(p))
    psi = np.linspace(-half, half, _GRID)  # near-Gaussian peak: nothing beyond 20 SD
    p = phase_pdf(psi, looks, g)
    return float(np.trapezoid(psi**2 * p, psi) / np.trapezoid(p, psi))


def bickel_bates_variance(snr, looks, form: str = "exact"):
    """Variance (rad^2) of the Bickel-Bates estimate over ``looks`` samples at the eq. (6) SNR.

    form : "exact" (the L-look phase density), "asymptotic" ``(1/16)(1 - g^2)/(2 L g^2)`` (the corrected
    eq. 5) or "printed" ``(1/16)(1 - g^2)/(2 g L)`` (eq. 5 as printed, docs/errata.md QC1/I1). The closed
    forms broadcast over arrays of ``snr`` and ``looks``; the exact form is evaluated element by element.
    """
    if form in ("asymptotic", "printed"):
        g = bickel_bates_coherence(snr)
        looks = np.asarray(looks, dtype=float)
        if np.any(looks < 1):
            raise PhysicsInputError(f"looks must be >= 1, got {looks!r}")
        denominator = g**2 if form == "asymptotic" else g
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.where(g >= 1, 0.0, (1 - g**2) / (16 * 2 * looks * denominator))
        return float(out) if out.ndim == 0 else out
    if np.ndim(snr) == 0 and np.ndim(looks) == 0:
        return phase_variance(looks, float(bickel_bates_coherence(snr)), form) / 16
    return np.vectorize(lambda s, n: phase_variance(n, float(bickel_bates_coherence(s)), form) / 16)(snr, looks)


def bickel_bates_limit(scene, state: SystemState, noise_power: float = 0.0) -> np.ndarray:
    """The estimate for an infinite window, ``arg(a^T C_M b*) / 4`` (rad), exact for any system errors."""
    cov = measured_covariance(scene, state, noise_power)
    return np.angle(np.einsum("i,...ij,j->...", Z_A, cov, np.conj(Z_B))) / 4


def bickel_bates_bias(scene, state: SystemState, noise_power: float = 0.0) -> np.ndarray:
    """Large-window bias ``Omega_inf - Omega`` (rad), wrapped to [-pi/4, pi/4)."""
    return wrap_error(bickel_bates_limit(scene, state, noise_power) - np.asarray(state.omega))


def _first_order_distortion(delta, f) -> np.ndarray:
    """The part of ``T^T kron R`` (Men et al. 2021, eq. 1) linear in the delta_i and eps_i = f_i - 1."""
    d1, d2, d3, d4 = (np.asarray(delta)[..., i] for i in range(4))
    e1, e2 = np.asarray(f)[..., 0] - 1, np.asarray(f)[..., 1] - 1
    z = np.zeros_like(d1 * e1)
    rows = [
        [z, d2 + z, d4 + z, z],
        [d1 + z, e1 + z, z, d4 + z],
        [d3 + z, z, e2 + z, d2 + z],
        [z, d3 + z, d1 + z, e1 + e2 + z],
    ]
    return np.stack([np.stack(r, -1) for r in rows], -2)


def bickel_bates_bias_first_order(scene, delta, f, omega) -> np.ndarray:
    """First-order bias (rad) of the large-window Bickel-Bates estimate in the crosstalk and imbalance.

    ``C_M = (I + D1) K0 C4 K0^H (I + D1)^H`` with ``K0 = F^T kron F`` and ``D1`` the linear part of the
    distortion; the phase of ``a^T C_M b*`` moves by ``Im[a^T (D1 Q + Q D1^H) b* / a^T Q b*]``,
    ``Q = K0 C4 K0^H``, to first order. Linear in (delta, eps) and their conjugates: for a given target
    and Omega the bias is ``Re`` of a complex linear form, so it is a sinusoid in each error's phase.
    """
    omega = np.asarray(omega, dtype=float)
    rot = faraday_matrix(omega)
    k0 = batched_kron(np.swapaxes(rot, -1, -2), rot)
    q = k0 @ reciprocal_covariance4(scene) @ np.swapaxes(k0.conj(), -1, -2)
    d1 = _first_order_distortion(delta, f)
    dq = d1 @ q + q @ np.swapaxes(d1.conj(), -1, -2)
    num = np.einsum("i,...ij,j->...", Z_A, dq, np.conj(Z_B))
    den = np.einsum("i,...ij,j->...", Z_A, q, np.conj(Z_B))
    return np.imag(num / den) / 4


def ambiguity_error_probability(prior_sd_rad, estimate_sd_rad=0.0, period: float = AMBIGUITY_PERIOD) -> np.ndarray:
    """Probability that resolving the pi/2 ambiguity with a Gaussian prior picks the wrong branch:
    ``P(|e| > period/2)`` for ``e ~ N(0, prior_sd^2 + estimate_sd^2)`` (other branches' overlap ignored)."""
    sd = np.hypot(prior_sd_rad, estimate_sd_rad)
    with np.errstate(divide="ignore"):
        from scipy import special

        return 2 * special.ndtr(-(period / 2 / np.asarray(sd, dtype=float)))  # 2 P(Z > period / 2 sd)


def freeman_variance(scene, noise_power: float, omega: float, looks: int, noise_subtraction: bool = True) -> float:
    """Large-L variance (rad^2) of Freeman's second-moment estimate, by the delta method.

    ``d = M_vh - M_hv = x sin 2W + n_d`` and ``c = M_hh + M_vv = x cos 2W + n_c`` with ``x = S_hh + S_vv`` (power P)
    and independent noises of power 2 sigma_n, all circular Gaussian: the sample powers X = <|d|^2>,
    Y = <|c|^2> have ``Var X = E[X]^2 / L``, ``Var Y = E[Y]^2 / L``, ``Cov = (P sin 2W cos 2W)^2 / L``, and
    ``W_hat = (1/2) arctan sqrt(X' / Y')`` (X', Y' noise-subtracted or not). Valid away from W = 0 and
    W = pi/4, where the square root and the sign make the estimate non-linear.
    """
    c = scene.matrix
    p = float(np.real(c[0, 0] + c[2, 2] + 2 * c[0, 2]))
    s2, c2 = np.sin(2 * omega) ** 2, np.cos(2 * omega) ** 2
    ex, ey = p * s2 + 2 * noise_power, p * c2 + 2 * noise_power  # E|d|^2, E|c|^2
    x, y = (p * s2, p * c2) if noise_subtraction else (ex, ey)
    t = np.sqrt(x / y)
    gx = 0.5 / (1 + t**2) / (2 * t * y)
    gy = -0.5 / (1 + t**2) * t / (2 * y)
    var_x, var_y, cov = ex**2 / looks, ey**2 / looks, (p**2 * s2 * c2) / looks
    return float(gx**2 * var_x + gy**2 * var_y + 2 * gx * gy * cov)
