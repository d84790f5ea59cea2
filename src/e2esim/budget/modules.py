"""Propagation module ``backscatter_error_budget``: the random error budget of the backscatter product.

It runs after ``hv_backscatter_error`` (list the two in the ``propagation`` section) and adds to the
case's ``BackscatterError`` the budget of Ahmed, Siqueira & Hensley (2014), eqs. (20)-(38), for the
scene's HH, HV and VV backscatter at the product's resolution: speckle and noise with the product's
number of looks, temporal variability, calibration and area projection. The retrieval module then
combines it with the systematic error of system distortions and Faraday rotation.

Every parameter left null takes the preset's value (``e2esim.budget.presets``: ``biomass_200m`` or
``uavsar_ahmed2014``); the NESZ and the bandwidth come from the chain's instrument when it states them
and the scenario does not.
"""

from __future__ import annotations

import numpy as np

from e2esim import products as P
from e2esim.budget.block import block_budgets
from e2esim.budget.geometry import slant_range_spherical
from e2esim.budget.presets import PRESETS
from e2esim.budget.result import COMBINATIONS, GROUPS, BudgetInputs, backscatter_budget
from e2esim.errors import ConfigError, PhysicsInputError
from e2esim.module import Stage, fail
from e2esim.params import AtMostOneOf, Param, ParamGroup

_CHANNELS = ("hh", "hv", "vv")
SPECKLE_DISTRIBUTIONS = ("gamma", "gaussian")


def _p(name, doc, unit="", **bounds):
    return Param(name, "float", doc + " (null: the preset's value)", default=None, unit=unit, nullable=True, **bounds)


def _p_db(name, doc, **bounds):
    """A dB value the formulas of Ahmed et al. (2014) take in dB (kept, not converted)."""
    return Param(name, "float", doc + " (null: the preset's value)", default=None, unit="dB", nullable=True,
                 convert=False, **bounds)


class BackscatterErrorBudget(Stage):
    """Random error of sigma0 at the product scale, Ahmed et al. (2014), eqs. (20)-(38)."""

    kind = "propagation"
    type_name = "backscatter_error_budget"
    summary = ("speckle/noise, temporal, calibration and area-projection error of sigma0 at the product scale "
               "(Ahmed et al. 2014, eqs. 20-38); runs after hv_backscatter_error")
    params = (
        Param("preset", "str", "instrument and observation preset for every value left null",
              default="biomass_200m", choices=tuple(PRESETS)),
        ParamGroup("instrument", "radar and processing (Ahmed et al. 2014, Table III)", (
            _p("bandwidth_mhz", "range bandwidth B, eq. (23) (null: the instrument's, else the preset's)", "MHz",
               exclusive_minimum=0.0),
            _p("antenna_length_m", "azimuth antenna length L_az, eq. (24)", "m", exclusive_minimum=0.0),
            _p("range_resolution_m", "slant-range resolution, instead of eq. (23)", "m", exclusive_minimum=0.0),
            _p("azimuth_resolution_m", "azimuth resolution, instead of eq. (24)", "m", exclusive_minimum=0.0),
            _p("window_eta_range", "range window pedestal eta (1 uniform, 0.08 Hamming, 0 Hann), eqs. (25), (29)",
               minimum=0.0, maximum=1.0),
            _p("window_eta_azimuth", "azimuth window pedestal eta", minimum=0.0, maximum=1.0),
            _p("range_broadening", "range broadening kappa, instead of eq. (25)", minimum=1.0),
            _p("azimuth_broadening", "azimuth broadening kappa, instead of eq. (25)", minimum=1.0),
            _p_db("islr_range_db", "range ISLR, instead of eq. (29)", maximum=0.0),
            _p_db("islr_azimuth_db", "azimuth ISLR, instead of eq. (29)", maximum=0.0),
            _p("nesz_db", "noise-equivalent sigma0, eq. (26) (null: the instrument's, else the preset's)", "dB",
               minimum=-100.0, maximum=20.0),
            _p("quantisation_bits", "bits b of the quantiser, eq. (28)", minimum=1.0, maximum=32.0),
            _p_db("ambiguity_ratio_db", "total signal-to-ambiguity ratio AMB_t, eq. (27)", minimum=0.0),
            _p_db("random_calibration_db", "residual random calibration error Delta sigma_dB (1 sigma), eq. (31)",
                  minimum=0.0, maximum=10.0),
            _p("pointing_error_mrad", "antenna pointing uncertainty Delta theta, eqs. (32)-(34)", "mrad", minimum=0.0),
            _p("elevation_beamwidth_deg", "elevation half-power beamwidth, eq. (33)", "deg", exclusive_minimum=0.0),
            _p("azimuth_beamwidth_deg", "azimuth half-power beamwidth, eq. (34)", "deg", exclusive_minimum=0.0),
            _p("beam_shaping_factor", "beam-shaping factor k (1/0.88 uniform aperture), eqs. (33)-(34)",
               exclusive_minimum=0.5),
        )),
        ParamGroup("dem", "digital elevation model for orthorectification and slope correction", (
            _p("height_error_m", "DEM height error Delta h_dem, eqs. (35), (38)", "m", minimum=0.0),
            _p("posting_m", "DEM posting L_dem (A_dem = L_dem^2), eqs. (30), (36), (38)", "m", exclusive_minimum=0.0),
            Param("cap_averaging_factor", "bool",
                  "limit sqrt(A_dem / (N A_pix)) of eqs. (30), (36) to 1 (it exceeds 1 for areas smaller than a DEM "
                  "cell; false reproduces the paper)", default=False),
        )),
        ParamGroup("observation", "the product and its acquisitions (Ahmed et al. 2014, Table IV)", (
            _p("area_m2", "ground area A_g averaged into one product value, eq. (22)", "m2", exclusive_minimum=0.0),
            _p("product_resolution_m", "side of a square product cell (sets area_m2 = side^2)", "m",
               exclusive_minimum=0.0),
            _p("incidence_deg", "local incidence angle theta_i", "deg", exclusive_minimum=0.0, exclusive_maximum=90.0),
            _p("slope_range_deg", "mean cross-track slope tau_rho, eq. (37)", "deg", minimum=-45.0, maximum=45.0),
            _p("slope_azimuth_deg", "mean azimuth slope tau_s, eq. (37)", "deg", minimum=-45.0, maximum=45.0),
            _p("slant_range_km", "range to the target rho, eq. (35) (null: preset, or from altitude_km)", "km",
               exclusive_minimum=0.0),
            _p("altitude_km", "platform altitude; gives the slant range on a spherical Earth when given", "km",
               exclusive_minimum=0.0),
            _p("observations", "N_ot: repeat observations averaged (speckle identical and diverse), eqs. (21), (30)",
               minimum=1.0),
            _p("speckle_diverse_observations", "N_os: speckle-diverse observations among them, eqs. (21), (36)",
               minimum=1.0),
            AtMostOneOf("area_m2", "product_resolution_m"),
        )),
        ParamGroup("temporal", "temporal variability of sigma0 unrelated to AGB (Section II-D-2)", (
            _p("sd_percent", "relative SD of sigma0 from weather, moisture, wind", "%", minimum=0.0),
            _p("sd_m2m2", "absolute SD of sigma0 (eq. 44: 0.002 for UAVSAR HV); used instead of sd_percent",
               "m2/m2", minimum=0.0),
        )),
        Param("combination", "str",
              "how the terms of eq. (20) and the calibration terms of eq. (30) combine: independent errors "
              "(variances add) or linear (SDs add, as printed; an upper bound)", default="independent",
              choices=COMBINATIONS),
        Param("include", "str", "terms of eq. (20) that enter the AGB error", default=tuple(GROUPS),
              variable_length=True, choices=tuple(GROUPS)),
        Param("speckle_distribution", "str",
              "Monte Carlo law of the speckle-and-noise term: gamma (multi-look intensity) or gaussian",
              default="gamma", choices=SPECKLE_DISTRIBUTIONS),
    )
    needs = ("scene.covariance",)
    uses = ("backscatter.error", "instrument")
    provides = (P.BACKSCATTER_BUDGET,)
    fast_path_hooks = ("_inputs_with", "_instrument_reads")  # forward reads the instrument through these

    def setup(self):
        self._made = {}  # the budgets made so far in the run, by scene and instrument (e2esim.budget.block)
        self.base = self._base_inputs()
        try:
            self.base.check()
        except PhysicsInputError as exc:
            raise ConfigError(self.location, str(exc)) from exc

    def _base_inputs(self) -> BudgetInputs:
        c = self.si
        values = dict(PRESETS[c["preset"]])
        ins, dem, obs, tmp = c["instrument"], c["dem"], c["observation"], c["temporal"]

        def put(key, value):
            if value is not None:
                values[key] = value

        put("bandwidth_hz", ins["bandwidth_hz"])
        put("antenna_length_m", ins["antenna_length_m"])
        put("range_resolution_m", ins["range_resolution_m"])
        put("azimuth_resolution_m", ins["azimuth_resolution_m"])
        put("eta_range", ins["window_eta_range"])
        put("eta_azimuth", ins["window_eta_azimuth"])
        put("range_broadening", ins["range_broadening"])
        put("azimuth_broadening", ins["azimuth_broadening"])
        put("islr_range_db", ins["islr_range_db"])
        put("islr_azimuth_db", ins["islr_azimuth_db"])
        put("nesz", ins["nesz_linear"])
        put("quantisation_bits", ins["quantisation_bits"])
        put("ambiguity_ratio_db", ins["ambiguity_ratio_db"])
        put("random_calibration_db", ins["random_calibration_db"])
        put("pointing_error_rad", ins["pointing_error_rad"])
        put("elevation_beamwidth_rad", ins["elevation_beamwidth_rad"])
        put("azimuth_beamwidth_rad", ins["azimuth_beamwidth_rad"])
        put("beam_shaping", ins["beam_shaping_factor"])
        put("dem_height_error_m", dem["height_error_m"])
        put("dem_posting_m", dem["posting_m"])
        put("area_m2", obs["area_m2"])
        if obs["product_resolution_m"] is not None:
            values["area_m2"] = obs["product_resolution_m"] ** 2
        put("incidence_rad", obs["incidence_rad"])
        put("slope_range_rad", obs["slope_range_rad"])
        put("slope_azimuth_rad", obs["slope_azimuth_rad"])
        if obs["slant_range_m"] is not None:
            values["slant_range_m"] = obs["slant_range_m"]
        elif obs["altitude_m"] is not None:
            values["slant_range_m"] = float(slant_range_spherical(obs["altitude_m"], values["incidence_rad"]))
        put("observations", obs["observations"])
        put("diverse_observations", obs["speckle_diverse_observations"])
        if tmp["sd_m2m2"] is not None:
            values["temporal_sd_m2m2"] = tmp["sd_m2m2"]
        elif tmp["sd_fraction"] is not None:
            values["temporal_sd_m2m2"] = None
            values["temporal_relative_sd"] = tmp["sd_fraction"]
        values["combination"] = c["combination"]
        values["cap_dem_factor"] = dem["cap_averaging_factor"]
        return BudgetInputs(**values)

    def inputs_for(self, case) -> BudgetInputs:
        """The budget inputs of a case: the instrument's NESZ and bandwidth unless the scenario gives them (what
        ``forward`` uses, through ``_inputs_with``; for the ``forward`` of a subclass)."""
        return self._inputs_with(case.get("instrument"))

    def _inputs_with(self, inst) -> BudgetInputs:
        """The budget inputs with the instrument ``inst`` (None: the scenario's and the preset's values)."""
        changes = self._instrument_reads(inst)
        return self.base.replace(**changes) if changes else self.base

    def _instrument_reads(self, inst) -> dict:
        """What the budget takes from the instrument ``inst``: its NESZ and bandwidth unless the scenario gives
        them (``_inputs_with``)."""
        changes = {}
        ins = self.si["instrument"]
        if inst is not None:
            if ins["nesz_linear"] is None and np.isfinite(inst.nesz_db):
                changes["nesz"] = 10 ** (inst.nesz_db / 10)
            if (ins["bandwidth_hz"] is None and ins["range_resolution_m"] is None and inst.bandwidth_hz
                    and np.isfinite(inst.bandwidth_hz)):
                changes["bandwidth_hz"] = inst.bandwidth_hz
        return changes

    def _reading(self, inst) -> tuple:
        """What the budget reads of ``inst``, hashable: instruments with the same reading share a budget."""
        return tuple(sorted(self._instrument_reads(inst).items()))

    forward_takes_blocks = True

    def forward(self, case):
        """The budget of a case's scene and instrument; of a block at once, made once per distinct pair of them in
        the run (``block_budgets``: a ``Factor``), a case alone being a block of one. A block whose error model
        already counts speckle, or with a budget that cannot be made, runs case by case, where this says why."""
        self.refuse_speckle_twice(case)
        instruments = case.factor("instrument") if "instrument" in case else None
        try:
            made = block_budgets(case.factor("scene.covariance"), instruments, self._made,
                                 lambda scene, inst: self.budget_of(scene, self._inputs_with(inst)), self._reading)
        except PhysicsInputError as exc:
            case.per_case("a budget cannot be made")
            raise fail(self, f"case {case.index}: {exc}") from exc
        return {"backscatter.budget": case.product_of(made)}

    def refuse_speckle_twice(self, case) -> None:
        if "backscatter.error" in case and "speckle_noise" in self.si["include"] and np.any(
                case.column("backscatter.error", "includes speckle", lambda model: model.includes_speckle)):
            case.per_case("speckle counted twice")
            raise fail(self, "speckle would be counted twice: the propagation's error model already draws a new "
                       "speckle pattern per realisation (hv_backscatter_error with reference 'population')",
                       "use reference: scene in hv_backscatter_error, or leave speckle_noise out of include",
                       key="include")

    def budget_of(self, scene, inputs: BudgetInputs):
        """The budget of ``scene``'s HH, HV and VV backscatter with ``inputs``."""
        sigma = np.array([scene.sigma_hh, scene.sigma_hv, scene.sigma_vv])
        return backscatter_budget(inputs, sigma).with_(channels=_CHANNELS, groups=tuple(self.si["include"]),
                                                       speckle_distribution=self.si["speckle_distribution"])
