"""Residual errors stated directly, instead of derived from a simulated calibration (issue 23, item 3).

A requirement is flowed down to what calibration must leave, not to how an estimator gets there: these steps
say what is left, and the propagation sees it exactly as it sees the residuals of a simulated strategy.

* ``ResidualFaradayStep`` (kind "faraday"): the Faraday rotation left in the data after correction,
  ``Omega - Omega_hat ~ N(bias, sd^2)`` (rad). It rotates the calibration data by the estimate
  ``Omega_hat = Omega - residual`` as a Faraday-rotation estimator would (Quegan et al. 2018, eq. 4), and its
  result is a ``FaradayStepResult`` whose ``omega_error = -residual``, so every consumer of
  ``CalibrationRecord.faraday_error()`` (the co-polarised channels of one pass, ``distortion.faraday_correction``;
  each pass of a stack, ``stack.faraday``) reads it. The standard-normal draws are standardised to sample mean 0
  and SD 1, so that the residual's moments are exactly the stated ones (the analytic moments read the mean and SD
  of the draws) and a solve over ``bias_deg`` or ``sd_deg`` is smooth; the Monte Carlo draws from the same values.
* ``StatedResidualStep`` (kind "stated"): levels of the residual system errors (crosstalk and channel-imbalance
  variances, noise power, gain offset and SD) that replace what the steps before it leave. It is not simulated:
  ``CalibrationRecord.simulate`` applies it to the residual model (a plain Gaussian ``SystemErrorModel`` with the
  raw instrument's correlation structure, Men et al. 2021, Section III), whose Monte Carlo then draws from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from e2esim.calibration.pipeline import PipelineContext
from e2esim.calibration.steps import CalibrationStep, FaradayStepResult, StepResult
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.polarimetry.system_model import faraday_matrix
from e2esim.units import linear_to_db


def standard_draws(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` standard-normal draws with sample mean exactly 0 and sample SD exactly 1 (n >= 2)."""
    z = rng.standard_normal(n)
    z = z - z.mean()
    return z / z.std()


@dataclass(frozen=True)
class ResidualFaradayStep(CalibrationStep):
    """The Faraday rotation left after correction, stated: N(bias_rad, sd_rad^2) (rad)."""

    bias_rad: float = 0.0
    sd_rad: float = 0.0
    kind = "faraday"

    def apply(self, ctx: PipelineContext) -> FaradayStepResult:
        left = self.bias_rad + self.sd_rad * standard_draws(ctx.rng, ctx.size)
        omega_hat = np.asarray(ctx.truth.omega) - left

        def rotation():
            rot = faraday_matrix(-omega_hat)
            return rot, rot
        ctx.apply_outer_of(rotation)  # made only where the corrections are read (a polarimetric step's residual)
        return FaradayStepResult(-left, np.zeros(ctx.size, dtype=bool), self.sd_rad, math.nan)


@dataclass(frozen=True)
class StatedResidualResult(StepResult):
    """The levels a ``StatedResidualStep`` set, as output scalars (dB)."""

    values: dict

    def summary(self) -> dict:
        return dict(self.values)


@dataclass(frozen=True)
class StatedResidualStep(CalibrationStep):
    """Residual system-error levels stated directly; None keeps what the steps before leave.

    crosstalk_variance, imbalance_variance : V_delta, V_eps (Men et al. 2021, eqs. 7-8). noise_power : sigma_n
    (the NESZ, linear). gain_offset_db, gain_sd_db : |A|^2 ~ N(offset, sd^2) in dB (Quegan et al. 2018, eq. 11).
    """

    crosstalk_variance: float | None = None
    imbalance_variance: float | None = None
    noise_power: float | None = None
    gain_offset_db: float | None = None
    gain_sd_db: float | None = None
    kind = "stated"

    def apply(self, ctx: PipelineContext) -> StatedResidualResult:  # never simulated (CalibrationRecord.simulate)
        return self.result()

    def result(self) -> StatedResidualResult:
        out = {}
        for name, key in (("crosstalk_variance", "crosstalk_variance_db"),
                          ("imbalance_variance", "imbalance_variance_db"), ("noise_power", "nesz_db")):
            value = getattr(self, name)
            if value is not None:
                out[key] = float(linear_to_db(value)) if value > 0 else -math.inf
        for name in ("gain_offset_db", "gain_sd_db"):
            if getattr(self, name) is not None:
                out[name] = float(getattr(self, name))
        return StatedResidualResult(out)

    def applied_to(self, model: SystemErrorModel) -> SystemErrorModel:
        """A plain Gaussian model with ``model``'s structure and the stated levels in place of its own."""
        plain = SystemErrorModel(**{f.name: getattr(model, f.name) for f in fields(SystemErrorModel)})
        changes = {name: float(getattr(self, step_name)) for name, step_name in (
            ("crosstalk_level", "crosstalk_variance"), ("imbalance_level", "imbalance_variance"),
            ("noise_power", "noise_power"), ("gain_offset_db", "gain_offset_db"), ("gain_sd_db", "gain_sd_db"))
            if getattr(self, step_name) is not None}
        return replace(plain, **changes)
