"""The joint error model of sigma_hh, sigma_hv and sigma_vv (``MultiChannelErrorModel``).

``PolarimetricErrorModel`` is what the ``polarimetric_error`` stage provides as ``backscatter.error``: the
analytic mean vector and covariance matrix of the three channel errors (``polarimetric_moments``) at any
level, with any source removed, split into contributions; the simulated covariances when the Monte Carlo
ran (``covariance_montecarlo``). As a single-channel ``ErrorModel`` it is the HV channel, so the chain of Men
et al. (2021) runs on it unchanged. The level polynomial is computed once per model and shared by the
variants that only change a level.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from e2esim.derived import JointEvaluatedOnce, knowing
from e2esim.distortion.error_model import LEVELS, SystemLevels
from e2esim.distortion.faraday_correction import FaradayCorrection
from e2esim.distortion.polarimetric_moments import ChannelErrorMoments, error_polynomial, evaluate, evaluate_totals
from e2esim.distortion.validation import sample_covariance_moments
from e2esim.distortion.validity import VALIDITY
from e2esim.error_model import JointContribution, JointMoments, ModelEvaluation, MultiChannelErrorModel
from e2esim.faraday.distribution import ConstantFaraday, FaradayDistribution
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.polarimetry.system_model import RECIPROCAL_CHANNELS
from e2esim.scene.covariance import ScatteringCovariance

CONTRIBUTION_DESCRIPTIONS = {
    "system_distortions": "crosstalk, channel imbalance and gain errors without Faraday rotation",
    "faraday_rotation": "what the case's Faraday rotation (or what its correction leaves) adds to the system "
                        "distortions; for HH and VV also the rotation itself",
    "noise_bias": "thermal-noise bias (sigma_n in HH and VV, sigma_n/2 in HV) and its spread over the looks",
}
_LEVEL_ZERO = {"crosstalk": {"crosstalk": 0.0}, "channel_imbalance": {"imbalance": 0.0},
               "noise": {"noise_power": 0.0}}


@dataclass(frozen=True, eq=False)
class PolarimetricErrorModel(SystemLevels, JointEvaluatedOnce, ModelEvaluation, MultiChannelErrorModel):
    """Errors of (sigma_hh, sigma_hv, sigma_vv) for one scene, system-error model and Faraday rotation.

    scene, system, faraday : what the error is computed for (the residual system; the Faraday rotation in the
        data). correction : how the co-polarised channels treat the rotation. The keyword-only fields are
        ``ModelEvaluation``'s (looks and reference as in ``polarimetric_error_moments``; ``montecarlo`` is a
        ``CovarianceSamples``). kernel_memo : the process's ``KernelMemo`` (``case.services.memo``) or None:
        the level polynomial found again by value across cases and runs.
    """

    scene: ScatteringCovariance
    system: SystemErrorModel
    faraday: FaradayDistribution
    correction: FaradayCorrection = field(default_factory=FaradayCorrection)
    kernel_memo: Any = field(default=None, repr=False, compare=False, kw_only=True)
    plain_transient = ("kernel_memo",)  # a cache: not stored with the model

    channel = "hv"
    channels = RECIPROCAL_CHANNELS
    validity = VALIDITY["polarimetric"]

    @property
    def values(self) -> np.ndarray:
        return np.real(np.diag(self.scene.matrix))

    # Moments ---------------------------------------------------------------------------------------
    def polynomial(self):
        """The level polynomial of the moments (``ErrorPolynomial``), computed once (``level_polynomial``)."""
        return self.level_polynomial

    @cached_property
    def level_polynomial(self):
        """``polynomial()``, derived once; the variants that change a level only know it from their maker."""
        memo = self.kernel_memo if hasattr(self.kernel_memo, "recall") else None  # decoded: an empty dict
        return error_polynomial(self.scene, self.system, self.faraday, self.correction, memo)

    def joint_moments(self, crosstalk=None, channel_imbalance=None, nesz=None, **unknown) -> JointMoments:
        """Mean vector and covariance matrix, co-pol eqs. (5.1)-(5.4), with V_delta, V_eps and sigma_n replaced
        where given (broadcast); ``current_joint`` has every part."""
        mean, cov = evaluate_totals(self.polynomial(), *self._levels(crosstalk, channel_imbalance, nesz, unknown),
                                    self.system.gain_power_moments, self.looks, self.reference)
        return JointMoments(self.channels, mean, cov)

    @cached_property
    def evaluated(self) -> ChannelErrorMoments:
        """``current_joint()``: the moments at the model's own levels with their parts by source, derived once."""
        return evaluate(self.polynomial(), *self._levels(None, None, None, {}), self.system.gain_power_moments,
                        self.looks, self.reference)

    def _levels(self, crosstalk, channel_imbalance, nesz, unknown) -> tuple:
        if unknown:
            raise TypeError(f"unknown levels {', '.join(unknown)}; this model has {', '.join(LEVELS)}")
        self.check_available()
        s = self.system
        return (s.crosstalk_level if crosstalk is None else crosstalk,
                s.imbalance_level if channel_imbalance is None else channel_imbalance,
                s.noise_power if nesz is None else nesz)

    # Sources removed (``SystemLevels.without``) ----------------------------------------------------
    def _without(self, source: str) -> PolarimetricErrorModel:
        sysm = self.system
        if source == "faraday_rotation":
            return self if self._rotation_free() else self._no_faraday()
        if source == "gain":
            return self if not sysm.has_gain_error else self._variant(
                system=dataclasses.replace(sysm, gain_offset_db=0.0, gain_sd_db=0.0))
        variant = self._variant(system=sysm.with_levels(**_LEVEL_ZERO[source]))
        if "level_polynomial" in vars(self):  # the polynomial does not depend on the levels
            knowing(variant, level_polynomial=self.level_polynomial)
        return variant

    def _rotation_free(self) -> bool:
        fr = self.faraday
        no_rotation = fr.mean_rad == 0.0 and fr.sd_rad == 0.0
        residual = self.correction.residual
        return no_rotation and (residual is None or (residual.mean_rad == 0.0 and residual.sd_rad == 0.0))

    def _no_faraday(self) -> PolarimetricErrorModel:
        return self.no_faraday

    @cached_property
    def no_faraday(self) -> PolarimetricErrorModel:
        """The model without Faraday rotation (the contributions' reference), made once."""
        return self._variant(faraday=ConstantFaraday(0.0), correction=FaradayCorrection())

    def _variant(self, **changes) -> PolarimetricErrorModel:
        return dataclasses.replace(self, montecarlo=None, gaussianity=None, notes=(), **changes)

    # Contributions ---------------------------------------------------------------------------------
    def joint_contributions(self) -> dict:
        """System distortions (the same system without Faraday rotation), what the rotation adds (for HH and VV
        also the rotation itself, uncorrected or left by the correction) and the noise; they add up to the
        joint mean and covariance exactly."""
        m = self.current_joint()
        m0 = self._no_faraday().current_joint() if not self._rotation_free() else m
        sd_mean, sd_cov = m0.mean - m0.bias_noise, m0.covariance - m0.cov_finite_looks
        values = {
            "system_distortions": (sd_mean, sd_cov),
            "faraday_rotation": (m.mean - m.bias_noise - sd_mean, m.covariance - m.cov_finite_looks - sd_cov),
            "noise_bias": (m.bias_noise, m.cov_finite_looks),
        }
        return {name: JointContribution(np.asarray(mean), np.asarray(cov), CONTRIBUTION_DESCRIPTIONS[name])
                for name, (mean, cov) in values.items()}

    # Monte Carlo -----------------------------------------------------------------------------------
    def joint_relative_samples(self) -> np.ndarray | None:
        if self.montecarlo is None:
            return None
        return self.montecarlo.errors / np.real(np.diag(self.montecarlo.reference))

    def samples(self) -> np.ndarray | None:
        return None if self.montecarlo is None else self.montecarlo.errors[..., self.index(self.channel)]

    # Output ----------------------------------------------------------------------------------------
    def scalars(self) -> dict:
        """Per channel ``<ch>.analytic.*`` (parts of the moments, m^2/m^2; relative mean and SD),
        ``<ch>.montecarlo.*`` (sample moments with standard errors) and ``<ch>.comparison.*`` (z-scores);
        ``correlation.<p>_<q>.analytic`` / ``.montecarlo``; Gaussianity of the HV errors (docs/output-format.md)."""
        out: dict = {}
        sigma = self.values
        if self.unavailable is None:
            m = self.current_joint()
            for i, ch in enumerate(self.channels):
                for name in ("mean", "bias_faraday", "bias_crosstalk", "bias_imbalance", "bias_higher_order",
                             "bias_noise", "bias_gain"):
                    out[f"{ch}.analytic.{name}"] = float(getattr(m, name)[i])
                for name in ("crosstalk", "imbalance", "interaction", "faraday_spread", "finite_looks", "gain"):
                    out[f"{ch}.analytic.var_{name}"] = float(getattr(m, f"cov_{name}")[i, i])
                out[f"{ch}.analytic.variance"] = float(m.covariance[i, i])
                out[f"{ch}.analytic.sd"] = float(m.sd[i])
                out[f"{ch}.analytic.relative_mean_percent"] = 100 * float(m.mean[i]) / sigma[i]
                out[f"{ch}.analytic.relative_sd_percent"] = 100 * float(m.sd[i]) / sigma[i]
            out.update(correlation_scalars(m.covariance, "analytic"))
        mc = self.montecarlo
        if mc is not None:
            s = sample_covariance_moments(mc.errors)
            expected = self._conditional_on_simulated_scene() if self.unavailable is None else None
            for i, ch in enumerate(self.channels):
                out[f"{ch}.montecarlo.mean"] = float(s["mean"][i])
                out[f"{ch}.montecarlo.mean_se"] = float(s["mean_se"][i])
                out[f"{ch}.montecarlo.variance"] = float(s["covariance"][i, i])
                out[f"{ch}.montecarlo.variance_se"] = float(s["covariance_se"][i, i])
                out[f"{ch}.montecarlo.sd"] = math.sqrt(max(s["covariance"][i, i], 0.0))
                if expected is not None:
                    out[f"{ch}.comparison.mean_z"] = _z(s["mean"][i] - expected.mean[i], s["mean_se"][i])
                    out[f"{ch}.comparison.variance_z"] = _z(s["covariance"][i, i] - expected.covariance[i, i],
                                                            s["covariance_se"][i, i])
            out.update(correlation_scalars(s["covariance"], "montecarlo"))
            for name, value in (self.gaussianity or {}).items():
                out[f"hv.montecarlo.{name}"] = value
        return out

    def _conditional_on_simulated_scene(self) -> ChannelErrorMoments:
        """The analytic moments the Monte Carlo estimates: for the ``scene`` reference, given the simulated scene's
        own sample covariance (co-pol sec. 7: the rotation bias of HH and VV depends on it at O(1/sqrt(L)),
        which is far beyond the Monte Carlo's precision at the paper's sizes)."""
        if self.reference != "scene":
            return self.current_joint()
        scene = ScatteringCovariance(self.montecarlo.reference)
        return dataclasses.replace(self, scene=scene, montecarlo=None).current_joint()


def _z(difference, se) -> float:
    return float(difference / se) if se > 0 else 0.0


def correlation_scalars(cov, basis: str) -> dict:
    """``correlation.<p>_<q>.<basis>``: the correlation coefficients of the channel errors of a covariance matrix."""
    out = {}
    for p in range(3):
        for q in range(p + 1, 3):
            denom = math.sqrt(max(cov[p, p] * cov[q, q], 0.0))
            value = float(cov[p, q] / denom) if denom > 0 else 0.0
            out[f"correlation.{RECIPROCAL_CHANNELS[p]}_{RECIPROCAL_CHANNELS[q]}.{basis}"] = value
    return out
