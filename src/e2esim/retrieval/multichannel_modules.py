"""Retrieval module (kind ``retrieval``) ``multichannel_power_law``: AGB from HH, HV and VV together, as the
BIOMASS level-2 processor estimates it (``e2esim.retrieval.multichannel``), or from one channel alone."""

from __future__ import annotations

import numpy as np

from e2esim import products as P
from e2esim.error_model import MultiChannelErrorModel
from e2esim.errors import PhysicsInputError
from e2esim.module import Stage, fail
from e2esim.params import Param
from e2esim.retrieval.agb_error import AGBError
from e2esim.retrieval.combine import systematic_contributions
from e2esim.retrieval.loglinear import LogLinearModel
from e2esim.retrieval.multichannel import (
    CHANNELS,
    PROTOTYPE_AGB_RANGE_T_HA,
    TABLE1_ALPHA,
    CombinedChannelsError,
    LogErrorMap,
)

ESTIMATORS = ("joint", "hh", "hv", "vv")


class MultiChannelRetrieval(Stage):
    """sigma0_pq = L_pq AGB^alpha_pq cos^n_pq(theta) per channel; AGB from all three channels by the equal-weight
    dB least squares of the BIOMASS AGB ATBD (``joint``) or from one channel's power law (``hh``, ``hv``, ``vv``).

    L_pq passes through the case's scene at its AGB (so the estimate is exact without errors). The AGB error:
    analytic from the joint moments of the channel errors (delta method, co-pol eq. 8.3), Monte Carlo by
    inverting every simulated (sigma_hh, sigma_hv, sigma_vv). Only the propagation's (systematic) error is
    carried; a random-error budget or regression uncertainty is not combined here.
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
    )
    needs = ("scene.covariance", "backscatter.error")
    provides = (P.AGB_ERROR,)

    def alpha_for(self, scene) -> np.ndarray:
        if self.si["alpha"] is not None:
            return np.asarray(self.si["alpha"], dtype=float)
        if scene.biome not in TABLE1_ALPHA:
            raise fail(self, f"null needs a scene with a known biome, but the scene's biome is {scene.biome!r}",
                       f"give three exponents, or a scene of biome {' or '.join(TABLE1_ALPHA)}", key="alpha")
        return np.asarray(TABLE1_ALPHA[scene.biome])

    def model_for(self, scene, agb: float) -> LogLinearModel:
        """The per-channel power laws through the scene's powers at ``agb`` (identity residual covariance: the
        equal-weight cost)."""
        alpha, n = self.alpha_for(scene), np.asarray(self.si["n"], dtype=float)
        ln_cos = np.log(np.cos(self.si["incidence_rad"]))
        sigma = np.real(np.diag(scene.matrix))
        ln_l = np.log(sigma) - alpha * np.log(agb) - n * ln_cos
        return LogLinearModel(tuple(ln_l), tuple(alpha), tuple(n))

    def forward(self, case):
        scene, model = case["scene.covariance"], case["backscatter.error"]
        if not isinstance(model, MultiChannelErrorModel):
            raise fail(self, f"needs the errors of all channels, but backscatter.error is a single-channel "
                       f"{type(model).__name__}", "use propagation type polarimetric_error")
        agb = scene.agb_t_ha
        if agb is None or not agb > 0:
            raise fail(self, f"case {case.index}: the scene states no AGB", "use a scene that states its AGB")
        estimator = self.si["estimator"]
        forward_model = self.model_for(scene, agb)
        if estimator != "joint":
            return {"agb.error": self._single_channel(model, forward_model, estimator)}
        return {"agb.error": self._joint(model, forward_model, agb)}

    def _single_channel(self, model, forward_model, channel) -> AGBError:
        """One channel's power law: AGB_hat / AGB = (1 + x)^(1/alpha) (Men et al. 2021, eqs. 15-16)."""
        view = model.channel_view(channel)
        exponent = 1.0 / forward_model.a[CHANNELS.index(channel)]
        m = view.current() if view.unavailable is None else None
        return AGBError.from_sigma_errors(exponent, view.value, None if m is None else float(m.mean),
                                          None if m is None else float(m.sd), view.relative_samples(),
                                          contributions=systematic_contributions(view), error_model=view)

    def _joint(self, model, forward_model, agb) -> AGBError:
        """HH, HV and VV by the ATBD's equal-weight cost: y = ln(AGB_hat / AGB) (co-pol eqs. 8.2-8.3); the Monte
        Carlo inverts every simulated triple (``LogLinearModel.invert``, capped at ``agb_max_t_ha``)."""
        view = CombinedChannelsError(model, forward_model.channel_weights())
        m = view.current() if view.unavailable is None else None
        y = None
        rel = model.joint_relative_samples()
        if rel is not None:
            try:
                q, _ = forward_model.relative_agb_error(agb, rel, self.si["agb_max_t_ha"], channel=None,
                                                        incidence_rad=self.si["incidence_rad"])
            except PhysicsInputError as exc:
                raise fail(self, str(exc)) from exc
            with np.errstate(divide="ignore"):
                y = np.log1p(q)  # log AGB error of the actual estimate (-inf where it is 0)
        return AGBError.from_sigma_errors(1.0, 1.0, None if m is None else float(m.mean),
                                          None if m is None else float(m.sd), y, LogErrorMap(),
                                          systematic_contributions(view), error_model=view)
