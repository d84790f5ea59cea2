"""Retrieval module (kind ``retrieval``) ``multichannel_power_law``: AGB from HH, HV and VV together, as the
BIOMASS level-2 processor estimates it (``e2esim.retrieval.multichannel``), or from one channel alone; with the
random-error budget of the case (``backscatter.budget``) when there is one (``e2esim.retrieval.multichannel``,
``budget_log_agb_error``), and the uncertainty of the exponents as the model term (``e2esim.retrieval.model_error``)
with the joint estimate's sensitivity to them (``e2esim.retrieval.exponent_sensitivity``)."""

from __future__ import annotations

import dataclasses

import numpy as np

from e2esim import products as P
from e2esim.error_model import Moments, MultiChannelErrorModel
from e2esim.errors import PhysicsInputError
from e2esim.module import Stage, fail
from e2esim.params import Param
from e2esim.retrieval import model_error
from e2esim.retrieval.agb_error import AGBError
from e2esim.retrieval.combine import (
    budget_contributions,
    channel_covariance,
    draw_random_errors,
    intensity_correlation,
    random_total_variance,
    systematic_contributions,
)
from e2esim.retrieval.exponent_sensitivity import exponent_sensitivity
from e2esim.retrieval.loglinear import LogLinearModel
from e2esim.retrieval.multichannel import (
    CHANNELS,
    PROTOTYPE_AGB_RANGE_T_HA,
    TABLE1_ALPHA,
    CombinedChannelsError,
    LogErrorMap,
    budget_log_agb_error,
)

ESTIMATORS = ("joint", "hh", "hv", "vv")


class MultiChannelRetrieval(Stage):
    """sigma0_pq = L_pq AGB^alpha_pq cos^n_pq(theta) per channel; AGB from all three channels by the equal-weight
    dB least squares of the BIOMASS AGB ATBD (``joint``) or from one channel's power law (``hh``, ``hv``, ``vv``).

    L_pq passes through the case's scene at its AGB (so the estimate is exact without errors). The AGB error:
    analytic from the joint moments of the channel errors (delta method, co-pol eq. 8.3), Monte Carlo by
    inverting every simulated (sigma_hh, sigma_hv, sigma_vv). Only the propagation's (systematic) error is
    carried, with the random-error budget (``backscatter.budget``) when the case has one: for one channel as the
    power-law chain combines it (``e2esim.retrieval.combine``), for the joint estimate in the log-AGB error
    (``budget_log_agb_error``). Regression uncertainty is not combined here.
    """

    kind = "retrieval"
    type_name = "multichannel_power_law"
    summary = ("per-channel power laws L_pq AGB^alpha_pq cos^n_pq(theta); AGB from HH+HV+VV by the equal-weight dB "
               "least squares of the BIOMASS AGB ATBD, or from one channel")
    params = (
        Param("estimator", "str", "joint: HH, HV and VV together (ATBD eqs. 4.26-4.37); hh, hv, vv: one channel's "
              "power law alone", default="joint", choices=ESTIMATORS),
        Param("alpha", "float", "AGB exponents alpha_pq for (hh, hv, vv) (null: the Table I fit of the scene's biome, "
              "e2esim.retrieval.multichannel.TABLE1_ALPHA)", default=None, length=3, exclusive_minimum=0.0,
              maximum=10.0, nullable=True),
        Param("n", "float", "cosine powers n_pq for (hh, hv, vv) (BIOMASS AGB ATBD constant-n default 1)",
              default=(1.0, 1.0, 1.0), length=3, minimum=0.0, maximum=10.0),
        Param("incidence_deg", "float", "local incidence angle theta", default=30.0, unit="deg", minimum=0.0,
              exclusive_maximum=90.0),
        Param("agb_max_t_ha", "float", "largest AGB the estimator returns (BIOMASS prototype bound)",
              default=PROTOTYPE_AGB_RANGE_T_HA[1], unit="t/ha", exclusive_minimum=0.0),
        model_error.model_uncertainty_group("stated", 3),
    )
    needs = ("scene.covariance", "backscatter.error")
    uses = ("backscatter.budget",)
    provides = (P.AGB_ERROR,)

    def alpha_for(self, scene) -> np.ndarray:
        if self.si["alpha"] is not None:
            return np.asarray(self.si["alpha"], dtype=float)
        if scene.biome not in TABLE1_ALPHA:
            raise fail(self, f"null needs a scene with a known biome, but the scene's biome is {scene.biome!r}",
                       f"give three exponents, or a scene of biome {' or '.join(TABLE1_ALPHA)}", key="alpha")
        return np.asarray(TABLE1_ALPHA[scene.biome])

    def case_alpha(self, case) -> np.ndarray:
        """The exponents of a case (a subclass may read more of the case than the scene)."""
        return self.alpha_for(case["scene.covariance"])

    def case_hh_spread(self, case) -> float | None:
        """The SD of a ground-cancelled HH exponent (the distance between its rules), None when the data are not
        ground cancelled (a subclass for multi-pass estimates says)."""
        return None

    def model_variance(self, case, alpha, weights, channels=CHANNELS) -> float | None:
        """Var m of the model term (``model_error``, eq. 7.2) for exponents ``alpha`` and weights ``weights`` of
        ``channels``; None when the mode is none."""
        si = dict(self.si["model_uncertainty"])
        if si["mode"] == "none":
            return None
        scene = case["scene.covariance"]
        idx = [CHANNELS.index(ch) for ch in channels]
        for key in ("exponent_sd_fraction", "coefficient_sd_fraction"):
            if si[key] is not None:
                si[key] = [si[key][i] for i in idx]
        try:
            term = model_error.case_model_variance(si, np.asarray(alpha)[idx], weights, scene.agb_t_ha, scene.biome,
                                                   channels, self.case_hh_spread(case))
        except KeyError:
            raise fail(self, f"case {case.index}: no reference AGB for the scene's biome {scene.biome!r}",
                       "give model_uncertainty.reference_agb_t_ha", key="model_uncertainty") from None
        return None if term is None else term[0]

    def model_for(self, scene, agb: float, alpha=None) -> LogLinearModel:
        """The per-channel power laws through the scene's powers at ``agb`` (identity residual covariance: the
        equal-weight cost); exponents ``alpha`` (None: ``alpha_for``)."""
        alpha = self.alpha_for(scene) if alpha is None else np.asarray(alpha, dtype=float)
        n = np.asarray(self.si["n"], dtype=float)
        ln_cos = np.log(np.cos(self.si["incidence_rad"]))
        sigma = np.real(np.diag(scene.matrix))
        ln_l = np.log(sigma) - alpha * np.log(agb) - n * ln_cos
        return LogLinearModel(tuple(ln_l), tuple(alpha), tuple(n))

    def forward(self, case):
        scene, model = case["scene.covariance"], case["backscatter.error"]
        if not isinstance(model, MultiChannelErrorModel):
            raise fail(self, f"needs the errors of all channels, but backscatter.error is a single-channel "
                       f"{type(model).__name__}",
                       "use propagation type polarimetric_error, or stack_backscatter_error with channels: all")
        agb = scene.agb_t_ha
        if agb is None or not agb > 0:
            raise fail(self, f"case {case.index}: the scene states no AGB", "use a scene that states its AGB")
        estimator = self.si["estimator"]
        forward_model = self.model_for(scene, agb, self.case_alpha(case))
        budget = case.get("backscatter.budget")
        if estimator != "joint":
            return {"agb.error": self._single_channel(case, model, forward_model, estimator, budget)}
        return {"agb.error": self._joint(case, model, forward_model, agb, budget)}

    def _single_channel(self, case, model, forward_model, channel, budget) -> AGBError:
        """One channel's power law: AGB_hat / AGB = (1 + x)^(1/alpha) (Men et al. 2021, eqs. 15-16), plus the
        channel's random-error budget as the power-law chain adds it (``e2esim.retrieval.combine``)."""
        view = model.channel_view(channel)
        exponent = 1.0 / forward_model.a[CHANNELS.index(channel)]
        m = view.current() if view.unavailable is None else None
        contributions = systematic_contributions(view)
        rel = view.relative_samples()
        mean = sd = None
        if m is not None:
            mean, sd = float(m.mean), float(m.sd)
        if budget is not None:
            random_ = budget_contributions(budget, channel=channel)
            contributions = contributions + random_
            if m is not None:
                sd = float(np.sqrt(sd**2 + view.value**2 * random_total_variance(budget, random_)))
            if rel is not None:
                rel = rel + draw_random_errors(case.rng, rel.shape, budget, random_)
        variance = self.model_variance(case, forward_model.a, [exponent], (channel,))
        if variance is not None:  # eqs. 7.1-7.2 with c = p: an equivalent sigma error; exact in the Monte Carlo
            term = model_error.sigma_contribution(variance, exponent)
            contributions = contributions + (term,)
            if m is not None:
                sd = float(np.sqrt(sd**2 + view.value**2 * term.relative_variance))
            if rel is not None:
                draws = model_error.draw_log_errors(case.rng, rel.shape, variance)
                rel = (1.0 + rel) * model_error.scale_factors(draws, 1.0 / exponent) - 1.0
        return AGBError.from_sigma_errors(exponent, view.value, mean, sd, rel, contributions=contributions,
                                          error_model=view)

    def speckle_correlation(self, case, model) -> np.ndarray:
        """The correlation of the channels' speckle over the looks: the error model's, else the intensity
        correlation |rho_pq|^2 of the case's scene."""
        own = model.speckle_correlation()
        return own if own is not None else intensity_correlation(case["scene.covariance"].matrix)

    def _joint(self, case, model, forward_model, agb, budget) -> AGBError:
        """HH, HV and VV by the ATBD's equal-weight cost: y = ln(AGB_hat / AGB) (co-pol eqs. 8.2-8.3), with the
        random-error budget when the case has one (``budget_log_agb_error``); the Monte Carlo inverts every
        simulated triple (``LogLinearModel.invert``, capped at ``agb_max_t_ha``)."""
        view = CombinedChannelsError(model, forward_model.channel_weights())
        m = view.current() if view.unavailable is None else None
        contributions = systematic_contributions(view)
        rel = model.joint_relative_samples()
        if budget is not None:
            try:
                combined = budget_log_agb_error(view, budget, self.speckle_correlation(case, model), contributions,
                                                case.rng, rel)
            except PhysicsInputError as exc:
                raise fail(self, f"case {case.index}: {exc}", "give the error budget combination: independent, or "
                           "use a single-channel estimator") from exc
            m, contributions, rel = combined
        weights = forward_model.channel_weights()
        variance = self.model_variance(case, forward_model.a, weights)
        sensitivity = ()
        if variance is not None:  # eqs. 7.1-7.2: y gains m, independent of the channel errors
            contributions = contributions + (model_error.log_contribution(variance),)
            if m is not None:
                sensitivity = self._sensitivity(case, model, forward_model, budget)
                m = Moments(m.mean, m.variance + variance)
            if rel is not None:  # exact: every channel's power scaled by e^(m alpha_p) before the inversion
                draws = model_error.draw_log_errors(case.rng, rel.shape[:-1], variance)
                rel = (1.0 + rel) * model_error.scale_factors(draws, forward_model.a) - 1.0
        y = None
        if rel is not None:
            try:
                q, _ = forward_model.relative_agb_error(agb, rel, self.si["agb_max_t_ha"], channel=None,
                                                        incidence_rad=self.si["incidence_rad"])
            except PhysicsInputError as exc:
                raise fail(self, str(exc)) from exc
            with np.errstate(divide="ignore"):
                y = np.log1p(q)  # log AGB error of the actual estimate (-inf where it is 0)
        agb_error = AGBError.from_sigma_errors(1.0, 1.0, None if m is None else float(m.mean),
                                               None if m is None else float(m.sd), y, LogErrorMap(), contributions,
                                               error_model=view)
        return dataclasses.replace(agb_error, sensitivity=sensitivity) if sensitivity else agb_error

    def _sensitivity(self, case, model, forward_model, budget) -> tuple:
        """The analytic RMSE with each exponent at the ends of its stated range (``exponent_sensitivity``)."""
        joint = model.current_joint()
        sigma = np.asarray(model.values, dtype=float)
        cov = np.asarray(joint.covariance) / np.outer(sigma, sigma)
        if budget is not None:
            gamma = self.speckle_correlation(case, model)
            cov = cov + sum(channel_covariance(budget, g, gamma) for g in budget.groups)
        alpha = np.asarray(forward_model.a, dtype=float)
        spread = model_error.stated_exponent_sd(alpha, CHANNELS, self.case_hh_spread(case))
        given = self.si["model_uncertainty"]["exponent_sd_fraction"]
        if given is not None:
            spread = np.asarray(given, dtype=float) * alpha
        return exponent_sensitivity(alpha, spread, np.asarray(joint.mean) / sigma, cov,
                                    lambda a, w: self.model_variance(case, a, w) or 0.0)
