"""What the calibration modules did: the strategy so far and the residual errors it leaves (``state.calibration``).

Each calibration module appends its step to the ``CalibrationRecord`` and re-runs the whole strategy on
simulated calibration data (``pipeline.ResidualSampler``), so that steps that depend on each other
(e.g. Faraday rotation estimated on data a transponder calibration has corrected) are simulated together.
The residual then replaces ``state.system`` and ``state.faraday`` for the propagation:

* once a step has corrected crosstalk or imbalance: a ``ResidualSystemErrorModel`` (exact draws for the
  Monte Carlo, Gaussian moments for the analytic model) and no Faraday rotation left
  (``ConstantFaraday(0)``: any residual rotation is part of the residual crosstalk);
* while only Faraday rotation (and gain) has been corrected: the raw crosstalk, imbalance and Faraday
  rotation, with the gain replaced. This is exact, not an approximation: the sigma_hv estimator
  ``(M_hv + M_vh)/2`` of Men et al. (2021), eq. (2), is unchanged by the rotation ``F(-W) M F(-W)`` for any W
  (the symmetrised cross-polar sum is invariant under it), so Faraday-rotation correction alone cannot
  change the sigma_hv error; its residual Faraday rotation (the estimator's bias and SD) is reported here
  and matters for what follows (co-polarised channels, later calibration steps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from e2esim.faraday.estimators import AMBIGUITY_PERIOD
from e2esim.calibration.pipeline import ResidualSampler, fit_residual_model
from e2esim.faraday.distribution import ConstantFaraday
from e2esim.units import linear_to_db

_PILOT_MIN, _PILOT_MAX = 2_000, 20_000  # realisations of the pilot run behind the residual model


@dataclass(frozen=True)
class StepSummary:
    """One calibration step: its module type and scalar results (units in the key names)."""

    name: str
    kind: str
    values: dict = field(default_factory=dict)


@dataclass(frozen=True)
class CalibrationRecord:
    """The calibration strategy applied to a case and what it leaves.

    raw_system, raw_faraday : the instrument's errors and the geophysical Faraday rotation before
        calibration. scene : the target the distributed-target steps use. steps : pipeline steps in order;
        names : the module type of each. summaries : a ``StepSummary`` per step. residual : scalars of
        the residual model (levels in dB, unmodelled structure). representation : "raw" (nothing
        applied), "rotation_invariant" (Faraday rotation and gain only) or "residual".
    """

    raw_system: object
    raw_faraday: object
    scene: object
    steps: tuple = ()
    names: tuple = ()
    summaries: tuple = ()
    residual: dict = field(default_factory=dict)
    representation: str = "raw"

    @classmethod
    def start(cls, state) -> "CalibrationRecord":
        if isinstance(state.calibration, CalibrationRecord):
            return state.calibration
        raw = state.raw_system if state.raw_system is not None else state.system
        return cls(raw, state.faraday, state.scene)

    def extended(self, name: str, step) -> "CalibrationRecord":
        return replace(self, steps=self.steps + (step,), names=self.names + (name,))

    def sampler(self) -> ResidualSampler:
        return ResidualSampler(self.raw_system, self.raw_faraday, self.scene, self.raw_system.noise_power, self.steps)

    def apply(self, state):
        """Simulate the strategy (pilot of ``settings.realisations`` draws, within limits) and return the
        state the propagation should see."""
        if not self.steps:
            return state.with_(calibration=self)
        n = int(min(max(state.settings.realisations, _PILOT_MIN), _PILOT_MAX))
        sampler = self.sampler()
        res = sampler.sample(state.rng, n)
        summaries = tuple(StepSummary(name, step.kind, summarise(step, diag, self))
                          for name, step, diag in zip(self.names, self.steps, res.diagnostics))
        if any(step.kind == "polarimetric" for step in self.steps):
            model, unmodelled = fit_residual_model(res, self.raw_system.noise_power, sampler)
            residual = {**unmodelled, "gain_offset_db": model.gain_offset_db}
            record = replace(self, summaries=summaries, residual=residual, representation="residual")
            return state.with_(system=model, faraday=ConstantFaraday(0.0), calibration=record)
        model = self.raw_system
        gain_steps = [i for i, step in enumerate(self.steps) if step.kind == "gain"]
        if gain_steps:  # the last gain step sets the scale: residual |A|^2 is minus its error (dB)
            resid_db = -res.diagnostics[gain_steps[-1]]["gain_error_db"]
            model = replace(self.raw_system, gain_offset_db=float(np.mean(resid_db)), gain_sd_db=float(np.std(resid_db)))
        residual = {"gain_offset_db": model.gain_offset_db, "gain_sd_db": model.gain_sd_db}
        record = replace(self, summaries=summaries, residual=residual, representation="rotation_invariant")
        return state.with_(system=model, faraday=self.raw_faraday, calibration=record)

    def scalars(self) -> dict:
        """Flat ``calibration.<i>.<module>.<key>`` and ``calibration.residual.<key>`` scalars."""
        out = {"calibration.steps": float(len(self.steps))}
        for i, s in enumerate(self.summaries):
            for key, value in s.values.items():
                out[f"calibration.{i}.{s.name}.{key}"] = float(value)
        for key, value in self.residual.items():
            out[f"calibration.residual.{key}"] = float(value)
        return out


def _deg(x) -> np.ndarray:
    return np.degrees(np.asarray(x, dtype=float))


def _power_db(x) -> float:
    p = float(np.mean(np.abs(x) ** 2))
    return float(linear_to_db(p)) if p > 0 else -math.inf


def summarise(step, diag: dict, record: CalibrationRecord) -> dict:
    """Scalars of one step's diagnostics (errors of what it estimated), with theory where there is one."""
    out: dict = {}
    if step.kind == "faraday":
        err = _deg(diag["omega_error"])
        out.update({
            "omega_error_mean_deg": float(np.mean(err)),
            "omega_error_sd_deg": float(np.std(err)),
            "omega_error_rms_deg": float(np.sqrt(np.mean(err**2))),
            "omega_error_abs_q99865_deg": float(np.quantile(np.abs(err), 0.99865)),
            "ambiguity_error_fraction": float(np.mean(diag["ambiguity_error"])),
        })
        out.update(faraday_theory_values(step, record))
    elif "delta_error" in diag:  # transponder
        out.update({
            "delta_error_power_db": _power_db(diag["delta_error"]),
            "imbalance_error_power_db": _power_db(diag["f_error"]),
            "gain_error_sd_db": float(np.std(diag["gain_error_db"])),
            "site_omega_error_sd_deg": float(np.std(_deg(diag["site_omega_error"]))),
            "chi2_mean": float(np.mean(diag["chi2"])),
        })
    elif "gain_error_db" in diag:  # gain step
        out.update({"gain_error_mean_db": float(np.mean(diag["gain_error_db"])),
                    "gain_error_sd_db": float(np.std(diag["gain_error_db"]))})
    elif "copol_imbalance" in diag:  # trihedral
        out["copol_imbalance_error_power_db"] = _power_db(diag["copol_imbalance"] - 1)
    elif "estimated_delta" in diag:  # distributed target
        out["estimated_crosstalk_power_db"] = _power_db(diag["estimated_delta"])
    return out


def faraday_theory_values(step, record: CalibrationRecord) -> dict:
    """Predicted noise SD of the Faraday-rotation estimate (no crosstalk) and the probability that the
    climatology prior resolves the pi/2 ambiguity wrongly."""
    from e2esim.faraday.chirp import chirp_omega0_sd
    from e2esim.faraday.theory import (
        ambiguity_error_probability, bickel_bates_snr, bickel_bates_variance, freeman_variance,
    )

    snr = bickel_bates_snr(record.scene, record.raw_system.noise_power)
    out = {}
    if step.method == "chirp_slope":
        out["predicted_noise_sd_deg"] = float(np.degrees(chirp_omega0_sd(snr, step.looks, step.chirp)))
    elif step.method == "bickel_bates":
        out["predicted_noise_sd_deg"] = float(np.degrees(np.sqrt(bickel_bates_variance(snr, step.looks))))
    else:  # Freeman, at the mean Faraday rotation (delta method: not near 0 or 45 deg)
        var = freeman_variance(record.scene, record.raw_system.noise_power, record.raw_faraday.mean_rad, step.looks,
                               step.noise_subtraction)
        out["predicted_noise_sd_deg"] = float(np.degrees(np.sqrt(var)))
    if step.method != "chirp_slope":
        prior_sd = record.raw_faraday.sd_rad if step.prior == "climatology" else step.prior_sd_rad
        out["ambiguity_error_probability"] = float(ambiguity_error_probability(prior_sd, 0.0, AMBIGUITY_PERIOD))
    return out
