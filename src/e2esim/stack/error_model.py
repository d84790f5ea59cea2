"""The error model of a multi-pass HV estimate: single date, multi-date average or ground cancelled.

``StackHVErrorModel`` is what the ``stack_backscatter_error`` stage provides as ``backscatter.error``. It answers
the questions of ``e2esim.error_model.ErrorModel`` from the analytic moments of ``e2esim.stack.analytic`` (and
carries the exact Monte Carlo of ``e2esim.stack.montecarlo`` when simulated), so retrieval, verdicts, margins,
attribution and trade-off curves work on ground-cancelled data through the requirement code unchanged.

Levels: ``crosstalk`` and ``channel_imbalance`` (V_delta, V_epsilon), ``nesz`` (sigma_n) and
``faraday_difference`` (sigma_D^2, rad^2: the variance of the Faraday-rotation difference of two passes).
Sources ``without`` removes: the three level sources, ``faraday_rotation`` (the stack's common rotation),
``faraday_difference``, ``system_instability`` (the errors made identical on every pass), ``gain``,
``temporal_decorrelation`` (the scene without it: its value changes too) and, for the population reference,
``speckle``. Every evaluation is kept with the model object.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from e2esim.distortion.validation import compare_with_analytic, sample_moments
from e2esim.error_model import Contribution, ErrorModel
from e2esim.faraday.distribution import ConstantFaraday
from e2esim.stack.analytic import StackHVMoments, stack_hv_moments
from e2esim.stack.combination import PassCombination
from e2esim.stack.faraday import StackFaraday
from e2esim.stack.montecarlo import StackMonteCarloErrors
from e2esim.stack.scene import StackScene
from e2esim.stack.system import StackSystemErrors
from e2esim.stack.temporal import TemporalDecorrelation

LEVELS = ("crosstalk", "channel_imbalance", "nesz", "faraday_difference")
BASE_SOURCES = ("crosstalk", "channel_imbalance", "noise", "faraday_rotation", "faraday_difference",
                "system_instability", "gain", "temporal_decorrelation")

CONTRIBUTION_DESCRIPTIONS = {
    "system_distortions": "crosstalk, channel imbalance and gain identical on every pass, no Faraday rotation "
                          "(Men et al. 2021 on the combined covariance)",
    "faraday_rotation": "what the stack's common Faraday rotation adds",
    "faraday_difference": "what the Faraday-rotation differences between the passes add",
    "system_instability": "what system errors that differ between the passes add",
    "noise": "thermal noise of the combined passes: its bias and its spread over the looks",
    "speckle": "speckle over the looks, with the inter-pass coherence of the stack",
}


@dataclass(frozen=True, eq=False)
class StackHVErrorModel(ErrorModel):
    """Error of a multi-pass HV estimate (module docstring).

    scene : the ``StackScene``. errors : per-pass system errors. faraday : per-pass Faraday rotation.
    combination : the estimator (``PassCombination``). looks : L, or None for L -> infinity. reference :
    "scene" or "population". montecarlo : simulated errors of every channel, or None. gaussianity : statistics
    of the simulated HV errors, or None. notes, unavailable : as ``ErrorModel``.
    """

    scene: StackScene
    errors: StackSystemErrors
    faraday: StackFaraday
    combination: PassCombination
    looks: int | None = None
    reference: str = "scene"
    montecarlo: StackMonteCarloErrors | None = None
    gaussianity: dict | None = None
    notes: tuple = ()
    unavailable: str | None = None
    _memo: dict = field(default_factory=dict, repr=False, compare=False)

    channel = "hv"

    @property
    def value(self) -> float:
        return self.combination.value(self.scene.channel_matrix(1))

    @property
    def includes_speckle(self) -> bool:
        return self.reference == "population"

    @property
    def levels(self) -> dict:
        s = self.errors.system
        return {"crosstalk": s.crosstalk_level, "channel_imbalance": s.imbalance_level, "nesz": s.noise_power,
                "faraday_difference": self.faraday.difference_sd**2}

    @property
    def sources(self) -> tuple:
        return BASE_SOURCES + (("speckle",) if self.reference == "population" else ())

    # Moments ---------------------------------------------------------------------------------------
    def moments(self, crosstalk=None, channel_imbalance=None, nesz=None, faraday_difference=None,
                **unknown) -> StackHVMoments:
        if unknown:
            raise TypeError(f"unknown levels {', '.join(unknown)}; this model has {', '.join(LEVELS)}")
        self.check_available()
        cache = self._memo.setdefault("node terms", {})
        return stack_hv_moments(self.scene, self.errors, self.faraday, self.combination, self.looks, self.reference,
                                crosstalk, channel_imbalance, nesz, faraday_difference, cache)

    def current(self) -> StackHVMoments:
        if "current" not in self._memo:
            self._memo["current"] = self.moments()
        return self._memo["current"]

    # Sources removed -------------------------------------------------------------------------------
    def without(self, source: str) -> StackHVErrorModel:
        if source not in self.sources:
            raise KeyError(f"unknown error source {source!r}; sources: {', '.join(self.sources)}")
        key = f"without {source}"
        if key not in self._memo:
            self._memo[key] = self._without(source)
        return self._memo[key]

    def _without(self, source: str) -> StackHVErrorModel:
        sysm = self.errors.system
        if source in ("crosstalk", "channel_imbalance", "noise"):
            level = {"crosstalk": "crosstalk", "channel_imbalance": "imbalance", "noise": "noise_power"}[source]
            if getattr(sysm, {"crosstalk": "crosstalk_level", "channel_imbalance": "imbalance_level",
                               "noise": "noise_power"}[source]) == 0.0:
                return self
            return self._variant(errors=dataclasses.replace(self.errors, system=sysm.with_levels(**{level: 0.0})),
                                 same_structure=True)
        if source == "faraday_rotation":
            common = self.faraday.common
            if common.mean_rad == 0.0 and common.sd_rad == 0.0:
                return self
            return self._variant(faraday=dataclasses.replace(self.faraday, common=ConstantFaraday(0.0)))
        if source == "faraday_difference":
            return self if self.faraday.difference_sd == 0.0 else self._variant(
                faraday=dataclasses.replace(self.faraday, difference_sd=0.0), same_structure=True)
        if source == "system_instability":
            return self if self.errors.correlation == 1.0 else self._variant(
                errors=dataclasses.replace(self.errors, correlation=1.0))
        if source == "gain":
            return self if not sysm.has_gain_error else self._variant(errors=dataclasses.replace(
                self.errors, system=dataclasses.replace(sysm, gain_offset_db=0.0, gain_sd_db=0.0)))
        if source == "temporal_decorrelation":
            return self if self.scene.temporal.is_none else self._variant(
                scene=self.scene.replaced(temporal=TemporalDecorrelation.none()))
        return self._variant(reference="scene")  # speckle

    def _variant(self, same_structure: bool = False, **changes) -> StackHVErrorModel:
        """The model with fields replaced. same_structure: only error levels or the Faraday-difference SD change,
        so the kernel's node terms (level-free, keyed by that SD) are shared."""
        memo = {"node terms": self._memo.setdefault("node terms", {})} if same_structure else {}
        return dataclasses.replace(self, montecarlo=None, gaussianity=None, notes=(), _memo=memo, **changes)

    # Contributions ---------------------------------------------------------------------------------
    def contributions(self) -> dict:
        """The error built up source by source, each step adding one (they add up to the total exactly):
        stable system distortions without Faraday rotation and noise, then the common Faraday rotation, the
        differences between the passes, unstable system errors, noise, and speckle (population reference)."""
        sysm = self.errors.system
        quiet = dataclasses.replace(self.errors, system=sysm.with_levels(noise_power=0.0))
        stable = dataclasses.replace(quiet, correlation=1.0)
        is_stable = self.errors.correlation == 1.0
        steps = [
            ("system_distortions", self._variant(errors=stable, faraday=StackFaraday(ConstantFaraday(0.0)),
                                                 reference="scene")),
            ("faraday_rotation", self._variant(errors=stable, reference="scene", same_structure=is_stable,
                                               faraday=dataclasses.replace(self.faraday, difference_sd=0.0))),
            ("faraday_difference", self._variant(errors=stable, reference="scene", same_structure=is_stable)),
            ("system_instability", self._variant(errors=quiet, reference="scene", same_structure=True)),
            ("noise", self._variant(reference="scene", same_structure=True) if self.reference == "population"
             else self),
        ]
        if self.reference == "population":
            steps.append(("speckle", self))
        out, prev_mean, prev_var = {}, 0.0, 0.0
        for name, model in steps:
            m = model.current()
            mean, var = float(m.mean), float(m.variance)
            out[name] = Contribution(mean - prev_mean, var - prev_var, CONTRIBUTION_DESCRIPTIONS[name])
            prev_mean, prev_var = mean, var
        return out

    # Monte Carlo -----------------------------------------------------------------------------------
    def relative_samples(self) -> np.ndarray | None:
        if self.montecarlo is None:
            return None
        return self.montecarlo.hv / self.montecarlo.reference["hv"]

    def samples(self) -> np.ndarray | None:
        return None if self.montecarlo is None else self.montecarlo.hv

    # Derived quantities ----------------------------------------------------------------------------
    def speckle_diversity(self) -> float:
        """Independent speckle samples of the estimate from the inter-pass coherence (eq. 17)."""
        return self.combination.speckle_diversity(self.scene.channel_matrix(1))

    def cancellation(self) -> dict:
        """How much ground the estimator leaves: ideal and with the case's errors (system errors and Faraday
        rotation of every pass), as fractions of the estimator's value and against the ground it would see
        without cancellation (tr Q sigma_g,hv) in dB."""
        if "cancellation" not in self._memo:
            ground = self.scene.ground_only()
            ideal = self.combination.value(ground.channel_matrix(1))
            quiet = dataclasses.replace(self.errors, system=self.errors.system.with_levels(noise_power=0.0))
            with_errors = stack_hv_moments(ground, quiet, self.faraday, self.combination, None, "scene")
            residual = float(with_errors.value + with_errors.bias_distortion)
            uncancelled = self.combination.noise_gain * float(np.real(self.scene.ground[1, 1]))
            self._memo["cancellation"] = {
                "ground_residual_fraction": residual / self.value,
                "ground_residual_ideal_fraction": ideal / self.value,
                "ground_suppression_db": 10 * math.log10(residual / uncancelled) if residual > 0 else float("-inf"),
                "ground_suppression_ideal_db": (10 * math.log10(ideal / uncancelled) if ideal > 0
                                                else float("-inf")),
            }
        return self._memo["cancellation"]

    # Output ----------------------------------------------------------------------------------------
    def scalars(self) -> dict:
        """``analytic.*``, ``montecarlo.*``, ``comparison.*`` as the HV model; ``estimator.*`` (the passes'
        combination), ``cancellation.*`` (ground left) and ``combined.*`` (the combined (hh, hv, vv) covariance
        a multi-channel estimator reads)."""
        out: dict = {}
        analytic = None
        if self.unavailable is None:
            analytic = self.current()
            for name, value in analytic.as_dict().items():
                out[f"analytic.{name}"] = float(value)
            out["analytic.sd"] = float(analytic.sd)
        mc = self.montecarlo
        if mc is not None:
            for name, value in sample_moments(mc.hv).items():
                out[f"montecarlo.{name}"] = value
            out["montecarlo.sd"] = math.sqrt(max(out["montecarlo.variance"], 0.0))
            for name, value in (self.gaussianity or {}).items():
                out[f"montecarlo.{name}"] = value
        if analytic is not None and mc is not None:
            fixed = self.reference == "scene"
            cmp = compare_with_analytic(float(analytic.mean), float(analytic.variance), mc.hv, mc.looks, fixed)
            if fixed and mc.looks:  # the one scene's sample covariance also moves the distortion bias, O(1/sqrt(L))
                extra = 2 * abs(float(analytic.bias_distortion)) / (abs(float(analytic.mean)) * math.sqrt(mc.looks))
                cmp["bias_rel_se"] = float(np.hypot(cmp["bias_rel_se"], extra))
            out.update({f"comparison.{name}": value for name, value in cmp.items()})
        comb = self.combination
        out["estimator.passes"] = float(self.scene.passes)
        out["estimator.combinations"] = float(comb.weights.shape[0])
        out["estimator.noise_gain"] = comb.noise_gain
        out["estimator.speckle_diversity"] = self.speckle_diversity()
        out["estimator.faraday_difference_sd_deg"] = math.degrees(self.faraday.difference_sd)
        out["estimator.system_error_correlation"] = float(self.errors.correlation)
        out.update({f"cancellation.{k}": v for k, v in self.cancellation().items()})
        combined = comb.combined_covariance(self.scene.blocks())
        for i, ch in enumerate(("hh", "hv", "vv")):
            out[f"combined.sigma_{ch}"] = float(np.real(combined[i, i]))
        out["combined.hhvv_magnitude"] = float(abs(combined[0, 2]))
        out["combined.hhvv_phase_deg"] = math.degrees(float(np.angle(combined[0, 2])))
        return out


__all__ = ["LEVELS", "StackHVErrorModel"]
