"""System errors of every pass of a stack, from fully stable to independent.

Each pass n has its own crosstalk, channel imbalance and gain with the single-pass statistics of Men et al.
(2021), Section III (``SystemErrorModel``). Between passes (ground-cancellation.md, eq. 8):

    xi_n = sqrt(rho) xi_c + sqrt(1 - rho) xi'_n,     E[xi_m xi_n^H] = (rho + (1 - rho) delta_mn) Sigma_1,

for xi = (delta_1..delta_4, epsilon_1, epsilon_2), with xi_c, xi'_n independent draws of the single-pass model
and the same for the gain in dB. rho = 1: the errors are stable, identical on every pass (the proviso of Men et
al. 2021, Section VI); rho = 0: independent. Noise is independent between passes.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.stack.quadratic_form import error_structure
from e2esim.units import db_to_linear

_AMPLITUDE_PER_DB = np.log(10.0) / 20.0  # d ln(amplitude) / d(power in dB)


def error_covariance(v, c13, c24, ve, ce12) -> np.ndarray:
    """Sigma_1 = E[xi xi^H] (6 x 6) of xi = (delta_1..delta_4, epsilon_1, epsilon_2) from the variances and pair
    covariances of Men et al. (2021), eqs. (7)-(8)."""
    s = np.zeros((6, 6), complex)
    s[[0, 1, 2, 3], [0, 1, 2, 3]] = np.asarray(v)
    s[[4, 5], [4, 5]] = np.asarray(ve)
    s[0, 2], s[2, 0] = c13, np.conj(c13)
    s[1, 3], s[3, 1] = c24, np.conj(c24)
    s[4, 5], s[5, 4] = ce12, np.conj(ce12)
    return s


@dataclass(frozen=True, eq=False)
class StackSystemErrors:
    """The single-pass error statistics ``system`` and the correlation ``correlation`` (rho of eq. 8)."""

    system: SystemErrorModel
    correlation: float = 1.0

    def __post_init__(self):
        if not 0.0 <= self.correlation <= 1.0:
            raise PhysicsInputError(f"the correlation of the system errors between passes must be in [0, 1], got "
                                    f"{self.correlation}")

    def pass_correlation(self, passes: int) -> np.ndarray:
        """r_mn = rho + (1 - rho) delta_mn (N x N)."""
        return self.correlation + (1.0 - self.correlation) * np.eye(passes)

    def unit_covariances(self) -> tuple[np.ndarray, np.ndarray]:
        """(Sigma_delta, Sigma_epsilon): Sigma_1 for unit crosstalk and unit channel-imbalance levels, so that
        Sigma_1 = V_delta Sigma_delta + V_epsilon Sigma_epsilon."""
        v, c13, c24, ve, ce12 = self.system.unit_structure
        return (error_covariance(v, c13, c24, np.zeros(2), 0.0),
                error_covariance(np.zeros(4), 0.0, 0.0, ve, ce12))

    @functools.cached_property
    def kernel_structure(self) -> tuple:
        """``e2esim.stack.quadratic_form.error_structure`` of the unit covariances (computed once)."""
        return error_structure(*self.unit_covariances())

    @functools.cached_property
    def common_gain_moments(self) -> tuple[float, float]:
        """(E G, E G^2) of the gain power common to all passes (offset, SD sqrt(rho) x the gain SD in dB); computed
        once (the analytic moments read it at every evaluation)."""
        common = SystemErrorModel(gain_offset_db=self.system.gain_offset_db,
                                  gain_sd_db=self.system.gain_sd_db * np.sqrt(self.correlation))
        return common.gain_power_moments

    @property
    def pass_gain_log_sd(self) -> float:
        """SD of the log amplitude of each pass's own gain factor eta_n = exp(beta z_n)."""
        return float(_AMPLITUDE_PER_DB * self.system.gain_sd_db * np.sqrt(1.0 - self.correlation))

    def sample(self, rng: np.random.Generator, realisations: int, passes: int):
        """(delta (M, N, 4), f (M, N, 2), amplitude gain (M, N)) of eq. (8)."""
        rho = self.correlation
        common = self.system.sample(rng, realisations)
        own = self.system.sample(rng, realisations * passes)
        a, b = np.sqrt(rho), np.sqrt(1.0 - rho)
        delta = a * common.delta[:, None, :] + b * own.delta.reshape(realisations, passes, 4)
        eps = a * (common.f[:, None, :] - 1.0) + b * (own.f.reshape(realisations, passes, 2) - 1.0)
        s = self.system
        if s.has_gain_error:
            z = a * rng.standard_normal((realisations, 1)) + b * rng.standard_normal((realisations, passes))
            gain = np.sqrt(db_to_linear(s.gain_offset_db + s.gain_sd_db * z)) * np.ones((1, passes))
        else:
            gain = np.ones((realisations, passes))
        return delta, 1.0 + eps, gain
