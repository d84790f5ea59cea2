"""What the error models of multi-pass estimates share: the case, its levels and sources, the variants with a
source removed, the steps of the contributions and the estimator's output scalars.

``StackHVErrorModel`` (HV) and ``StackJointErrorModel`` (HH, HV and VV together) are this plus their moments.
Levels: ``crosstalk`` and ``channel_imbalance`` (V_delta, V_epsilon), ``nesz`` (sigma_n) and
``faraday_difference`` (sigma_D^2, rad^2: the variance of the Faraday-rotation difference of two passes).
Sources ``without`` removes: the three level sources, ``faraday_rotation`` (the stack's common rotation),
``faraday_difference``, ``system_instability`` (the errors made identical on every pass), ``gain``,
``temporal_decorrelation`` (the scene without it: its value changes too) and, for the population reference,
``speckle``. Every evaluation at the model's own levels is kept with the model object (``functools.cached_property``);
the node terms of the levels searched are kept in the run's kernel memo (``node_terms``), found by value.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from e2esim.derived import RemovedOnce, derived_values, knowing
from e2esim.distortion.validation import compare_with_analytic, sample_moments
from e2esim.error_model import ModelEvaluation
from e2esim.faraday.distribution import ConstantFaraday
from e2esim.memo_keys import value_key
from e2esim.stack.analytic import NodeTermTable
from e2esim.stack.combination import PassCombination
from e2esim.stack.faraday import StackFaraday
from e2esim.stack.scene import StackScene
from e2esim.stack.system import StackSystemErrors
from e2esim.stack.temporal import TemporalDecorrelation

LEVELS = ("crosstalk", "channel_imbalance", "nesz", "faraday_difference")
NODE_TERM_TABLES_KEPT = 8
"""Structures whose node terms the kernel memo keeps (``StackModelBase.node_terms``): a case's variants have a few."""
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
class StackModelBase(RemovedOnce, ModelEvaluation):
    """The case of a multi-pass error model.

    scene : the ``StackScene``. errors : per-pass system errors. faraday : per-pass Faraday rotation.
    combination : the estimator (``PassCombination``). The keyword-only fields are ``ModelEvaluation``'s
    (``montecarlo``: a ``StackMonteCarloErrors`` of every channel) and ``kernel_memo``.
    """

    scene: StackScene
    errors: StackSystemErrors
    faraday: StackFaraday
    combination: PassCombination
    kernel_memo: Any = field(default=None, repr=False, compare=False, kw_only=True)
    """The run's ``KernelMemo`` (``case.services.memo``) or None: node terms found again by value across cases."""
    plain_transient = ("kernel_memo",)  # a cache: not stored with the model
    costly_levels = ("faraday_difference",)
    """Every Faraday-rotation difference needs the node terms computed anew (``ErrorModel.costly_levels``)."""
    levels_lead_sources = True
    """The level sources come first in ``sources`` and their removal shares the node terms (``node_terms``)."""

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

    @staticmethod
    def check_levels(unknown: dict) -> None:
        if unknown:
            raise TypeError(f"unknown levels {', '.join(unknown)}; this model has {', '.join(LEVELS)}")

    @cached_property
    def channel_values(self) -> tuple:
        """(tr Q Y_hh, tr Q Y_hv, tr Q Y_vv): the estimator's values, which the moments read at every evaluation of a
        root finding's step, derived once."""
        return tuple(self.combination.value(self.scene.channel_matrix(i)) for i in range(3))

    @cached_property
    def node_terms(self):
        """The kernel's node terms by difference SD (the moments' ``cache``): level-free, so kept in the run's kernel
        memo (``NodeTermTable``) under a key of this model's structure (the scene's blocks, the combination, the
        passes' correlation, error structure and gain spread, the common and residual rotations), which its variants
        that change a level or the difference SD share with it; a dict of its own without a memo."""
        memo = self.kernel_memo if hasattr(self.kernel_memo, "recall") else None  # decoded: an empty dict
        if memo is None:
            return {}
        e, f, n = self.errors, self.faraday, self.scene.passes
        try:
            structure = value_key(type(self).__name__, self.scene.blocks(), self.combination.matrix,
                                  e.pass_correlation(n), e.system.unit_structure, float(e.pass_gain_log_sd), f.common,
                                  f.residual, bool(getattr(memo, "repeated_geometry", False)))
        except TypeError:  # a part that has no value key (a plug-in's rotation): the model's own dict
            return {}
        return NodeTermTable.of(memo, structure, NODE_TERM_TABLES_KEPT)

    # Sources removed (``RemovedOnce.without``) -----------------------------------------------------
    def _without(self, source: str):
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
        return self._variant(reference="scene", same_structure=True)  # speckle

    def _variant(self, same_structure: bool = False, **changes):
        """The model with fields replaced (the node terms of its structure found again: ``node_terms``). It is handed
        what this model derived and it would derive the same: the estimator's values where the scene and combination
        stay, and where ``same_structure`` (a level, the difference SD or the reference changed: nothing the node
        terms' structure key reads) the table of node terms itself, the one ``node_terms`` would find by that key
        (a Shapley split's variants no longer key it anew, each)."""
        variant = dataclasses.replace(self, montecarlo=None, gaussianity=None, notes=(), **changes)
        derived = derived_values(self)
        kept = {}
        if "scene" not in changes and "combination" not in changes and "channel_values" in derived:
            kept["channel_values"] = derived["channel_values"]
        if same_structure and isinstance(derived.get("node_terms"), NodeTermTable):
            kept["node_terms"] = derived["node_terms"]
        return knowing(variant, **kept) if kept else variant

    def contribution_steps(self) -> list:
        """(name, model) in the order the contributions build the error up, each step adding one source: stable
        system distortions without Faraday rotation and noise, then the common Faraday rotation, the differences
        between the passes, unstable system errors, noise, and speckle (population reference)."""
        sysm = self.errors.system
        quiet = dataclasses.replace(self.errors, system=sysm.with_levels(noise_power=0.0))
        stable = dataclasses.replace(quiet, correlation=1.0)
        steps = [
            ("system_distortions", self._variant(errors=stable, faraday=StackFaraday(ConstantFaraday(0.0)),
                                                 reference="scene")),
            ("faraday_rotation", self._variant(errors=stable, reference="scene",
                                               faraday=dataclasses.replace(self.faraday, difference_sd=0.0))),
            ("faraday_difference", self._variant(errors=stable, reference="scene")),
            ("system_instability", self._variant(errors=quiet, reference="scene")),
            ("noise", self._variant(reference="scene", same_structure=True) if self.reference == "population"
             else self),
        ]
        if self.reference == "population":
            steps.append(("speckle", self))
        return steps

    # Derived quantities ----------------------------------------------------------------------------
    def speckle_diversity(self, channel: int = 1) -> float:
        """Independent speckle samples of the estimate of a channel (0 hh, 1 hv, 2 vv) from the inter-pass
        coherence (eq. 17)."""
        return self.combination.speckle_diversity(self.scene.channel_matrix(channel))

    def estimator_scalars(self) -> dict:
        """``estimator.*`` (the passes' combination) and ``combined.*`` (the combined (hh, hv, vv) covariance a
        multi-channel estimator reads)."""
        comb = self.combination
        return {"estimator.passes": float(self.scene.passes), "estimator.combinations": float(comb.weights.shape[0]),
               "estimator.noise_gain": comb.noise_gain, "estimator.speckle_diversity": self.speckle_diversity(),
               "estimator.faraday_difference_sd_deg": math.degrees(self.faraday.difference_sd),
               "estimator.system_error_correlation": float(self.errors.correlation)}

    def combined_scalars(self) -> dict:
        """``combined.*``: the combined (for ground cancellation the ground-cancelled) covariance of the passes."""
        combined = self.combination.combined_covariance(self.scene.blocks())
        out = {f"combined.sigma_{ch}": float(np.real(combined[i, i])) for i, ch in enumerate(("hh", "hv", "vv"))}
        out["combined.hhvv_magnitude"] = float(abs(combined[0, 2]))
        out["combined.hhvv_phase_deg"] = math.degrees(float(np.angle(combined[0, 2])))
        return out


def cancellation_scalars(value: float, ideal: float, residual: float, uncancelled: float) -> dict:
    """How much ground an estimator leaves (``cancellation.*``): the ground left without and with the case's
    errors (m^2/m^2) as fractions of the estimator's value ``value``, and against the ground it would see
    without cancellation, ``uncancelled`` = tr Q sigma_g, in dB."""
    return {
        "ground_residual_fraction": residual / value,
        "ground_residual_ideal_fraction": ideal / value,
        "ground_suppression_db": 10 * math.log10(residual / uncancelled) if residual > 0 else float("-inf"),
        "ground_suppression_ideal_db": 10 * math.log10(ideal / uncancelled) if ideal > 0 else float("-inf"),
    }


def channel_scalars(prefix: str, analytic: dict | None, samples: np.ndarray | None, looks: int | None,
                    fixed_scene: bool, gaussianity: dict | None = None) -> dict:
    """``<prefix>analytic.*`` (the parts of one channel's moments, ``analytic`` a dict with at least ``mean``,
    ``variance`` and ``bias_distortion``, or None), ``<prefix>montecarlo.*`` (sample moments of the simulated
    errors with standard errors, and the Gaussianity statistics) and ``<prefix>comparison.*`` (eq. 18 with
    standard errors; for one scene the scene's sample covariance also moves the distortion bias, O(1/sqrt(L)))."""
    out: dict = {}
    if analytic is not None:
        out.update({f"{prefix}analytic.{name}": float(value) for name, value in analytic.items()})
        out[f"{prefix}analytic.sd"] = math.sqrt(max(float(analytic["variance"]), 0.0))
    if samples is not None:
        out.update({f"{prefix}montecarlo.{name}": value for name, value in sample_moments(samples).items()})
        out[f"{prefix}montecarlo.sd"] = math.sqrt(max(out[f"{prefix}montecarlo.variance"], 0.0))
        out.update({f"{prefix}montecarlo.{name}": value for name, value in (gaussianity or {}).items()})
    if analytic is not None and samples is not None:
        mean, variance = float(analytic["mean"]), float(analytic["variance"])
        cmp = compare_with_analytic(mean, variance, samples, looks, fixed_scene)
        if fixed_scene and looks:
            extra = 2 * abs(float(analytic["bias_distortion"])) / (abs(mean) * math.sqrt(looks))
            cmp["bias_rel_se"] = float(np.hypot(cmp["bias_rel_se"], extra))
        out.update({f"{prefix}comparison.{name}": value for name, value in cmp.items()})
    return out
