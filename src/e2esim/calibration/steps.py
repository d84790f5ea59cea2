"""The correction steps of a calibration strategy, vectorised over Monte Carlo realisations.

Each step (a ``CalibrationStep``) reads a ``PipelineContext`` (the true system per realisation and the
corrections so far), estimates something from simulated calibration data, updates the corrections and
returns a typed ``StepResult``: arrays of what it estimated wrongly, one value per realisation, and a
``summary()`` of scalars for the outputs. Steps that estimate the raw system (calibrators) act inside the
corrections made so far (``apply_inner``); steps that estimate what the current corrected data show (Faraday
rotation, distributed targets, trihedrals) act outside (``apply_outer``). ``kind`` is one of
``pipeline.STEP_KINDS``. A plug-in adds a step by subclassing ``CalibrationStep`` and ``StepResult`` and
returning the step from a calibration module's ``steps`` (docs/writing-a-module.md).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np

from e2esim.calibration.pipeline import PipelineContext
from e2esim.calibration.quegan1994 import quegan_calibrate
from e2esim.calibration.targets import Calibrators, calibrator_responses
from e2esim.calibration.transponder import solve_transponder
from e2esim.faraday.estimators import AMBIGUITY_PERIOD, resolve_ambiguity
from e2esim.faraday.theory import ambiguity_error_probability
from e2esim.polarimetry.simulate import SystemState
from e2esim.polarimetry.small_matrices import inverse2
from e2esim.polarimetry.system_model import faraday_matrix
from e2esim.units import linear_to_db


def _deg(x) -> np.ndarray:
    return np.degrees(np.asarray(x, dtype=float))


def _power_db(x) -> float:
    p = float(np.mean(np.abs(x) ** 2))
    return float(linear_to_db(p)) if p > 0 else -math.inf


@dataclass(frozen=True)
class StepResult(ABC):
    """What a step estimated wrongly, one value per realisation (array fields), and its output scalars."""

    @abstractmethod
    def summary(self) -> dict:
        """Scalars for the outputs (``calibration.<i>.<module>.<key>``), units in the key names."""

    @classmethod
    def concatenate(cls, parts: list) -> StepResult:
        """The results of several chunks of realisations as one (array fields joined, others from the first)."""
        first = parts[0]
        values = {}
        for f in fields(first):
            value = getattr(first, f.name)
            if isinstance(value, np.ndarray) and value.ndim:
                value = np.concatenate([getattr(p, f.name) for p in parts])
            values[f.name] = value
        return type(first)(**values)


class CalibrationStep(ABC):
    """One correction of a calibration strategy. ``kind``: "faraday", "polarimetric" or "gain"."""

    kind: ClassVar[str] = ""

    @abstractmethod
    def apply(self, ctx: PipelineContext) -> StepResult:
        """Estimate, update the corrections in ``ctx``, and return what was estimated wrongly."""


@dataclass(frozen=True)
class FaradayStepResult(StepResult):
    """omega_error : Omega_hat - Omega (rad); ambiguity_error : the pi/2 ambiguity resolved wrongly (bool).
    predicted_sd_rad : the estimator's theory (noise and speckle only). ambiguity_probability : probability
    that the prior resolves the ambiguity wrongly (NaN for an unambiguous estimator)."""

    omega_error: np.ndarray
    ambiguity_error: np.ndarray
    predicted_sd_rad: float
    ambiguity_probability: float

    def summary(self) -> dict:
        err = _deg(self.omega_error)
        out = {
            "omega_error_mean_deg": float(np.mean(err)),
            "omega_error_sd_deg": float(np.std(err)),
            "omega_error_rms_deg": float(np.sqrt(np.mean(err**2))),
            "omega_error_abs_q99865_deg": float(np.quantile(np.abs(err), 0.99865)),
            "ambiguity_error_fraction": float(np.mean(self.ambiguity_error)),
            "predicted_noise_sd_deg": float(np.degrees(self.predicted_sd_rad)),
        }
        if not math.isnan(self.ambiguity_probability):
            out["ambiguity_error_probability"] = self.ambiguity_probability
        return out


@dataclass(frozen=True)
class FaradayStep(CalibrationStep):
    """Estimate Omega on the corrected scene and rotate it away (Quegan et al. 2018, eq. 4).

    estimator : a ``FaradayEstimatorModule`` (``e2esim.faraday.estimator_modules``). looks : samples in the
    window. prior : "climatology" (the raw distribution's mean) or "tec_map" (truth + N(0, prior_sd_rad^2)),
    used to resolve the pi/2 ambiguity of an ambiguous estimator. instrument : the instrument's description
    (frequency and bandwidth, for the chirp slope).
    """

    estimator: object
    looks: int = 10_000
    prior: str = "climatology"
    prior_sd_rad: float = 0.0
    instrument: object = None
    kind = "faraday"

    def apply(self, ctx: PipelineContext) -> FaradayStepResult:
        omega_true = np.asarray(ctx.truth.omega)
        omega = self.estimator.estimate(ctx, self.looks, self.instrument)
        probability = float("nan")
        if self.estimator.ambiguous:
            if self.prior == "climatology":
                prior = np.full(ctx.size, ctx.faraday.mean_rad)
            else:
                prior = omega_true + self.prior_sd_rad * ctx.rng.standard_normal(ctx.size)
            omega = resolve_ambiguity(omega, prior)
            prior_sd = ctx.faraday.sd_rad if self.prior == "climatology" else self.prior_sd_rad
            probability = float(ambiguity_error_probability(prior_sd, 0.0, AMBIGUITY_PERIOD))
        rot = faraday_matrix(-omega)
        ctx.apply_outer(rot, rot)
        error = omega - omega_true
        predicted = self.estimator.predicted_sd(ctx.scene, ctx.noise_power, ctx.faraday, self.looks, self.instrument)
        return FaradayStepResult(error, np.abs(np.round(error / AMBIGUITY_PERIOD)) > 0, predicted, probability)


@dataclass(frozen=True)
class QueganStepResult(StepResult):
    """estimated_delta : the crosstalk the algorithm found (n, 4); estimated_alpha : its alpha (n,)."""

    estimated_delta: np.ndarray
    estimated_alpha: np.ndarray

    def summary(self) -> dict:
        return {"estimated_crosstalk_power_db": _power_db(self.estimated_delta)}


@dataclass(frozen=True)
class QueganStep(CalibrationStep):
    """Crosstalk and f1/f2 from a distributed-target window by Quegan (1994), corrected outside."""

    looks: int = 100_000
    iterations: int = 1
    subtract_noise: bool = True
    kind = "polarimetric"

    def apply(self, ctx: PipelineContext) -> QueganStepResult:
        cov = ctx.corrected(ctx.window(self.looks))
        q = quegan_calibrate(cov, self.iterations, ctx.noise_power if self.subtract_noise else None)
        ctx.apply_outer(inverse2(q.receive), inverse2(q.transmit))
        return QueganStepResult(q.delta, q.alpha)


@dataclass(frozen=True)
class TrihedralStepResult(StepResult):
    """copol_imbalance : the estimated k = f1 f2 (n,) after the crosstalk correction; gain : the absolute
    gain found (n,), or None."""

    copol_imbalance: np.ndarray
    gain: np.ndarray | None = None

    def summary(self) -> dict:
        return {"copol_imbalance_error_power_db": _power_db(self.copol_imbalance - 1)}


@dataclass(frozen=True)
class TrihedralStep(CalibrationStep):
    """Co-polarised imbalance k = f1 f2 (and optionally the absolute gain) from trihedrals in the scene.

    For a trihedral ``M = A R F(2 Omega) T``, so ``det M / (M_hh^2 + M_vh^2) = f1 f2`` and
    ``M_hh^2 + M_vh^2 = A^2`` at any Faraday rotation when the crosstalk is corrected (first order).
    Estimated over the reflectors as ratios of sums, then split equally between receive and transmit.
    """

    calibrators: Calibrators
    absolute_gain: bool = True
    kind = "polarimetric"

    def apply(self, ctx: PipelineContext) -> TrihedralStepResult:
        m = calibrator_responses(ctx.rng, self.calibrators, ctx.truth)  # (n, K, 2, 2)
        m = ctx.p_receive[:, None] @ m @ ctx.p_transmit[:, None]
        a2 = m[..., 0, 0] ** 2 + m[..., 0, 1] ** 2
        k = np.sum(np.linalg.det(m), -1) / np.sum(a2, -1)
        half = np.sqrt(k)
        corr = np.zeros((ctx.size, 2, 2), complex)
        corr[:, 0, 0] = 1.0
        corr[:, 1, 1] = 1.0 / half
        ctx.apply_outer(corr, corr)
        gain = None
        if self.absolute_gain:
            gain = np.sqrt(np.mean(a2, -1))  # complex root; its sign is a common phase
            ctx.p_receive = ctx.p_receive / gain[:, None, None]
        return TrihedralStepResult(k, gain)


@dataclass(frozen=True)
class TransponderStepResult(StepResult):
    """Errors of the least-squares solution per realisation: delta (n, 4), f (n, 2), gain (dB), the Omega at
    the calibration site (rad), and the fit's chi^2."""

    delta_error: np.ndarray
    f_error: np.ndarray
    gain_error_db: np.ndarray
    site_omega_error: np.ndarray
    chi2: np.ndarray

    def summary(self) -> dict:
        return {
            "delta_error_power_db": _power_db(self.delta_error),
            "imbalance_error_power_db": _power_db(self.f_error),
            "gain_error_sd_db": float(np.std(self.gain_error_db)),
            "site_omega_error_sd_deg": float(np.std(_deg(self.site_omega_error))),
            "chi2_mean": float(np.mean(self.chi2)),
        }


@dataclass(frozen=True)
class TransponderStep(CalibrationStep):
    """All system errors from polarimetric calibrators by non-linear least squares (``transponder``).

    site_faraday : FaradayDistribution at the calibration site, or None when the calibrators are in the
        scene (same Omega); correct_faraday : then also rotate the scene by the Omega found.
    absolute_gain : also take the absolute gain from the calibrators (their RCS known); otherwise the
        correction keeps the HH scale (``R11 = T11 = 1``) and the instrument's gain statistics stand.
    """

    calibrators: Calibrators
    gauge: str = "min_crosstalk"
    site_faraday: object = None
    prior_sd_rad: float = 0.0
    correct_faraday: bool = False
    absolute_gain: bool = True
    kind = "polarimetric"

    def apply(self, ctx: PipelineContext) -> TransponderStepResult:
        t = ctx.truth
        site = t.omega if self.site_faraday is None else self.site_faraday.sample(ctx.rng, ctx.size)
        state = SystemState(t.delta, t.f, site, t.gain)
        responses = calibrator_responses(ctx.rng, self.calibrators, state)
        prior = None
        if self.gauge == "faraday_prior":  # an independent Omega estimate at the site, SD prior_sd_rad
            prior = (site + self.prior_sd_rad * ctx.rng.standard_normal(ctx.size), self.prior_sd_rad)
        sol = solve_transponder(responses, self.calibrators, self.gauge, faraday_prior=prior)
        receive = sol.receive_matrix() if self.absolute_gain else sol.receive_matrix() / sol.gain[:, None, None]
        ctx.apply_inner(inverse2(receive), inverse2(sol.transmit_matrix()))
        if self.correct_faraday and self.site_faraday is None:
            rot = faraday_matrix(-sol.omega)
            ctx.apply_outer(rot, rot)
        return TransponderStepResult(sol.delta - t.delta, sol.f - t.f, 20 * np.log10(np.abs(sol.gain / t.gain)),
                                     sol.omega - site, sol.chi2)


@dataclass(frozen=True)
class GainStepResult(StepResult):
    """gain_error_db : error of the estimated |A|^2 (dB) per realisation."""

    gain_error_db: np.ndarray

    def summary(self) -> dict:
        return {"gain_error_mean_db": float(np.mean(self.gain_error_db)),
                "gain_error_sd_db": float(np.std(self.gain_error_db))}


@dataclass(frozen=True)
class GainStep(CalibrationStep):
    """Absolute gain set from an external estimate of the current |gain| with error ``N(offset_db, sd_db^2)``
    in |A|^2 (dB). The current gain is ``|A| sqrt|det P_r det P_t|`` (rotations have unit determinant), so a
    later gain step re-sets the scale rather than compounding it; the residual |A|^2 is ``-error`` in dB."""

    sd_db: float = 0.0
    offset_db: float = 0.0
    kind = "gain"

    def apply(self, ctx: PipelineContext) -> GainStepResult:
        err_db = self.offset_db + self.sd_db * ctx.rng.standard_normal(ctx.size)
        current = np.abs(ctx.truth.gain) * np.sqrt(np.abs(np.linalg.det(ctx.p_receive) * np.linalg.det(ctx.p_transmit)))
        ctx.p_receive = ctx.p_receive / (current * 10 ** (err_db / 20))[:, None, None]
        return GainStepResult(err_db)
