"""Stages of the multi-pass chain: the forest seen by a stack (kind ``scene``), the error of a multi-pass HV
estimate (kind ``propagation``) and the random-error budget with the effective looks of the stack."""

from __future__ import annotations

import math

import numpy as np

from e2esim import products as P
from e2esim.budget.geometry import slant_range_spherical
from e2esim.budget.modules import BackscatterErrorBudget
from e2esim.budget.result import backscatter_budget
from e2esim.calibration.modules import rotation_only_setting
from e2esim.distortion.faraday_correction import HV_UNCHANGED_BY_ROTATION
from e2esim.distortion.modules import analytic_use
from e2esim.distortion.montecarlo import gaussianity
from e2esim.distortion.validity import VALIDITY
from e2esim.error_terms.wrapped import innermost
from e2esim.errors import PhysicsInputError
from e2esim.ionosphere.variability import DEFAULT_TEC_VARIABILITY
from e2esim.memo_keys import value_key
from e2esim.module import Stage, fail
from e2esim.params import AtMostOneOf, Param, ParamGroup
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.table1 import TABLE1_FORESTS
from e2esim.stack import combination as combos
from e2esim.stack.acquisitions import (
    DAY_S,
    PHASES,
    AcquisitionStack,
    preset_stack,
    radar_wavelength,
    vertical_wavenumber,
)
from e2esim.stack.analytic import REFERENCES
from e2esim.stack.error_model import StackHVErrorModel
from e2esim.stack.faraday import StackFaraday, residual_moments, tec_difference_sd
from e2esim.stack.joint_model import StackJointErrorModel
from e2esim.stack.model_base import StackModelBase
from e2esim.stack.montecarlo import NOISE_FACTORS, simulate_stack
from e2esim.stack.rvog import ForestStructure
from e2esim.stack.scene import StackScene
from e2esim.stack.sites import SITE_FORESTS, SITES
from e2esim.stack.system import StackSystemErrors
from e2esim.stack.temporal import ASSUMED_FLOOR, ASSUMED_GROUND_RATIO, ASSUMED_TIME_CONSTANT_DAYS, TemporalDecorrelation

BIOMASS_CENTRE_FREQUENCY_HZ = 435e6  # Quegan et al. (2018), Section 5
BIOMASS_ALTITUDE_M = 666e3  # CEOS EO Handbook, BIOMASS mission summary: 666 km
BIOMASS_MID_INCIDENCE_DEG = 0.5 * (23.0 + 33.75)  # Quegan et al. (2018), Section 4.2: 23 deg near to 33.75 deg far

_TEMPORAL = ParamGroup("temporal", "temporal decorrelation gamma_v(dt) = floor + (1 - floor) exp(-dt / tau), "
                       "gamma_g = 1 - ground_ratio (1 - gamma_v) (ground-cancellation.md eq. 3; values assumed)", (
    Param("floor", "float", "long-term volume coherence gamma_inf (assumed)", default=ASSUMED_FLOOR, minimum=0.0,
          maximum=1.0),
    Param("time_constant_days", "float", "decay time tau (assumed)", default=ASSUMED_TIME_CONSTANT_DAYS, unit="day",
          exclusive_minimum=0.0),
    Param("ground_ratio", "float", "ground decorrelation as a fraction of the volume's (0: none, 1: the same; BIOMASS "
          "processor's range)", default=ASSUMED_GROUND_RATIO, minimum=0.0, maximum=1.0),
))


class RVoGStackScene(Stage):
    """A forest over ground seen by an interferometric or tomographic stack: the single-pass covariance of Men et
    al. (2021), Table I, and the 3N x 3N multi-pass covariance of the random-volume-over-ground model with
    temporal decorrelation (ground-cancellation.md, eqs. 1-4)."""

    kind = "scene"
    type_name = "rvog_stack"
    summary = "multi-pass forest covariance: Table I powers, random volume over ground, k_z and temporal decorrelation"
    params = (
        Param("site", "str", "forest-structure preset (e2esim.stack.sites)", default="boreal", choices=tuple(SITES)),
        Param("forest", "str", "Table I forest of the single-pass powers (null: the site's)", default=None,
              choices=tuple(TABLE1_FORESTS), nullable=True),
        Param("height_m", "float", "volume height h_v (null: the site's)", default=None, unit="m",
              exclusive_minimum=0.0, maximum=100.0, nullable=True),
        Param("extinction_db_m", "float", "power extinction per metre of slant path (null: the site's)", default=None,
              unit="dB/m", minimum=0.0, maximum=5.0, nullable=True),
        Param("ground_to_volume_db", "float", "effective ground-to-volume ratio of (hh, hv, vv) (null: the site's)",
              default=None, unit="dB", length=3, minimum=-60.0, maximum=40.0, nullable=True, convert=False),
        Param("volume_hhvv_coherence", "float", "HH-VV coherence of the volume (null: the site's, 1/3)", default=None,
              minimum=0.0, maximum=1.0, nullable=True),
        Param("phase", "str", "stack preset: interferometric (3 passes) or tomographic (7 passes), 3 days apart",
              default="interferometric", choices=tuple(PHASES)),
        Param("repeat_days", "float", "days between passes (null: the phase's, 3)", default=None, unit="day",
              exclusive_minimum=0.0, nullable=True),
        Param("kz_rad_m", "float", "vertical wavenumber of every pass relative to the first (null: the phase's "
              "assumed preset, or from the baselines)", default=None, unit="rad/m", variable_length=True,
              nullable=True),
        Param("perpendicular_baselines_m", "float", "perpendicular baseline of every pass relative to the first; "
              "k_z = 4 pi B / (lambda rho sin theta)", default=None, unit="m", variable_length=True, nullable=True),
        Param("incidence_deg", "float", "incidence of the passes (null: the mean of the orbit's acquisitions, else "
              "BIOMASS mid swath 28.4 deg)", default=None, unit="deg", exclusive_minimum=0.0,
              exclusive_maximum=90.0, nullable=True),
        Param("slant_range_km", "float", "slant range for k_z from baselines (null: the orbit's, else 666 km "
              "altitude at the incidence)", default=None, unit="km", exclusive_minimum=0.0, nullable=True),
        _TEMPORAL,
        AtMostOneOf("kz_rad_m", "perpendicular_baselines_m"),
    )
    uses = ("geometry", "instrument")
    provides = (P.SCENE, P.STACK_SCENE)

    def setup(self):
        c = self.si
        site = SITES[c["site"]]
        self.forest = ForestStructure(
            c["height_m"] if c["height_m"] is not None else site.height_m,
            c["extinction_db_m"] if c["extinction_db_m"] is not None else site.extinction_db_m,
            tuple(c["ground_to_volume_db"]) if c["ground_to_volume_db"] is not None else site.ground_to_volume_db,
            c["volume_hhvv_coherence"] if c["volume_hhvv_coherence"] is not None else site.volume_hhvv_coherence,
            site.label)
        name = c["forest"] or SITE_FORESTS[c["site"]]
        biome, agb, hh, hv, vv, r, theta = TABLE1_FORESTS[name]
        self.covariance = ScatteringCovariance.from_powers(
            hh, hv, vv, r, np.radians(theta), agb_t_ha=agb, biome=biome,
            label=f"{biome} {agb:g} t/ha (Men et al. 2021, Table I)")
        t = c["temporal"]
        self.temporal = TemporalDecorrelation(t["floor"], t["time_constant_days"] * DAY_S, t["ground_ratio"])
        for key in ("kz_rad_m", "perpendicular_baselines_m"):
            if c[key] is not None and len(c[key]) != PHASES[c["phase"]][0]:
                raise PhysicsInputError(f"{key} has {len(c[key])} values but the {c['phase']} phase has "
                                        f"{PHASES[c['phase']][0]} passes")

    def _geometry(self, case) -> tuple[float, float]:
        """(incidence (rad), slant range (m)) of the case."""
        c = self.si
        geometry = case.get("geometry")
        incidence = c["incidence_rad"]
        if incidence is None:
            incidence = (float(np.mean(geometry.incidence)) if geometry is not None
                         else math.radians(BIOMASS_MID_INCIDENCE_DEG))
        slant = c["slant_range_m"]
        if slant is None:
            slant = (float(np.mean(np.linalg.norm(geometry.satellite_ecef - geometry.target_ecef, axis=-1)))
                     if geometry is not None else float(slant_range_spherical(BIOMASS_ALTITUDE_M, incidence)))
        return incidence, slant

    def stack(self, case) -> AcquisitionStack:
        c = self.si
        incidence, slant = self._geometry(case)
        preset = preset_stack(c["phase"], incidence, c["repeat_days"])
        kz = preset.kz_rad_m
        if c["kz_rad_m"] is not None:
            kz = np.asarray(c["kz_rad_m"], float)
        elif c["perpendicular_baselines_m"] is not None:
            inst = case.get("instrument")
            frequency = inst.centre_frequency_hz if inst is not None else BIOMASS_CENTRE_FREQUENCY_HZ
            kz = vertical_wavenumber(c["perpendicular_baselines_m"], radar_wavelength(frequency), slant, incidence)
        return AcquisitionStack(preset.time_s, kz, preset.incidence_rad, preset.label)

    def forward(self, case):
        stack = self.stack(case)
        parts = (stack, self.covariance, self.forest, self.temporal)

        def scene() -> StackScene:
            try:
                return StackScene(*parts)
            except PhysicsInputError as exc:
                raise fail(self, str(exc)) from exc

        # the cases of one geometry share their scene: kept in the kernel memo, by the values it is made of
        key = ("stack scene", value_key(*parts))
        return {"scene.covariance": self.covariance, "scene.stack": case.services.memo.recall(key, scene, keep=16)}


CHANNELS = ("hv", "all")
RESIDUAL_ANALYTIC_MAX_SD_RAD = math.radians(3.0)
"""Beyond this SD of the residual rotation of the co-polarised correction, the analytic cubature misses more than
3 % of the residual's own spread (and 5e-5 of the bias it adds; ground-cancellation.md, Section 3.3)."""


class StackBackscatterError(Stage):
    """Error of a multi-pass estimate: single date, multi-date average without cancellation, or ground
    cancelled as the BIOMASS processor does; per-pass system errors, Faraday rotation and noise, analytic and
    Monte Carlo (ground-cancellation.md). ``channels: hv`` provides the HV error model (``StackHVErrorModel``),
    ``all`` the joint model of HH, HV and VV (``StackJointErrorModel``, the same HV) for a multi-channel
    retrieval."""

    kind = "propagation"
    type_name = "stack_backscatter_error"
    summary = ("sigma_hv (or sigma_hh, sigma_hv, sigma_vv jointly) error of single-date, multi-date or ground-"
               "cancelled estimates of a stack: per-pass system errors, Faraday rotation, temporal decorrelation, "
               "noise")
    params = (
        Param("estimator", "str", "single_date, multi_date (average without cancellation) or ground_cancelled",
              default="ground_cancelled", choices=combos.ESTIMATORS),
        Param("date", "int", "single_date: which pass (1 the first)", default=1, minimum=1),
        Param("cancellation", "str", "ground_cancelled: interpolated (BPS multi-reference at k_z0 = pi / z0) or "
              "subtraction of two passes", default="interpolated", choices=combos.CANCELLATIONS),
        Param("pair", "int", "subtraction: the two passes (1 the first)", default=(1, 2), length=2, minimum=1),
        Param("emphasised_height_m", "float", "interpolated: z0 (BPS default 30 m)",
              default=combos.BPS_EMPHASISED_HEIGHT_M, unit="m", exclusive_minimum=0.0),
        Param("system_error_correlation", "float", "correlation of each pass's system errors with the others' "
              "(1: stable, 0: independent)", default=1.0, minimum=0.0, maximum=1.0),
        Param("faraday_difference_sd_deg", "float", "SD of the Faraday-rotation difference of two passes (null: "
              "from the day-to-day TEC variability, eq. 7)", default=None, unit="deg", minimum=0.0, maximum=90.0,
              nullable=True),
        Param("tec_variability", "float", "coefficient of variation of TEC from day to day (null: the climatology's, "
              "else 0.25)", default=None, minimum=0.0, maximum=2.0, nullable=True),
        Param("tec_correlation", "float", "correlation of the day-to-day TEC deviations of two passes (assumed 0)",
              default=0.0, minimum=-1.0, maximum=1.0),
        Param("reference", "str", "'scene': one scene, error against its own value (speckle in a budget); "
              "'population': a new scene per realisation (speckle included)", default="scene", choices=REFERENCES),
        Param("channels", "str", "hv: the HV error model; all: HH, HV and VV jointly (their covariance, for "
              "multichannel retrieval; HV the same)", default="hv", choices=CHANNELS),
        Param("correct_copol_faraday", "bool", "correct each pass's co-polarised channels for its own Faraday rotation "
              "before the passes are combined, as the processor does at level 1 (Monte Carlo, and the analytic moments "
              "of channels: all; HV is unchanged by it), by the calibration's faraday_correction estimate when "
              "there is one, else by the true rotation", default=True),
        Param("gaussianity", "bool", "test the simulated HV errors for Gaussianity", default=True),
    )
    needs = ("scene.stack", "system.residual", "faraday.residual")
    uses = ("calibration",)
    provides = (P.BACKSCATTER_ERROR,)

    def combination(self, scene: StackScene):
        c = self.si
        n = scene.passes
        try:
            if c["estimator"] == "single_date":
                return combos.single_date(n, c["date"] - 1)
            if c["estimator"] == "multi_date":
                return combos.multi_date(n)
            if c["cancellation"] == "subtraction":
                return combos.subtraction(n, c["pair"][0] - 1, c["pair"][1] - 1)
            return combos.interpolated(scene.acquisitions.kz_rad_m, c["emphasised_height_m"])
        except PhysicsInputError as exc:
            key = {"single_date": "date"}.get(c["estimator"], "pair" if c["cancellation"] == "subtraction"
                                              else "emphasised_height_m")
            raise fail(self, str(exc), key=key) from exc

    def difference_sd(self, faraday) -> float:
        """sigma_D (rad): given, or eq. (7) from the TEC variability."""
        c = self.si
        if c["faraday_difference_sd_rad"] is not None:
            return c["faraday_difference_sd_rad"]
        cv = c["tec_variability"]
        if cv is None:
            cv = getattr(faraday, "variability", DEFAULT_TEC_VARIABILITY) or DEFAULT_TEC_VARIABILITY
        rms = math.hypot(faraday.mean_rad, faraday.sd_rad)
        return tec_difference_sd(rms, cv, c["tec_correlation"])

    def copol_residual(self, case) -> tuple:
        """(dW distribution or None, notes): what is left of each pass's Faraday rotation in the co-polarised
        channels after their correction. Only the joint model reads it (the symmetrised HV is unchanged by any
        rotation): the residual of the calibration section's Faraday-rotation estimate, while no polarimetric step
        has folded the rotation into the residual crosstalk; None (the true rotation) without such a step."""
        if self.si["channels"] != "all" or not self.si["correct_copol_faraday"]:
            return None, ()
        record = case.get("calibration")
        if record is None:
            return None, ()
        residual = record.faraday_error() if record.representation == "rotation_invariant" else None
        if residual is None:
            return None, ()
        _, sd, wrong = residual_moments(residual)
        notes = ()
        if case.settings.analytic and wrong > 0.0:
            notes += (f"{100 * wrong:.3g} % of the Faraday-rotation estimates of calibration resolve the pi/2 "
                      "ambiguity wrongly (HH and VV swapped on that pass): the Monte Carlo draws them, the analytic "
                      "moments leave them out",)
        if case.settings.analytic and sd > RESIDUAL_ANALYTIC_MAX_SD_RAD:
            notes += (f"the Faraday rotation left by calibration's estimates has an SD of {math.degrees(sd):.3g} deg: "
                      "the analytic moments of HH and VV average it by a cubature that is approximate beyond "
                      f"{math.degrees(RESIDUAL_ANALYTIC_MAX_SD_RAD):g} deg; the Monte Carlo is exact",)
        return residual, notes

    def insensitivity(self, owner, key):
        """HV (and HH and VV left uncorrected) cannot see the settings of a Faraday-rotation correction."""
        if getattr(owner, "kind", None) != "calibration" or not rotation_only_setting(owner, key):
            return None
        if self.si["channels"] == "all" and self.si["correct_copol_faraday"]:
            return None
        return HV_UNCHANGED_BY_ROTATION + ("" if self.si["channels"] == "hv" else
                                           "; HH and VV are not corrected (correct_copol_faraday: false)")

    def forward(self, case):
        c, s = self.si, case.settings
        scene, system, faraday = case["scene.stack"], case["system.residual"], case["faraday.residual"]
        errors = StackSystemErrors(system, c["system_error_correlation"])
        residual, notes = self.copol_residual(case)
        stack_faraday = StackFaraday(faraday, self.difference_sd(faraday), residual)
        combination = self.combination(scene)
        joint = c["channels"] == "all"
        unavailable, use_notes = analytic_use(self, case, system, VALIDITY["stack_joint" if joint else "stack_hv"])
        notes += use_notes
        extra = {"correct_copol": c["correct_copol_faraday"]} if joint else {}
        kind = StackJointErrorModel if joint else StackHVErrorModel
        model = kind(scene, errors, stack_faraday, combination, looks=s.looks, reference=c["reference"], notes=notes,
                     unavailable=unavailable, kernel_memo=case.services.memo, **extra)
        if unavailable is None:  # evaluated here, once: every later stage reads it
            model.current()
        if s.montecarlo:
            if c["reference"] == "scene" and s.looks < 3 * scene.passes:
                raise fail(self, f"case {case.index}: the Monte Carlo of one scene needs at least 3N = "
                           f"{3 * scene.passes} looks, got {s.looks}", "raise simulation.looks")
            mc = simulate_stack(scene, errors, stack_faraday, combination, case.rng, s.looks, s.realisations,
                                s.noise_realisations, c["reference"], c["correct_copol_faraday"])
            gauss = gaussianity(mc.hv) if c["gaussianity"] and np.ravel(mc.hv).size >= 20 else None
            model = model.with_montecarlo(mc, gauss)
        return {"backscatter.error": model}


class StackErrorBudget(BackscatterErrorBudget):
    """The random-error budget of Ahmed et al. (2014) for a multi-pass estimate: the observations and their
    speckle diversity from the estimator and the inter-pass coherence of the stack (ground-cancellation.md,
    eq. 17), not the speckle-identical repeat passes of the single-pass preset. Its NESZ is the noise of each
    channel's combined estimate, sigma_n tr Q for HH and VV and sigma_n tr Q / 2 for the symmetrised HV (Men et al.
    2021, eq. 3)."""

    type_name = "stack_error_budget"
    summary = ("speckle/noise, temporal, calibration and area-projection error of a multi-pass estimate, with the "
               "effective looks of the stack's inter-pass coherence; runs after stack_backscatter_error")
    needs = ("scene.covariance", "scene.stack", "backscatter.error")
    uses = ("instrument",)

    def forward(self, case):
        model = innermost(case["backscatter.error"])  # the stack's own model under any error terms
        if not isinstance(model, StackModelBase):
            raise fail(self, f"needs the error model of stack_backscatter_error, got a {type(model).__name__}",
                       "list stack_backscatter_error before this module in propagation")
        include = tuple(self.si["include"])
        if model.includes_speckle and "speckle_noise" in include:
            raise fail(self, "speckle would be counted twice: the stack error model with reference 'population' "
                       "already includes it", "use reference: scene, or leave speckle_noise out of include",
                       key="include")
        comb, scene = model.combination, case["scene.stack"]
        sigma = np.real(np.diag(comb.combined_covariance(scene.blocks())))
        noise_obs = comb.noise_diversity
        speckle_obs = np.array([min(comb.speckle_diversity(scene.channel_matrix(i)), noise_obs) for i in range(3)])
        base = self.inputs_for(case)
        # The noise of each channel's combined estimate: tr Q times the per-pass estimate's, which is sigma_n for
        # HH and VV and sigma_n / 2 for the symmetrised HV = (M_hv + M_vh) / 2 (two independent noise draws of
        # power sigma_n averaged: Men et al. 2021, eq. 3; ground-cancellation.md, "Reduction").
        inputs = base.replace(observations=noise_obs, diverse_observations=speckle_obs,
                              nesz=base.nesz * comb.noise_gain * NOISE_FACTORS)
        try:
            budget = backscatter_budget(inputs, sigma)
        except PhysicsInputError as exc:
            raise fail(self, f"case {case.index}: {exc}") from exc
        budget = budget.with_(channels=("hh", "hv", "vv"), groups=include,
                              speckle_distribution=self.si["speckle_distribution"])
        return {"backscatter.budget": budget}
