"""What a calibration strategy did and the residual errors it leaves (product ``calibration``).

The calibration stage (``e2esim.calibration.stage``) appends each calibration module's steps to a
``CalibrationRecord`` and then simulates the whole strategy once on calibration data (``pipeline.ResidualSampler``),
so that steps that depend on each other (e.g. Faraday rotation estimated on data a transponder calibration
has corrected) are simulated together. The record then gives the residual products the propagation applies,
beside the raw ``system`` and ``faraday.geophysical``, which stay as they are:

* once a step has corrected crosstalk or imbalance: ``system.residual`` is a ``ResidualSystemErrorModel``
  (exact draws for the Monte Carlo, Gaussian moments for the analytic model) and ``faraday.residual`` is no
  rotation (``ConstantFaraday(0)``: any residual rotation is part of the residual crosstalk);
* while only Faraday rotation (and gain) has been corrected: the raw crosstalk, imbalance and Faraday
  rotation, with the gain replaced. This is exact, not an approximation, for the sigma_hv estimator
  ``(M_hv + M_vh)/2`` of Men et al. (2021), eq. (2): it is unchanged by the rotation ``F(-W) M F(-W)`` for any W
  (the symmetrised cross-polar sum is invariant under it), so Faraday-rotation correction alone cannot change
  the sigma_hv error. The error of the Faraday-rotation estimate (the rotation actually left in the data) is
  in the step's result (``faraday_error``), for what follows (co-polarised channels).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from e2esim.block import Batched
from e2esim.calibration.pipeline import ResidualSampler, fit_residual_model
from e2esim.calibration.steps import FaradayStepResult
from e2esim.faraday.distribution import ConstantFaraday, EmpiricalFaraday

_PILOT_MIN, _PILOT_MAX = 2_000, 20_000  # realisations of the pilot run behind the residual model
REPRESENTATIONS = ("raw", "rotation_invariant", "residual", "stated")


@dataclass(frozen=True)
class StepSummary:
    """One calibration step: its module type, kind and scalar results (units in the key names)."""

    name: str
    kind: str
    values: dict = field(default_factory=dict)


@dataclass(frozen=True)
class CalibrationRecord(Batched):
    """The calibration strategy applied to a case and what it leaves. Without steps, also that of a block of
    cases (``e2esim.block.Batched``): its raw products are then the block's, and ``item`` gives a case's record.

    raw_system, raw_faraday : the instrument's errors and the geophysical Faraday rotation before
        calibration. scene : the target the distributed-target steps use. steps : pipeline steps in order;
        names : the module type of each. results : the ``StepResult`` of each step (last simulation).
        summaries : a ``StepSummary`` per step. residual : scalars of the residual model (levels in dB,
        unmodelled structure). representation : "raw" (nothing applied), "rotation_invariant" (Faraday
        rotation and gain only) or "residual". declared : the scenario has a calibration section (a chain
        without one writes no calibration outputs).
    """

    raw_system: object
    raw_faraday: object
    scene: object
    steps: tuple = ()
    names: tuple = ()
    results: tuple = ()
    summaries: tuple = ()
    residual: dict = field(default_factory=dict)
    representation: str = "raw"
    declared: bool = True

    def __len__(self) -> int:
        return len(self.raw_system)

    def item(self, i: int) -> CalibrationRecord:
        scene = None if self.scene is None else self.scene.item(i)
        return replace(self, raw_system=self.raw_system.item(i), raw_faraday=self.raw_faraday.item(i), scene=scene)

    def extended(self, name: str, step) -> CalibrationRecord:
        return replace(self, steps=self.steps + (step,), names=self.names + (name,))

    def sampler(self) -> ResidualSampler:
        return ResidualSampler(self.raw_system, self.raw_faraday, self.scene, self.raw_system.noise_power, self.steps)

    def simulate(self, rng: np.random.Generator, realisations: int) -> tuple:
        """Simulate the strategy (a pilot of ``realisations`` draws, within limits); return the completed
        record and the residual system and Faraday rotation the propagation applies."""
        if not self.steps:
            return self, self.raw_system, self.raw_faraday
        if any(step.kind == "stated" for step in self.steps):
            return self._simulate_stated(rng, realisations)
        n = int(min(max(realisations, _PILOT_MIN), _PILOT_MAX))
        sampler = self.sampler()
        polarimetric = any(step.kind == "polarimetric" for step in self.steps)
        res = sampler.sample(rng, n, residuals=polarimetric)  # only a polarimetric step's residual system is read
        summaries = tuple(StepSummary(name, step.kind, result.summary())
                          for name, step, result in zip(self.names, self.steps, res.diagnostics))
        done = replace(self, results=tuple(res.diagnostics), summaries=summaries)
        if polarimetric:
            model, unmodelled = fit_residual_model(res, self.raw_system.noise_power, sampler)
            residual = {**unmodelled, "gain_offset_db": model.gain_offset_db}
            return replace(done, residual=residual, representation="residual"), model, ConstantFaraday(0.0)
        model = self.raw_system
        gain_steps = [i for i, step in enumerate(self.steps) if step.kind == "gain"]
        if gain_steps:  # the last gain step sets the scale: residual |A|^2 is minus its error (dB)
            resid_db = -res.diagnostics[gain_steps[-1]].gain_error_db
            model = replace(
                self.raw_system, gain_offset_db=float(np.mean(resid_db)), gain_sd_db=float(np.std(resid_db))
            )
        residual = {"gain_offset_db": model.gain_offset_db, "gain_sd_db": model.gain_sd_db}
        return replace(done, residual=residual, representation="rotation_invariant"), model, self.raw_faraday

    def _simulate_stated(self, rng: np.random.Generator, realisations: int) -> tuple:
        """Simulate the steps that are not stated, then apply the stated residual levels
        (``e2esim.calibration.stated_steps``), in order, to the residual system they leave."""
        simulated = [i for i, step in enumerate(self.steps) if step.kind != "stated"]
        inner = replace(self, steps=tuple(self.steps[i] for i in simulated),
                        names=tuple(self.names[i] for i in simulated))
        done, model, faraday = inner.simulate(rng, realisations)
        results, summaries = list(done.results), list(done.summaries)
        for i, (name, step) in enumerate(zip(self.names, self.steps)):
            if step.kind == "stated":
                model = step.applied_to(model)
                result = step.result()
                results.insert(i, result)
                summaries.insert(i, StepSummary(name, step.kind, result.summary()))
        residual = {**done.residual, "gain_offset_db": model.gain_offset_db, "gain_sd_db": model.gain_sd_db}
        representation = "stated" if done.representation == "raw" else done.representation
        return (replace(done, steps=self.steps, names=self.names, results=tuple(results), summaries=tuple(summaries),
                        residual=residual, representation=representation), model, faraday)

    def faraday_error(self) -> EmpiricalFaraday | None:
        """The Faraday rotation left in the data by the last Faraday-rotation step (Omega - Omega_hat: its
        estimation error, rad), or None when no step estimated it."""
        errors = [r.omega_error for r in self.results if isinstance(r, FaradayStepResult)]
        if not errors:
            return None
        return EmpiricalFaraday(-np.asarray(errors[-1]), label="Faraday rotation left after correction")

    def scalars(self) -> dict:
        """Output scalars (``calibration.*``): ``steps`` (how many), ``<i>.<module>.<key>`` per step and
        ``residual.<key>`` of the residual model; none for a chain without a calibration section."""
        if not self.declared:
            return {}
        out = {"steps": float(len(self.steps))}
        for i, s in enumerate(self.summaries):
            for key, value in s.values.items():
                out[f"{i}.{s.name}.{key}"] = float(value)
        for key, value in self.residual.items():
            out[f"residual.{key}"] = float(value)
        return out
