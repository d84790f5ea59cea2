"""Retrieval modules (kind ``retrieval``): from the sigma_hv error to the relative AGB error.

Three backscatter-AGB models: the power law of Men et al. (2021), eq. (15); the saturating model of
Ahmed et al. (2014), eq. (1); the multi-channel log-linear model of the BIOMASS level-2 prototype.
Each maps the case's relative sigma_hv error to a relative AGB error at the case's AGB, and combines
(``e2esim.retrieval.combine``) the systematic error of the propagation module with the random error
budget (``backscatter_error_budget``, when the scenario has one) and, optionally, the regression
uncertainty of the model's calibration (the ``regression`` section), each reported as a contribution.
Without a budget and without regression the power law gives exactly the results of the plain chain.
"""

from __future__ import annotations

import numpy as np

from e2esim import products as P
from e2esim.block import Batched
from e2esim.errors import ConfigError, PhysicsInputError
from e2esim.module import Stage, fail, fast_path
from e2esim.params import Ordered, Param, ParamGroup
from e2esim.retrieval import combine_block
from e2esim.retrieval.agb_error import AGBError, RelativeErrorMap
from e2esim.retrieval.combine import combined_agb_error, systematic_agb_error
from e2esim.retrieval.loglinear import LogLinearModel
from e2esim.retrieval.power_law import BIOME_EXPONENTS, PowerLaw
from e2esim.retrieval.regression_campaign import (
    REGRESSION_METHODS,
    REGRESSION_MODES,
    CalibrationCampaign,
    regression_contribution,
)
from e2esim.retrieval.saturating import ALPHA_DEFAULT, SaturatingModel

_REGRESSION = ParamGroup("regression", "uncertainty of the model's calibration on field plots (Ahmed et al. 2014, "
                         "eqs. 2-19), simulated from the model itself", (
    Param("mode", "str", "none; confidence: coefficient uncertainty (eq. 3); prediction: plus the error in "
          "equation (eq. 7)", default="none", choices=REGRESSION_MODES),
    Param("method", "str", "delta: naive fit and eq. (6); bootstrap: SIMEX and parametric bootstrap (eqs. 11-19)",
          default="delta", choices=REGRESSION_METHODS),
    Param("plots", "int", "number of calibration plots", default=40, minimum=5, maximum=100000),
    Param("agb_range_t_ha", "float", "AGB range of the calibration plots", default=(20.0, 400.0), unit="t/ha",
          length=2, minimum=0.0),
    Param("allometric_error_percent", "float", "field AGB error (1 sigma)", default=10.0, unit="%", minimum=0.0),
    Param("backscatter_error_percent", "float", "backscatter measurement error of the plots (1 sigma)", default=5.0,
          unit="%", minimum=0.0),
    Param("model_error_percent", "float", "error in equation: scatter of stands around the model (1 sigma)",
          default=10.0, unit="%", minimum=0.0),
    Param("bootstrap_samples", "int", "B for method bootstrap", default=200, minimum=10, maximum=100000),
    Param("simex_samples", "int", "S per lambda for method bootstrap", default=50, minimum=2, maximum=10000),
    Param("campaigns", "int", "simulated calibration campaigns the regression term is the mean over (its standard "
          "error falls as 1/sqrt(campaigns))", default=100, minimum=10, maximum=100000),
    Ordered("agb_range_t_ha"),
))

_AGB = Param("agb_t_ha", "float", "AGB the case's backscatter error is applied at (null: the scene's AGB)",
             default=None, unit="t/ha", exclusive_minimum=0.0, nullable=True)
_CAP = Param("agb_max_t_ha", "float", "largest AGB the model returns: estimates beyond it count as saturated",
             default=1000.0, unit="t/ha", exclusive_minimum=0.0)
_INVERTED_MODEL = (_AGB, _CAP, _REGRESSION)  # what a model inverted numerically takes besides its coefficients


class _Retrieval(Stage):
    """Shared parts: the case's AGB, the calibration campaign, the combination of the error sources."""

    kind = "retrieval"
    needs = ("scene.covariance", "backscatter.error")
    uses = ("backscatter.budget",)
    provides = (P.AGB_ERROR,)

    def setup(self):
        r = self.si["regression"]
        self.campaign = CalibrationCampaign(**{k: (tuple(v) if isinstance(v, (list, tuple)) else v)
                                               for k, v in r.items()})

    def case_agb(self, case) -> float:
        agb = self.si.get("agb_t_ha") or case["scene.covariance"].agb_t_ha
        if agb is None:
            raise fail(self, f"case {case.index}: the scene states no AGB and agb_t_ha is null",
                       "give agb_t_ha, or a scene with an AGB", key="agb_t_ha")
        return float(agb)

    def regression(self, case, model, agb, covariates=None):
        try:
            return regression_contribution(model, agb, self.campaign, case.settings.seed, covariates,
                                           getattr(case.services, "memo", None))
        except PhysicsInputError as exc:
            raise fail(self, f"case {case.index}: {exc}", key="regression") from exc

    def combine(self, case, exponent, mapping=None, regression=None, channel_weights=None, model_term=None):
        return {"agb.error": combined_agb_error(case, exponent, mapping, regression, channel_weights, model_term)}


class PowerLawRetrieval(_Retrieval):
    """AGB = A sigma_hv^p (Men et al. 2021, eq. 15); relative errors through eq. (16)."""

    type_name = "power_law"
    summary = "power law AGB = A sigma_hv^p (Men et al. 2021, eq. 15); p = 2.2 boreal, 1.9 tropical"
    params = (
        Param("exponent", "float", "power-law exponent p (null: from the scene's biome, 2.2 boreal, 1.9 tropical)",
              default=None, exclusive_minimum=0.0, maximum=10.0, nullable=True),
        _REGRESSION,
    )
    # a block's forward reads the scene's exponent and AGB alone, and adds no model term
    fast_path_hooks = ("case_exponent", "case_agb", "model_term")

    def exponent_for(self, scene) -> float:
        if self.si["exponent"] is not None:
            return self.si["exponent"]
        if scene.biome not in BIOME_EXPONENTS:
            raise ConfigError(
                self.location.child("exponent"),
                f"null needs a scene with a known biome, but the scene's biome is {scene.biome!r}",
                f"give a number, or a scene of biome {' or '.join(BIOME_EXPONENTS)}",
            )
        return BIOME_EXPONENTS[scene.biome]

    def case_exponent(self, case) -> float:
        """The exponent of a case (a subclass may read more of the case than the scene)."""
        return self.exponent_for(case["scene.covariance"])

    def model_term(self, case, exponent):
        """The model-error contribution of a case (``e2esim.retrieval.model_error``), or None: the plain power law
        of Men et al. (2021) does not propagate the uncertainty of its exponent (``stack_power_law`` does)."""
        return None

    forward_takes_blocks = True

    def forward(self, case):
        """The AGB error of a case; of a block of analytic cases at once (``_block_error``: an ``AGBError`` with the
        case axis, each case's bitwise the one it gets alone). A Monte Carlo, a regression term that draws from the
        case's generator and scenes the batched sums do not describe run case by case."""
        made = self._block_error(case) if fast_path(self) is not None else None
        if made is not None:
            return {"agb.error": case.product_of(made)}  # a case alone: the item of its block of one
        case.per_case("a Monte Carlo, a regression that draws, or scenes the batched sums do not describe")
        model = case["backscatter.error"]
        p = self.case_exponent(case)
        model_term = self.model_term(case, p)
        if "backscatter.budget" not in case and self.campaign.mode == "none" and model_term is None:
            return {"agb.error": systematic_agb_error(model, p)}
        regression = None
        if self.campaign.mode != "none":
            agb = self.case_agb(case)
            regression = self.regression(case, PowerLaw.through(agb, model.value, p), agb)
        return self.combine(case, p, None, regression, model_term=model_term)

    def _block_error(self, block) -> AGBError | None:
        """The ``AGBError`` of a block when the error is analytic for every case: the propagation's error alone, or
        combined with the error budget (``combine_block``) and a regression term that draws nothing from the case's
        generator (the same for every case of a scene); None (case by case) otherwise."""
        if block.settings.montecarlo:
            return None  # (a block's Monte Carlo cases have no batched error model: they are handed back first)
        model, scene = block.batched("backscatter.error"), block.factor("scene.covariance")
        budget = block.factor("backscatter.budget") if "backscatter.budget" in block else None
        if not isinstance(model, Batched) or model.unavailable is not None:
            return None
        try:  # the exponent of each scene, read once per run (named by what it depends on: the class and setting)
            p = scene.gather(self.exponent_for, name=f"power-law exponent, {type(self).__qualname__} "
                             f"{self.si['exponent']!r}")
        except ConfigError:
            return None  # case by case, where forward says which scene
        s = np.asarray(model.value, dtype=float)
        if budget is None and self.campaign.mode == "none":
            m = model.current()
            return AGBError(p, *(np.reshape(np.asarray(x, dtype=float), len(block)) for x in (s, m.mean, m.sd)),
                            error_model=model)
        if not s.ndim:
            return None  # a case alone with a budget or a regression: its own sums (forward)
        regression = None
        if self.campaign.mode != "none":
            agb = combine_block.gather_agb(self, scene)
            regression = None if agb is None else combine_block.stable_regression(
                self, block, s, agb, p, lambda a, sigma, exponent: PowerLaw.through(a, sigma, exponent))
            if regression is None:
                return None
        return combine_block.combined_agb_error_block(model, budget, p, regression)


class SaturatingRetrieval(_Retrieval):
    """The saturating model of Ahmed et al. (2014), eq. (1), inverted numerically with explicit saturation.

    The case's relative sigma_hv error is applied to the model's backscatter at the case's AGB; estimates
    beyond ``agb_max_t_ha`` (or beyond the model's peak) are saturated: set to the cap and counted.
    """

    type_name = "saturating"
    summary = "saturating model beta0 (1 - e^{-beta1 M}) + beta2 M^alpha e^{-beta1 M} (Ahmed et al. 2014, eq. 1)"
    params = (
        Param("beta0", "float", "saturation level", default=0.055, unit="m2/m2", exclusive_minimum=0.0, maximum=10.0),
        Param("beta1", "float", "saturation rate", default=0.015, unit="1/(t/ha)", exclusive_minimum=0.0, maximum=1.0),
        Param("beta2", "float", "low-AGB scale", default=0.008, unit="m2/m2"),
        Param("alpha", "float", "fixed exponent alpha (0.2 in the paper)", default=ALPHA_DEFAULT, exclusive_minimum=0.0,
              maximum=1.0),
        *_INVERTED_MODEL,
    )

    def setup(self):
        super().setup()
        c = self.si
        try:
            self.model = SaturatingModel(c["beta0"], c["beta1"], c["beta2"], c["alpha"])
            self.model.branch(c["agb_max_t_ha"])
        except PhysicsInputError as exc:
            raise ConfigError(self.location, str(exc)) from exc

    def forward(self, case):
        agb = self.case_agb(case)
        cap = self.si["agb_max_t_ha"]
        if agb >= cap:
            raise fail(self, f"case {case.index}: the case's AGB {agb:g} t/ha is not below the cap {cap:g} t/ha",
                       "raise agb_max_t_ha", key="agb_max_t_ha")
        mapping = RelativeErrorMap(self.model, agb, cap)
        regression = self.regression(case, self.model, agb) if self.campaign.mode != "none" else None
        return self.combine(case, mapping.local_exponent(), mapping, regression)


class LogLinearRetrieval(_Retrieval):
    """sigma0_pq = l_pq AGB^a_pq cos^n_pq(theta) for HH, HV, VV, inverted jointly (BIOMASS L2 prototype form).

    Defaults: l_pq and a_pq fitted (log-log least squares) to the three boreal forests of Men et al. (2021),
    Table I (P-band; residuals below 0.6 %), n_pq = 0 (Table I has no incidence dependence), residual SD
    0.1 in ln sigma with correlation 0.5 between channels (assumed).
    """

    type_name = "log_linear"
    summary = "multi-channel log-linear model l_pq AGB^a_pq cos^n_pq(theta), joint HH/HV/VV inversion"
    params = (
        Param("l_db", "float", "l_pq for (hh, hv, vv)", default=(-20.374, -21.113, -7.054), unit="dB", length=3,
              convert=False),
        Param("a", "float", "AGB exponents a_pq for (hh, hv, vv)", default=(0.8039, 0.4224, 0.0612), length=3),
        Param("n", "float", "cosine powers n_pq for (hh, hv, vv)", default=(0.0, 0.0, 0.0), length=3),
        Param("residual_sd", "float", "SD of the ln-sigma residuals of (hh, hv, vv) around the model",
              default=(0.1, 0.1, 0.1), length=3, exclusive_minimum=0.0),
        Param("residual_correlation", "float", "correlation of the residuals between channels", default=0.5,
              minimum=-0.49, maximum=0.99),
        Param("incidence_deg", "float", "local incidence angle theta", default=30.0, unit="deg", minimum=0.0,
              exclusive_maximum=90.0),
        *_INVERTED_MODEL,
    )

    def setup(self):
        super().setup()
        c = self.si
        sd = np.asarray(c["residual_sd"])
        corr = np.full((3, 3), c["residual_correlation"])
        np.fill_diagonal(corr, 1.0)
        try:
            self.model = LogLinearModel(tuple(np.log(10.0) / 10.0 * np.asarray(c["l_db"])), tuple(c["a"]),
                                        tuple(c["n"]), corr * np.outer(sd, sd))
            self.model.check_hv_weight()
        except PhysicsInputError as exc:
            raise ConfigError(self.location, str(exc)) from exc
        self.covariates = {"incidence_rad": c["incidence_rad"]}

    def forward(self, case):
        agb = self.case_agb(case)
        cap = self.si["agb_max_t_ha"]
        mapping = RelativeErrorMap(self.model, agb, cap, tuple(self.covariates.items()))
        regression = (self.regression(case, self.model, agb, self.covariates)
                      if self.campaign.mode != "none" else None)
        weights = self.model.channel_weights()
        return self.combine(case, float(weights[1]), mapping, regression, weights)
