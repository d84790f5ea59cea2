"""Faraday-rotation estimators as registered modules (kind ``faraday_estimator``), each with its predicted SD.

The ``faraday_correction`` calibration step names one (``estimator: bickel_bates`` or
``estimator: {type: chirp_slope, subbands: 8}``); a plug-in registers another under the entry-point group
``e2esim.modules`` as ``faraday_estimator.<name>``. An estimator sees the calibration pipeline's context
(``e2esim.calibration.pipeline.PipelineContext``: the true system per realisation, the corrections so
far, the distributed target) and returns Omega_hat per realisation; ``predicted_sd`` is its theory (the
noise-only SD), reported beside the simulated error.
"""

from __future__ import annotations

from abc import abstractmethod
from typing import ClassVar

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.faraday.chirp import ChirpSlopeEstimator, chirp_omega0_sd, sample_subband_covariances
from e2esim.faraday.estimators import BickelBates, FreemanSecondMoment
from e2esim.faraday.theory import bickel_bates_snr, bickel_bates_variance, freeman_variance
from e2esim.module import Module
from e2esim.params import Param


class FaradayEstimatorModule(Module):
    """Base class of the Faraday-rotation estimators a calibration step can use.

    ambiguous : the estimate is known only modulo pi/2 (the step resolves it with a prior).
    needs_frequency : the estimator needs the instrument's centre frequency and bandwidth.
    """

    kind = "faraday_estimator"
    ambiguous: ClassVar[bool] = True
    needs_frequency: ClassVar[bool] = False

    def check_window(self, looks: int) -> None:
        """Raise ``PhysicsInputError`` if a window of ``looks`` samples cannot be used (override)."""

    @abstractmethod
    def estimate(self, ctx, looks: int, instrument) -> np.ndarray:
        """Omega_hat (rad) per realisation from a window of ``looks`` samples of the corrected data."""

    @abstractmethod
    def predicted_sd(self, scene, noise_power: float, faraday, looks: int, instrument) -> float:
        """Predicted SD (rad) of Omega_hat from noise and speckle alone, for a window of ``looks`` samples."""


class BickelBatesEstimator(FaradayEstimatorModule):
    """Bickel & Bates (1965) in the circular basis; variance Quegan et al. (2018), eqs. (5)-(6), with the
    gamma^2 correction of docs/errata.md, evaluated exactly from the L-look phase density."""

    type_name = "bickel_bates"
    summary = "Bickel-Bates estimate arg(<z_a z_b*>)/4 (Quegan et al. 2018, eqs. 4-6), ambiguous modulo pi/2"

    def estimate(self, ctx, looks, instrument):
        return BickelBates().from_covariance(ctx.corrected(ctx.window(looks)), looks).omega

    def predicted_sd(self, scene, noise_power, faraday, looks, instrument):
        return float(np.sqrt(bickel_bates_variance(bickel_bates_snr(scene, noise_power), looks)))


class FreemanEstimator(FaradayEstimatorModule):
    """Freeman's (2004) second-moment estimate; its variance by the delta method at the mean Faraday rotation
    (not valid near 0 or 45 deg)."""

    type_name = "freeman"
    summary = "Freeman second-moment estimate (Freeman 2004), ambiguous modulo pi/2"
    params = (Param("noise_subtraction", "bool", "subtract the known noise power", default=True),)

    def estimate(self, ctx, looks, instrument):
        est = FreemanSecondMoment(ctx.noise_power if self.si["noise_subtraction"] else None)
        return est.from_covariance(ctx.corrected(ctx.window(looks)), looks).omega

    def predicted_sd(self, scene, noise_power, faraday, looks, instrument):
        var = freeman_variance(scene, noise_power, faraday.mean_rad, looks, self.si["noise_subtraction"])
        return float(np.sqrt(var))


class ChirpSlopeEstimatorModule(FaradayEstimatorModule):
    """Omega0 from the slope of sub-band Bickel-Bates estimates across the chirp (Quegan et al. 2018, eq. 12):
    unambiguous, since the slope of Omega with 1/f^2 does not wrap."""

    type_name = "chirp_slope"
    summary = "Omega from the slope of sub-band Bickel-Bates estimates across the chirp (Quegan et al. 2018, eq. 12)"
    params = (Param("subbands", "int", "sub-bands of the chirp", default=4, minimum=2, maximum=1024),)
    ambiguous = False
    needs_frequency = True

    def check_window(self, looks):
        if looks < self.si["subbands"]:
            raise PhysicsInputError(f"looks = {looks} cannot be shared among subbands = {self.si['subbands']}; "
                                    "give at least one look per sub-band")

    def kernel(self, instrument) -> ChirpSlopeEstimator:
        return ChirpSlopeEstimator(instrument.centre_frequency_hz, instrument.bandwidth_hz, self.si["subbands"])

    def estimate(self, ctx, looks, instrument):
        chirp = self.kernel(instrument)
        covs, per_band = sample_subband_covariances(ctx.rng, ctx.scene, ctx.truth, ctx.noise_power, looks, chirp)
        return chirp.from_subband_covariances(ctx.corrected(covs), per_band).omega0

    def predicted_sd(self, scene, noise_power, faraday, looks, instrument):
        return float(chirp_omega0_sd(bickel_bates_snr(scene, noise_power), looks, self.kernel(instrument)))
