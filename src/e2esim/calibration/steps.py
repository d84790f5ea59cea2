"""The correction steps of a calibration strategy, vectorised over Monte Carlo realisations.

Each step reads a ``PipelineContext`` (the true system per realisation and the corrections so far),
estimates something from simulated calibration data, updates the corrections and returns diagnostics
(arrays, one value per realisation). Steps that estimate the raw system (calibrators) act inside the
corrections made so far (``apply_inner``); steps that estimate what the current corrected data show (Faraday
rotation, distributed targets, trihedrals) act outside (``apply_outer``). ``kind`` is one of
``pipeline.STEP_KINDS``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.faraday.chirp import ChirpSlopeEstimator, sample_subband_covariances
from e2esim.faraday.estimators import (
    AMBIGUITY_PERIOD, BickelBates, FreemanSecondMoment, resolve_ambiguity,
)
from e2esim.calibration.pipeline import PipelineContext
from e2esim.calibration.quegan1994 import quegan_calibrate
from e2esim.polarimetry.simulate import SystemState
from e2esim.calibration.targets import Calibrators, calibrator_responses
from e2esim.calibration.transponder import solve_transponder
from e2esim.polarimetry.system_model import faraday_matrix


@dataclass(frozen=True)
class FaradayStep:
    """Estimate Omega on the corrected scene and rotate it away (Quegan et al. 2018, eq. 4).

    method : "bickel_bates", "freeman" or "chirp_slope". looks : samples in the window.
    prior : "climatology" (the raw distribution's mean) or "tec_map" (truth + N(0, prior_sd_rad^2)),
        used to resolve the pi/2 ambiguity (the chirp slope has none). chirp : ChirpSlopeEstimator.
    noise_subtraction : Freeman only, subtract the known noise power.
    """

    method: str = "bickel_bates"
    looks: int = 10_000
    prior: str = "climatology"
    prior_sd_rad: float = 0.0
    chirp: ChirpSlopeEstimator | None = None
    noise_subtraction: bool = True
    kind = "faraday"

    def apply(self, ctx: PipelineContext) -> dict:
        omega_true = np.asarray(ctx.truth.omega)
        if self.method == "chirp_slope":
            covs, per_band = sample_subband_covariances(ctx.rng, ctx.scene, ctx.truth, ctx.noise_power, self.looks,
                                                        self.chirp)
            omega = self.chirp.from_subband_covariances(ctx.corrected(covs), per_band).omega0
        else:
            est = BickelBates() if self.method == "bickel_bates" else FreemanSecondMoment(
                ctx.noise_power if self.noise_subtraction else None)
            raw = est.from_covariance(ctx.corrected(ctx.window(self.looks)), self.looks).omega
            if self.prior == "climatology":
                prior = np.full(ctx.size, ctx.faraday.mean_rad)
            else:
                prior = omega_true + self.prior_sd_rad * ctx.rng.standard_normal(ctx.size)
            omega = resolve_ambiguity(raw, prior)
        rot = faraday_matrix(-omega)
        ctx.apply_outer(rot, rot)
        error = omega - omega_true
        return {"omega_error": error, "ambiguity_error": np.abs(np.round(error / AMBIGUITY_PERIOD)) > 0}


@dataclass(frozen=True)
class QueganStep:
    """Crosstalk and f1/f2 from a distributed-target window by Quegan (1994), corrected outside."""

    looks: int = 100_000
    iterations: int = 1
    subtract_noise: bool = True
    kind = "polarimetric"

    def apply(self, ctx: PipelineContext) -> dict:
        cov = ctx.corrected(ctx.window(self.looks))
        q = quegan_calibrate(cov, self.iterations, ctx.noise_power if self.subtract_noise else None)
        ctx.apply_outer(np.linalg.inv(q.receive), np.linalg.inv(q.transmit))
        return {"estimated_delta": q.delta, "estimated_alpha": q.alpha}


@dataclass(frozen=True)
class TrihedralStep:
    """Co-polarised imbalance k = f1 f2 (and optionally the absolute gain) from trihedrals in the scene.

    For a trihedral ``M = A R F(2 Omega) T``, so ``det M / (M_hh^2 + M_vh^2) = f1 f2`` and
    ``M_hh^2 + M_vh^2 = A^2`` at any Faraday rotation when the crosstalk is corrected (first order).
    Estimated over the reflectors as ratios of sums, then split equally between receive and transmit.
    """

    calibrators: Calibrators
    absolute_gain: bool = True
    kind = "polarimetric"

    def apply(self, ctx: PipelineContext) -> dict:
        m = calibrator_responses(ctx.rng, self.calibrators, ctx.truth)  # (n, K, 2, 2)
        m = ctx.p_receive[:, None] @ m @ ctx.p_transmit[:, None]
        a2 = m[..., 0, 0] ** 2 + m[..., 0, 1] ** 2
        k = np.sum(np.linalg.det(m), -1) / np.sum(a2, -1)
        half = np.sqrt(k)
        corr = np.zeros((ctx.size, 2, 2), complex)
        corr[:, 0, 0] = 1.0
        corr[:, 1, 1] = 1.0 / half
        ctx.apply_outer(corr, corr)
        out = {"copol_imbalance": k}
        if self.absolute_gain:
            gain = np.sqrt(np.mean(a2, -1))  # complex root; its sign is a common phase
            ctx.p_receive = ctx.p_receive / gain[:, None, None]
            out["gain"] = gain
        return out


@dataclass(frozen=True)
class TransponderStep:
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

    def apply(self, ctx: PipelineContext) -> dict:
        t = ctx.truth
        site = t.omega if self.site_faraday is None else self.site_faraday.sample(ctx.rng, ctx.size)
        state = SystemState(t.delta, t.f, site, t.gain)
        responses = calibrator_responses(ctx.rng, self.calibrators, state)
        prior = None
        if self.gauge == "faraday_prior":  # an independent Omega estimate at the site, SD prior_sd_rad
            prior = (site + self.prior_sd_rad * ctx.rng.standard_normal(ctx.size), self.prior_sd_rad)
        sol = solve_transponder(responses, self.calibrators, self.gauge, faraday_prior=prior)
        receive = sol.receive_matrix() if self.absolute_gain else sol.receive_matrix() / sol.gain[:, None, None]
        ctx.apply_inner(np.linalg.inv(receive), np.linalg.inv(sol.transmit_matrix()))
        if self.correct_faraday and self.site_faraday is None:
            rot = faraday_matrix(-sol.omega)
            ctx.apply_outer(rot, rot)
        return {"delta_error": sol.delta - t.delta, "f_error": sol.f - t.f,
                "gain_error_db": 20 * np.log10(np.abs(sol.gain / t.gain)), "site_omega_error": sol.omega - site,
                "chi2": sol.chi2}


@dataclass(frozen=True)
class GainStep:
    """Absolute gain set from an external estimate of the current |gain| with error ``N(offset_db, sd_db^2)``
    in |A|^2 (dB). The current gain is ``|A| sqrt|det P_r det P_t|`` (rotations have unit determinant), so a
    later gain step re-sets the scale rather than compounding it; the residual |A|^2 is ``-error`` in dB."""

    sd_db: float = 0.0
    offset_db: float = 0.0
    kind = "gain"

    def apply(self, ctx: PipelineContext) -> dict:
        err_db = self.offset_db + self.sd_db * ctx.rng.standard_normal(ctx.size)
        current = np.abs(ctx.truth.gain) * np.sqrt(np.abs(np.linalg.det(ctx.p_receive) * np.linalg.det(ctx.p_transmit)))
        ctx.p_receive = ctx.p_receive / (current * 10 ** (err_db / 20))[:, None, None]
        return {"gain_error_db": err_db}
