"""The joint error model of the HH, HV and VV estimates of a multi-pass estimator (``StackJointErrorModel``).

What the ``stack_backscatter_error`` stage provides as ``backscatter.error`` with ``channels: all``: a
``MultiChannelErrorModel`` (``e2esim.error_model``) of a single-date, multi-date or ground-cancelled estimate,
its joint mean vector and covariance matrix from ``e2esim.stack.joint_moments`` at any level, with any source
removed (``e2esim.stack.model_base``), split into contributions; its joint Monte Carlo samples from
``StackMonteCarloErrors`` when simulated. As a single-channel ``ErrorModel`` it is HV, equal to
``StackHVErrorModel`` (tested to 1e-12), so the chain of Men et al. (2021) runs on it unchanged; issue 12's
multi-channel retrieval reads its joint moments (the ground-cancelled channels of the BIOMASS AGB ATBD).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from e2esim.derived import JointEvaluatedOnce
from e2esim.distortion.polarimetric_model import correlation_scalars
from e2esim.distortion.validation import sample_covariance_moments
from e2esim.distortion.validity import VALIDITY
from e2esim.error_model import JointContribution, JointMoments, MultiChannelErrorModel
from e2esim.polarimetry.system_model import RECIPROCAL_CHANNELS
from e2esim.stack.joint_moments import StackJointMoments, stack_joint_moments
from e2esim.stack.model_base import CONTRIBUTION_DESCRIPTIONS, StackModelBase, cancellation_scalars, channel_scalars

_HV_PARTS = {"bias_distortion": "bias_distortion", "bias_noise": "bias_noise", "bias_gain": "bias_gain",
             "var_distortion": "cov_distortion", "var_pass_gain": "cov_pass_gain",
             "var_faraday_spread": "cov_faraday_spread", "var_gain": "cov_gain", "var_finite_looks": "cov_finite_looks"}
"""The parts of ``StackHVMoments`` (HV output names) and where each channel's stands in ``StackJointMoments``."""


@dataclass(frozen=True, eq=False)
class StackJointErrorModel(StackModelBase, JointEvaluatedOnce, MultiChannelErrorModel):
    """Errors of (sigma_hh, sigma_hv, sigma_vv) of a multi-pass estimate (module docstring); fields as
    ``StackModelBase`` and ``correct_copol``: every pass's co-polarised channels are rotated back by its own
    Faraday rotation before the passes are combined (the processor's order), else not corrected."""

    correct_copol: bool = True

    channel = "hv"
    channels = RECIPROCAL_CHANNELS
    validity = VALIDITY["stack_joint"]

    @property
    def values(self) -> np.ndarray:
        return np.array([self.combination.value(self.scene.channel_matrix(i)) for i in range(3)])

    # Moments ---------------------------------------------------------------------------------------
    def _moments(self, crosstalk, channel_imbalance, nesz, faraday_difference, unknown, totals_only):
        self.check_levels(unknown)
        self.check_available()
        return stack_joint_moments(self.scene, self.errors, self.faraday, self.combination, self.looks,
                                   self.reference, self.correct_copol, crosstalk, channel_imbalance, nesz,
                                   faraday_difference, self.node_terms, totals_only, self.kernel_memo,
                                   values=self.channel_values)

    def joint_moments(self, crosstalk=None, channel_imbalance=None, nesz=None, faraday_difference=None,
                      **unknown) -> JointMoments:
        """Mean vector and covariance matrix with levels replaced where given (broadcast); ``current_joint`` has
        every part."""
        mean, cov = self._moments(crosstalk, channel_imbalance, nesz, faraday_difference, unknown, True)
        return JointMoments(self.channels, mean, cov)

    @cached_property
    def evaluated(self) -> StackJointMoments:
        """``current_joint()``, derived once."""
        return self._moments(None, None, None, None, {}, False)

    def joint_contributions(self) -> dict:
        """The errors built up source by source (``StackModelBase.contribution_steps``); they add up to the joint
        mean and covariance exactly."""
        out, prev_mean, prev_cov = {}, np.zeros(3), np.zeros((3, 3))
        for name, model in self.contribution_steps():
            m = model.current_joint()
            out[name] = JointContribution(m.mean - prev_mean, m.covariance - prev_cov, CONTRIBUTION_DESCRIPTIONS[name])
            prev_mean, prev_cov = m.mean, m.covariance
        return out

    # Monte Carlo -----------------------------------------------------------------------------------
    def joint_relative_samples(self) -> np.ndarray | None:
        if self.montecarlo is None:
            return None
        mc = self.montecarlo
        return np.stack([mc.errors[ch] / mc.reference[ch] for ch in self.channels], -1)

    def samples(self) -> np.ndarray | None:
        return None if self.montecarlo is None else self.montecarlo.hv

    # Derived quantities ----------------------------------------------------------------------------
    def speckle_correlation(self) -> np.ndarray:
        """3 x 3 correlation of the speckle of the three channels' estimates over the looks, from the inter-pass
        and inter-channel covariances of the stack: tr(Q Y^pq Q Y^qp) / sqrt(tr(Q Y^pp Q Y^pp) tr(Q Y^qq Q Y^qq))
        (the intensity correlation |rho_pq|^2 of the combined covariance for a single combination)."""
        q = self.combination.matrix
        blocks = self.scene.blocks()  # [n, m, p, q]
        qy = np.einsum("ab,bcpq->acpq", q, blocks)
        t = np.real(np.einsum("acpq,caqp->pq", qy, qy))
        d = np.sqrt(np.diag(t))
        return t / np.outer(d, d)

    def cancellation(self) -> dict:
        """Per channel, how much ground the estimator leaves: ideal and with the case's errors, as fractions of
        the estimator's value and against the ground it would see without cancellation (tr Q sigma_g,pp) in dB
        (``<ch>.<name>``; HV also without the prefix, as ``StackHVErrorModel``)."""
        return self.ground_left

    @cached_property
    def ground_left(self) -> dict:
        """``cancellation()``, derived once."""
        ground = self.scene.ground_only()
        quiet = dataclasses.replace(self.errors, system=self.errors.system.with_levels(noise_power=0.0))
        left = stack_joint_moments(ground, quiet, self.faraday, self.combination, None, "scene", self.correct_copol,
                                   mean_only=True)  # the means alone are read: no covariance computed
        residual = left.values + left.bias_distortion
        out = {}
        for i, ch in enumerate(self.channels):
            uncancelled = self.combination.noise_gain * float(np.real(self.scene.ground[i, i]))
            part = cancellation_scalars(float(self.values[i]), float(left.values[i]), float(residual[i]), uncancelled)
            out.update({f"{ch}.{k}": v for k, v in part.items()})
            if ch == self.channel:  # the HV names of StackHVErrorModel
                out.update(part)
        return out

    # Output ----------------------------------------------------------------------------------------
    def scalars(self) -> dict:
        """HV as ``StackHVErrorModel`` (``analytic.*``, ``montecarlo.*``, ``comparison.*``, the same values);
        per channel ``<ch>.analytic.*``, ``<ch>.montecarlo.*``, ``<ch>.comparison.*``; ``correlation.<p>_<q>.*``;
        ``estimator.*``, ``cancellation.<ch>.*`` and ``combined.*`` (docs/output-format.md)."""
        m = None if self.unavailable is not None else self.current_joint()
        mc = self.montecarlo
        looks = None if mc is None else mc.looks
        fixed = self.reference == "scene"
        out: dict = {}
        for i, ch in enumerate(self.channels):
            parts = None
            if m is not None:
                parts = {"mean": m.mean[i], "variance": m.covariance[i, i], "value": m.values[i]}
                parts.update({name: (getattr(m, key)[i] if key.startswith("bias") else getattr(m, key)[i, i])
                              for name, key in _HV_PARTS.items()})
                if ch == self.channel:
                    out.update(channel_scalars("", parts, None if mc is None else mc.errors[ch], looks, fixed,
                                               self.gaussianity))
                parts["relative_mean_percent"] = 100 * parts["mean"] / parts["value"]
                parts["relative_sd_percent"] = 100 * np.sqrt(max(parts["variance"], 0.0)) / parts["value"]
            out.update(channel_scalars(f"{ch}.", parts, None if mc is None else mc.errors[ch], looks, fixed))
        if m is not None:
            out.update(correlation_scalars(m.covariance, "analytic"))
        if mc is not None:
            out.update(correlation_scalars(sample_covariance_moments(
                np.stack([mc.errors[ch] for ch in self.channels], -1))["covariance"], "montecarlo"))
        out.update(self.estimator_scalars())
        out.update({f"cancellation.{k}": v for k, v in self.cancellation().items()})
        out.update(self.combined_scalars())
        return out


__all__ = ["StackJointErrorModel"]
