"""The error model of a multi-pass HV estimate: single date, multi-date average or ground cancelled.

``StackHVErrorModel`` is what the ``stack_backscatter_error`` stage provides as ``backscatter.error``. It answers
the questions of ``e2esim.error_model.ErrorModel`` from the analytic moments of ``e2esim.stack.analytic`` (and
carries the exact Monte Carlo of ``e2esim.stack.montecarlo`` when simulated), so retrieval, verdicts, margins,
attribution and trade-off curves work on ground-cancelled data through the requirement code unchanged.

Levels, sources, variants and the steps of the contributions are those of ``e2esim.stack.model_base``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from e2esim.derived import EvaluatedOnce
from e2esim.distortion.validity import VALIDITY
from e2esim.error_model import Contribution, ErrorModel
from e2esim.stack.analytic import StackHVMoments, stack_hv_moments
from e2esim.stack.model_base import (
    CONTRIBUTION_DESCRIPTIONS,
    LEVELS,
    StackModelBase,
    cancellation_scalars,
    channel_scalars,
)


@dataclass(frozen=True, eq=False)
class StackHVErrorModel(StackModelBase, EvaluatedOnce, ErrorModel):
    """Error of a multi-pass HV estimate (module docstring); fields as ``StackModelBase``."""

    channel = "hv"
    validity = VALIDITY["stack_hv"]

    @property
    def value(self) -> float:
        return self.channel_values[1]

    # Moments ---------------------------------------------------------------------------------------
    def moments(self, crosstalk=None, channel_imbalance=None, nesz=None, faraday_difference=None,
                **unknown) -> StackHVMoments:
        self.check_levels(unknown)
        self.check_available()
        return stack_hv_moments(self.scene, self.errors, self.faraday, self.combination, self.looks, self.reference,
                                crosstalk, channel_imbalance, nesz, faraday_difference, self.node_terms,
                                self.kernel_memo, value=self.channel_values[1])

    # Contributions ---------------------------------------------------------------------------------
    def contributions(self) -> dict:
        """The error built up source by source (``StackModelBase.contribution_steps``), each step adding one; they
        add up to the total exactly."""
        steps = self.contribution_steps()
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
    def cancellation(self) -> dict:
        """How much ground the estimator leaves: ideal and with the case's errors (system errors and Faraday
        rotation of every pass), as fractions of the estimator's value and against the ground it would see
        without cancellation (tr Q sigma_g,hv) in dB."""
        return self.ground_left

    @cached_property
    def ground_left(self) -> dict:
        """``cancellation()``, derived once."""
        ground = self.scene.ground_only()
        ideal = self.combination.value(ground.channel_matrix(1))
        quiet = dataclasses.replace(self.errors, system=self.errors.system.with_levels(noise_power=0.0))
        with_errors = stack_hv_moments(ground, quiet, self.faraday, self.combination, None, "scene",
                                       mean_only=True)  # the mean alone is read: no variance computed
        residual = float(with_errors.value + with_errors.bias_distortion)
        uncancelled = self.combination.noise_gain * float(np.real(self.scene.ground[1, 1]))
        return cancellation_scalars(self.value, ideal, residual, uncancelled)

    # Output ----------------------------------------------------------------------------------------
    def scalars(self) -> dict:
        """``analytic.*``, ``montecarlo.*``, ``comparison.*`` as the HV model; ``estimator.*`` (the passes'
        combination), ``cancellation.*`` (ground left) and ``combined.*`` (the combined (hh, hv, vv) covariance
        a multi-channel estimator reads)."""
        analytic = None if self.unavailable is not None else self.current().as_dict()
        mc = self.montecarlo
        out = channel_scalars("", analytic, None if mc is None else mc.hv, None if mc is None else mc.looks,
                              self.reference == "scene", self.gaussianity)
        out.update(self.estimator_scalars())
        out.update({f"cancellation.{k}": v for k, v in self.cancellation().items()})
        out.update(self.combined_scalars())
        return out


__all__ = ["LEVELS", "StackHVErrorModel"]
