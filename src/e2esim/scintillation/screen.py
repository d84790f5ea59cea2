"""A power-law phase screen (Rino 1979): the one-way phase a thin ionospheric layer imposes on a P-band wave.

Rino (1979), Radio Science 14(6), eq. (5): the three-dimensional spectrum of the electron-density irregularities is

    Phi_dN(kappa) = C_s (kappa_0^2 + kappa^2)^-(nu + 1/2),       kappa_0 = 2 pi / L_0 (outer scale L_0),

with ``C_kL = C_s L`` its height-integrated strength (layer thickness L). A thin screen (Rino 1979, eq. 8, isotropic
irregularities, G = 1) imposes the phase phi = -r_e lambda dTEC, whose two-dimensional spectrum is
r_e^2 lambda^2 sec(theta) C_kL (kappa_0^2 + kappa^2)^-(nu+1/2). Integrated over the cross-scan wavenumber
(docs/theory/scintillation.md, eq. S2), the one-dimensional spectrum along a scan is

    Phi_1(kappa) = r_e^2 lambda^2 sec(theta) C_kL Gamma(nu) / (2 sqrt(pi) Gamma(nu + 1/2)) (kappa_0^2 + kappa^2)^-nu,

a power law of index ``p = 2 nu`` (the phase spectral index; Rino 1979, Section 3). Its inverse Fourier transform is
a Matern covariance of smoothness mu = nu - 1/2 (Gradshteyn & Ryzhik 3.771.2), which gives the phase variance and
the structure function in closed form (eqs. S3, S4):

    sigma_phi^2 = r_e^2 lambda^2 sec(theta) C_kL kappa_0^(1 - 2 nu) / (4 pi (nu - 1/2)),
    D(Delta) = 2 sigma_phi^2 [1 - 2^(1 - mu) / Gamma(mu) (kappa_0 Delta)^mu K_mu(kappa_0 Delta)].

Conventions: SI throughout; kappa in rad/m; ``Phi_1`` normalised so that sigma^2 = integral Phi_1 dkappa / (2 pi);
C_kL in SI units, m^-(2 nu + 3) (this normalisation; values quoted in WBMOD units differ by a convention factor, see
docs/theory/scintillation.md). Model range: 1 < p < 5 (1/2 < nu < 5/2; Rino 1979 gives his weak-scatter results
for this range: nu > 1/2 for a finite variance, nu < 5/2 for a convergent weak-scatter intensity integral).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import beta, betainc, gammaln, kv
from scipy.special import gamma as gamma_fn

from e2esim.errors import PhysicsInputError

ELECTRON_RADIUS_M = 2.8179403262e-15  # classical electron radius r_e (CODATA 2018)
SPECTRAL_INDEX_RANGE = (1.0, 5.0)  # open interval of the phase spectral index p = 2 nu (module docstring)


@dataclass(frozen=True)
class PhaseScreen:
    """A thin power-law screen (module docstring). c_kl : height-integrated strength C_kL (SI, m^-(2 nu + 3), >= 0).
    spectral_index : phase spectral index p = 2 nu, in (1, 5). outer_scale_m : L_0 (m). height_m : screen height
    above the ground (m). drift_m_s : along-track drift of the irregularities (m/s, in the platform's direction)."""

    c_kl: float
    spectral_index: float = 2.67
    outer_scale_m: float = 10e3
    height_m: float = 350e3
    drift_m_s: float = 0.0

    def __post_init__(self):
        check_screen(self.c_kl, self.spectral_index, self.outer_scale_m, self.height_m)

    @property
    def nu(self) -> float:
        return self.spectral_index / 2.0


def check_screen(c_kl, spectral_index, outer_scale_m, height_m, orbit_height_m=None) -> None:
    """Refuse a screen outside the model (module docstring): a clear ``PhysicsInputError`` naming the key."""
    c = np.asarray(c_kl, dtype=float)
    if not np.all(np.isfinite(c)) or np.any(c < 0.0):
        raise PhysicsInputError(f"C_kL must be finite and >= 0 (a turbulence strength), got {c_kl!r}", key="c_kl")
    lo, hi = SPECTRAL_INDEX_RANGE
    p = np.asarray(spectral_index, dtype=float)
    if not np.all((p > lo) & (p < hi)):
        raise PhysicsInputError(f"spectral index p = {spectral_index!r} is outside the power-law model's range "
                                f"{lo:g} < p < {hi:g} (Rino 1979: 1/2 < nu < 5/2)", key="spectral_index")
    if not np.all(np.asarray(outer_scale_m, dtype=float) > 0.0):
        raise PhysicsInputError(f"outer scale must be > 0 m, got {outer_scale_m!r}", key="outer_scale_km")
    h = np.asarray(height_m, dtype=float)
    if not np.all(h > 0.0):
        raise PhysicsInputError(f"screen height must be > 0 m, got {height_m!r}", key="screen_height_km")
    if orbit_height_m is not None and np.any(h >= np.asarray(orbit_height_m, dtype=float)):
        raise PhysicsInputError(f"the screen ({float(np.max(h)) / 1e3:g} km) is not below the orbit "
                                f"({float(np.min(orbit_height_m)) / 1e3:g} km): a screen must lie between the "
                                "ground and the satellite", key="screen_height_km")


def spectral_constant(c_kl, spectral_index, wavelength_m, zenith_rad=0.0):
    """r_e^2 lambda^2 sec(theta) C_kL Gamma(nu) / (2 sqrt(pi) Gamma(nu + 1/2)): the factor of Phi_1 (module
    docstring, eq. S2). Broadcasts."""
    nu = np.asarray(spectral_index, dtype=float) / 2.0
    ratio = np.exp(gammaln(nu) - gammaln(nu + 0.5)) / (2.0 * math.sqrt(math.pi))
    return (ELECTRON_RADIUS_M * np.asarray(wavelength_m, float)) ** 2 / np.cos(zenith_rad) * np.asarray(c_kl) * ratio


def phase_spectrum(kappa, c_kl, spectral_index, outer_scale_m, wavelength_m, zenith_rad=0.0):
    """One-way one-dimensional phase spectrum Phi_1(kappa) (rad^2 m; module docstring, eq. S2)."""
    k0 = 2.0 * math.pi / np.asarray(outer_scale_m, dtype=float)
    nu = np.asarray(spectral_index, dtype=float) / 2.0
    return spectral_constant(c_kl, spectral_index, wavelength_m, zenith_rad) * (k0 * k0 + np.square(kappa)) ** -nu


def phase_variance(c_kl, spectral_index, outer_scale_m, wavelength_m, zenith_rad=0.0):
    """One-way phase variance sigma_phi^2 (rad^2; module docstring, eq. S3)."""
    k0 = 2.0 * math.pi / np.asarray(outer_scale_m, dtype=float)
    nu = np.asarray(spectral_index, dtype=float) / 2.0
    return ((ELECTRON_RADIUS_M * np.asarray(wavelength_m, float)) ** 2 / np.cos(zenith_rad) * np.asarray(c_kl)
            * k0 ** (1.0 - 2.0 * nu) / (4.0 * math.pi * (nu - 0.5)))


def matern_decorrelation(lag_m, spectral_index, outer_scale_m):
    """1 - R(Delta)/R(0) of the Matern correlation of smoothness mu = nu - 1/2 (module docstring, eq. S4);
    0 at Delta = 0, -> 1 beyond the outer scale. Broadcasts."""
    mu = np.asarray(spectral_index, dtype=float) / 2.0 - 0.5
    x = 2.0 * math.pi * np.abs(np.asarray(lag_m, dtype=float)) / np.asarray(outer_scale_m, dtype=float)
    safe = np.where(x > 0.0, x, 1.0)
    corr = 2.0 ** (1.0 - mu) / gamma_fn(mu) * safe ** mu * kv(mu, safe)
    corr = np.where(x > 0.0, corr, 1.0)
    return np.where(np.isfinite(corr), 1.0 - corr, 1.0)


def structure_function(lag_m, c_kl, spectral_index, outer_scale_m, wavelength_m, zenith_rad=0.0):
    """One-way phase structure function D(Delta) = E[(phi(x + Delta) - phi(x))^2] (rad^2; eq. S4)."""
    var = phase_variance(c_kl, spectral_index, outer_scale_m, wavelength_m, zenith_rad)
    return 2.0 * var * matern_decorrelation(lag_m, spectral_index, outer_scale_m)


def gps_phase_index(c_kl, spectral_index, outer_scale_m, cutoff_scale_m=1000.0, frequency_hz=1575.42e6):
    """sigma_phi of a ground receiver at ``frequency_hz`` (GPS L1 by default) after a detrending that keeps the
    scales shorter than ``cutoff_scale_m`` (0.1 Hz at a pierce-point speed of about 100 m/s): the variance of
    Phi_1 above kappa_c = 2 pi / cutoff (vertical path). The index the published high-latitude climatologies give
    (docs/theory/scintillation.md, eq. S5), which anchors the climatology's strength."""
    wavelength = 299792458.0 / frequency_hz
    kc = 2.0 * math.pi / cutoff_scale_m

    def integrand(k):
        return phase_spectrum(k, c_kl, spectral_index, outer_scale_m, wavelength) / math.pi

    from scipy.integrate import quad  # here: scipy.integrate costs every e2esim process a quarter second

    return math.sqrt(quad(integrand, kc, np.inf, limit=200)[0])


__all__ = [
    "ELECTRON_RADIUS_M",
    "SPECTRAL_INDEX_RANGE",
    "PhaseScreen",
    "check_screen",
    "gps_phase_index",
    "matern_decorrelation",
    "phase_spectrum",
    "phase_variance",
    "spectral_constant",
    "spectral_tail",
    "structure_function",
]


def spectral_tail(kappa, spectral_index, outer_scale_m):
    """integral_kappa^inf (kappa_0^2 + k^2)^-nu dk in units of kappa_0^(1 - 2 nu): with s = 1 / (1 + t^2),
    (1/2) B(nu - 1/2, 1/2) I_s(nu - 1/2, 1/2) (Abramowitz & Stegun 6.6.2); the share of the phase spectrum above
    ``kappa`` (eq. S2). Broadcasts."""
    nu = np.asarray(spectral_index, dtype=float) / 2.0
    t = np.asarray(kappa, dtype=float) * np.asarray(outer_scale_m, dtype=float) / (2.0 * math.pi)
    return 0.5 * beta(nu - 0.5, 0.5) * betainc(nu - 0.5, 0.5, 1.0 / (1.0 + t * t))
