"""The calibration campaign as a calibration module (issue 25): ``type: campaign`` in the ``calibration`` list.

It runs the campaign over the mission (``e2esim.campaign.campaign``) and states, as ``residual_system`` does, the
residual crosstalk, channel imbalance and gain error at the mission day ``epoch_day``; sweeping ``epoch_day``
gives the AGB error and verdict against mission time through the ordinary chain. The campaign is computed once
per process and settings (the process's kernel memo), whatever the number of epochs swept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from e2esim.calibration.modules import CalibrationModule
from e2esim.calibration.stated_steps import StatedResidualResult, StatedResidualStep
from e2esim.campaign.campaign import CampaignSetup, find_acquisitions, run_campaign, search_schedules
from e2esim.campaign.drift import YEAR_DAYS, DriftModel
from e2esim.campaign.repeat_orbit import repeat_track
from e2esim.campaign.site_file import read_sites_file
from e2esim.campaign.sites import PRESETS
from e2esim.campaign.visit_ionosphere import SOLAR_F107, SOLAR_SUNSPOTS, VisitIonosphereSettings
from e2esim.errors import ConfigError, PhysicsInputError
from e2esim.input_files import scenario_relative
from e2esim.ionosphere.variability import DEFAULT_TEC_VARIABILITY
from e2esim.orbit.timeline import BIOMASS_LAUNCH
from e2esim.params import Param
from e2esim.units import LEVEL_CONVENTIONS, THREE_SIGMA_AMPLITUDE, level_db_from_variance, variance_from_level_db

DRIFT_KEYS = ("initial_sd", "random_walk_variance_per_day", "trend_sd_per_year", "seasonal_sd")
DRIFT_DEFAULTS = {  # assumed, stated in docs/theory/calibration-campaign.md; gain in dB, the others linear
    "gain": {"initial_sd": 0.5, "random_walk_variance_per_day": 2e-4, "trend_sd_per_year": 0.1, "seasonal_sd": 0.1},
    "crosstalk": {"initial_sd": 0.03, "random_walk_variance_per_day": 2e-8, "trend_sd_per_year": 0.003,
                  "seasonal_sd": 0.0},
    "imbalance": {"initial_sd": 0.1, "random_walk_variance_per_day": 1e-6, "trend_sd_per_year": 0.01,
                  "seasonal_sd": 0.01},
    # the antenna (campaign.antenna; dB at the swath's far edge): pattern and pointing as known before launch, and
    # their thermal (seasonal) and slow changes in orbit
    "pointing": {"initial_sd": 0.1, "random_walk_variance_per_day": 1e-6, "trend_sd_per_year": 0.01,
                 "seasonal_sd": 0.02},
    "pattern": {"initial_sd": 0.1, "random_walk_variance_per_day": 1e-6, "trend_sd_per_year": 0.01,
                "seasonal_sd": 0.02},
}
DRIFT_PARAMETERS = tuple(DRIFT_DEFAULTS)
DEFAULT_FREQUENCY_HZ = 435e6  # BIOMASS (Quegan et al. 2018, Section 5): used, and stated, without an instrument


def _drift_param(name: str) -> Param:
    unit = "dB" if name in ("gain", "pointing", "pattern") else "linear"
    return Param(f"drift_{name}", "mapping", f"drift of the {name} ({unit}): " + ", ".join(DRIFT_KEYS),
                 default=dict(DRIFT_DEFAULTS[name]), convert=False)


class Campaign(CalibrationModule):
    """The calibration campaign over the mission's life: sites, every pass over them, what each visit measures,
    the drift between visits combined by a Kalman filter, and the residual at ``epoch_day`` stated as the
    residual system errors (crosstalk, channel imbalance, gain SD)."""

    type_name = "campaign"
    summary = "calibration campaign over the mission: residual crosstalk, imbalance and gain at a mission day"
    needs = ("system", "faraday.geophysical", "geometry")
    params = (
        Param("sites", "str", "preset calibration sites", default=tuple(PRESETS), variable_length=True,
              choices=tuple(PRESETS)),
        Param("sites_file", "str", "YAML file of the user's own sites ('sites:' list), relative to the scenario",
              default=None, nullable=True, input_file=True),
        Param("mission_years", "float", "mission length", default=5.0, unit="years", exclusive_minimum=0.0,
              maximum=15.0),
        Param("commissioning_days", "float", "commissioning phase: every transponder pass used", default=91.0,
              minimum=0.0),
        Param("step_days", "float", "spacing of the residual dates", default=1.0, exclusive_minimum=0.0),
        Param("first_node_minutes", "float", "an ascending-node crossing after the mission's start, day 0 at 00:00 "
              "UTC (sets where the ground tracks fall)", default=0.0, minimum=0.0, maximum=1440.0),
        Param("repeat_days", "float", "the operational orbit's repeat cycle: the altitude tuned to the nearest whole "
              "number of revolutions in it, the track drifting between the timeline's stacks (null: the stated "
              "altitude, no repeat, every pass acquired)", default=3.0, nullable=True, exclusive_minimum=0.0,
              maximum=60.0, unit="days"),
        Param("frequency_mhz", "float", "centre frequency of the visits' Faraday rotation and scintillation (null: "
              "the instrument module's; without one, 435 MHz, BIOMASS's (Quegan et al. 2018, Section 5), reported as "
              "assumed: frequency_assumed = 1)", default=None, nullable=True, unit="MHz", exclusive_minimum=0.0,
              convert=False),
        Param("incidence_near_deg", "float", "near incidence of the swath", default=23.0, unit="deg", minimum=1.0,
              maximum=89.0),
        Param("incidence_far_deg", "float", "far incidence of the swath", default=33.75, unit="deg", minimum=1.0,
              maximum=89.0),
        Param("start_date", "str", "the mission's day 0 (ISO date, 00:00 UTC): the dates, months and local times of "
              "the visits for the Faraday-rotation and scintillation climatologies", default=BIOMASS_LAUNCH),
        Param("solar", "str", "solar activity of the campaign's epoch: min (F10.7 70 sfu, sunspot number 10) or max "
              "(180 sfu, 150)", default="max", choices=tuple(SOLAR_F107)),
        Param("f107_sfu", "float", "F10.7 instead of the solar preset's", default=None, nullable=True, unit="sfu",
              minimum=50.0, maximum=400.0),
        Param("sunspot_number", "float", "12-month sunspot number instead of the solar preset's", default=None,
              nullable=True, minimum=0.0, maximum=250.0),
        Param("tec_variability", "float", "day-to-day coefficient of variation of TEC about the climatology (the "
              "prior that resolves the Faraday-rotation estimate's pi/2 ambiguity)", default=DEFAULT_TEC_VARIABILITY,
              minimum=0.0, maximum=2.0),
        Param("faraday_window_km", "float", "side of the Faraday-rotation estimation window on the ground (its "
              "scintillation spread)", default=2.0, unit="km", exclusive_minimum=0.0, maximum=100.0),
        Param("scintillation", "bool", "scintillation in the visit errors (peak-power loss of point targets, "
              "Faraday-rotation spread)", default=True),
        Param("monte_carlo_seed", "int", "seed of the strong-scatter Monte Carlo of a point target's peak loss",
              default=20250429, minimum=0),
        Param("transponder_per_year", "int", "transponder passes used per year after commissioning (null: all)",
              default=2, nullable=True, minimum=0),
        Param("opportunity", "str", "targets of opportunity used (names of sites; []: none; null: all)",
              default=None, variable_length=True, may_be_empty=True, nullable=True),
        Param("schedule_years", "float", "span the schedule covers: no visit used after it (null: the mission)",
              default=None, nullable=True, unit="years"),
        Param("epoch_day", "float", "the mission day whose residual the chain propagates (null: the worst)",
              default=None, nullable=True, minimum=0.0),
        *(_drift_param(name) for name in DRIFT_PARAMETERS),
        Param("limit_crosstalk_db", "float", "residual crosstalk level that meets the requirement (flowed down)",
              default=-30.0, unit="dB", maximum=0.0, convert=False),
        Param("limit_imbalance_db", "float", "residual channel-imbalance level that meets the requirement",
              default=-25.0, unit="dB", maximum=0.0, convert=False),
        Param("limit_gain_sd_db", "float", "residual gain SD that meets the requirement", default=0.3,
              unit="dB", exclusive_minimum=0.0, convert=False),
        Param("convention", "str", "how the levels map to variances (docs/conventions.md)",
              default=THREE_SIGMA_AMPLITUDE, choices=LEVEL_CONVENTIONS),
        Param("search_max_per_year", "int", "largest number of transponder passes per year the search tries",
              default=6, minimum=0, maximum=52),
    )

    def setup(self):
        c = self.config
        sites = tuple(PRESETS[n] for n in c["sites"])
        if c["sites_file"] is not None:
            sites += read_sites_file(scenario_relative(c["sites_file"], self.location.source), key="sites_file")
        self.sites = sites
        self.drift = {}
        for name in DRIFT_PARAMETERS:
            given = c[f"drift_{name}"]
            unknown = [k for k in given if k not in DRIFT_KEYS]
            if unknown:
                raise PhysicsInputError(f"unknown drift key {unknown[0]!r}; allowed: {', '.join(DRIFT_KEYS)}",
                                        key=f"drift_{name}.{unknown[0]}")
            values = {**DRIFT_DEFAULTS[name], **given}
            try:
                self.drift[name] = DriftModel(values["initial_sd"], values["random_walk_variance_per_day"],
                                              values["trend_sd_per_year"], values["seasonal_sd"])
            except PhysicsInputError as exc:
                raise PhysicsInputError(str(exc), key=f"drift_{name}.{exc.key}") from None
        self.limits = {"crosstalk": float(variance_from_level_db(c["limit_crosstalk_db"], c["convention"])),
                       "imbalance": float(variance_from_level_db(c["limit_imbalance_db"], c["convention"])),
                       "gain": c["limit_gain_sd_db"] ** 2}
        if c["incidence_far_deg"] <= c["incidence_near_deg"]:
            raise PhysicsInputError(f"far incidence {c['incidence_far_deg']} deg must exceed the near one "
                                    f"{c['incidence_near_deg']} deg", key="incidence_far_deg")
        if c["schedule_years"] is not None and c["schedule_years"] > c["mission_years"]:
            raise PhysicsInputError(f"a schedule of {c['schedule_years']:g} years is longer than the mission "
                                    f"({c['mission_years']:g} years); allowed: at most mission_years",
                                    key="schedule_years")
        try:
            np.datetime64(c["start_date"], "D")
        except ValueError:
            raise PhysicsInputError(f"start_date {c['start_date']!r} is not an ISO date (YYYY-MM-DD)",
                                    key="start_date") from None
        if c["epoch_day"] is not None and c["epoch_day"] > c["mission_years"] * YEAR_DAYS:
            raise PhysicsInputError(f"epoch_day {c['epoch_day']:g} is after the mission's end (day "
                                    f"{c['mission_years'] * YEAR_DAYS:g})", key="epoch_day")

    def _where_from(self, message: str) -> str:
        """The message, naming the sites file when one of its sites is at fault."""
        file = self.config["sites_file"]
        preset_names = set(self.config["sites"])
        for site in self.sites:
            if f"site {site.name} " in message and site.name not in preset_names and file is not None:
                return f"{message} (site {site.name!r} of the sites file {file})"
        return message

    def ionosphere(self, frequency_hz: float) -> VisitIonosphereSettings:
        c = self.config
        return VisitIonosphereSettings(
            c["start_date"], SOLAR_F107[c["solar"]] if c["f107_sfu"] is None else c["f107_sfu"],
            SOLAR_SUNSPOTS[c["solar"]] if c["sunspot_number"] is None else c["sunspot_number"], frequency_hz,
            tec_variability=c["tec_variability"], window_m=c["faraday_window_km"] * 1e3,
            scintillation=c["scintillation"], seed=c["monte_carlo_seed"])

    def setup_for(self, orbit, frequency_hz: float = DEFAULT_FREQUENCY_HZ) -> CampaignSetup:
        c = self.config
        track = None
        if c["repeat_days"] is not None:
            track = repeat_track(orbit, c["mission_years"] * YEAR_DAYS, c["commissioning_days"], c["repeat_days"])
            orbit = track.orbit
        setup = CampaignSetup(orbit, self.sites, self.drift, c["mission_years"] * YEAR_DAYS,
                              math.radians(c["incidence_near_deg"]), math.radians(c["incidence_far_deg"]),
                              c["step_days"], c["commissioning_days"], self.ionosphere(frequency_hz),
                              c["first_node_minutes"] * 60.0,
                              None if c["schedule_years"] is None else c["schedule_years"] * YEAR_DAYS, track)
        return setup

    def outcome(self, case) -> CampaignOutcome:
        """The campaign and the schedule search, once per process and settings (the process's kernel memo,
        ``case.services.memo``): ``e2esim run`` and its chain schedule search (``flowdown.campaign_schedule``, a
        second run of the same campaign at its worst epoch) share it. The key holds every setting it is computed
        from (the step's settings but the epoch, the orbit, the frequency and whether it is assumed)."""
        memo = getattr(case.services, "memo", None)
        frequency, assumed = self.frequency_hz(case.get("instrument"))
        key = ("campaign", repr(sorted((k, repr(v)) for k, v in self.config.items() if k != "epoch_day")),
               repr(case["geometry"].orbit), frequency, assumed)

        def compute():
            try:
                return compute_outcome(self, self.setup_for(case["geometry"].orbit, frequency), assumed)
            except PhysicsInputError as exc:  # at run time: name the scenario file and the key path here
                raise ConfigError(exc.location(self.location), self._where_from(str(exc))) from None

        return compute() if memo is None else memo.recall(key, compute, keep=CAMPAIGNS_KEPT)

    def frequency_hz(self, instrument) -> tuple:
        """(centre frequency in Hz, whether it is assumed): ``frequency_mhz`` if stated, else the instrument
        module's, else BIOMASS's 435 MHz (assumed)."""
        if self.config["frequency_mhz"] is not None:
            return self.config["frequency_mhz"] * 1e6, False
        given = getattr(instrument, "centre_frequency_hz", None)
        return (given, False) if given else (DEFAULT_FREQUENCY_HZ, True)

    def steps(self, case):
        out = self.outcome(case)
        day = self.config["epoch_day"]
        i = int(np.argmin(out.margin)) if day is None else int(np.argmin(np.abs(out.result.days - day)))
        var = {p: float(v[i]) for p, v in out.result.variance.items()}
        step = CampaignResidualStep(var["crosstalk"], var["imbalance"], None, None, math.sqrt(var["gain"]),
                                    out.scalars(i, self.config["convention"]), out)
        return [(self.type_name, step)]


CAMPAIGNS_KEPT = 1
"""Campaign outcomes a process keeps (``Campaign.outcome``): the last one, as its runs ask it again."""


@dataclass(frozen=True)
class CampaignOutcome:
    """What the campaign leaves: the residual series, the smallest margin per date (dB) and the schedule search."""

    result: object
    margin: np.ndarray
    search: object
    limits: dict
    convention: str
    site_names: tuple
    setup: object = field(default=None, compare=False, repr=False)  # the CampaignSetup (chain schedule search)
    frequency_assumed: bool = False  # no instrument module and no frequency_mhz: BIOMASS's 435 MHz assumed

    def scalars(self, i: int, convention: str) -> dict:
        r, s = self.result, self.search
        var = {p: float(v[i]) for p, v in r.variance.items()}
        worst = int(np.argmin(self.margin))
        out = {
            "epoch_day": float(r.days[i]),
            "residual_crosstalk_db": float(level_db_from_variance(var["crosstalk"], convention)),
            "residual_imbalance_db": float(level_db_from_variance(var["imbalance"], convention)),
            "margin_db": float(self.margin[i]),
            "worst_epoch_day": float(r.days[worst]),
            "worst_margin_db": float(self.margin[worst]),
            "visits_used": int(r.used.sum()),
            "acquisitions": int(r.used.size),
            "frequency_hz": float(self.setup.ionosphere.frequency_hz),
            "frequency_assumed": int(self.frequency_assumed),
        }
        track = self.setup.track
        if track is not None:
            out.update({"orbit_altitude_m": float(track.orbit.altitude_m),
                        "repeat_revolutions": int(track.revolutions), "repeat_days": float(track.repeat_days)})
        if s.best is None:
            out["schedule_found"] = 0
        else:
            out.update({"schedule_found": 1, "schedule_transponder_per_year": int(s.per_year[s.best]),
                        "schedule_opportunity_sites": len(s.opportunity[s.best]),
                        "schedule_margin_db": float(s.margin_db[s.best])})
        return out


def compute_outcome(module: Campaign, setup: CampaignSetup, frequency_assumed: bool = False) -> CampaignOutcome:
    c = module.config
    acq = find_acquisitions(setup)
    opportunity = tuple(s.name for s in setup.sites if s.type != "transponder") if c["opportunity"] is None \
        else tuple(c["opportunity"])
    result = run_campaign(setup, c["transponder_per_year"], opportunity, acq)
    after = result.days >= setup.commissioning_days
    margin = np.full(result.days.size, np.inf)
    for p, lim in module.limits.items():
        m = 10 * np.log10(lim / np.maximum(result.variance[p], 1e-300))
        margin = np.minimum(margin, np.where(after, m, np.inf))
    search = search_schedules(setup, module.limits, c["search_max_per_year"], acq=acq)
    return CampaignOutcome(result, margin, search, dict(module.limits), c["convention"],
                           tuple(site.name for site in setup.sites), setup, frequency_assumed)


@dataclass(frozen=True)
class CampaignResidualStep(StatedResidualStep):
    """The campaign's residual levels at the epoch, applied as ``StatedResidualStep`` applies stated ones; its result
    also carries the campaign's scalars (the epoch, the worst epoch, the schedule search's answer)."""

    campaign: dict = field(default_factory=dict)
    outcome: object = field(default=None, compare=False, repr=False)

    def result(self) -> CampaignStepResult:
        return CampaignStepResult({**self.campaign, **super().result().values}, self.outcome)


@dataclass(frozen=True)
class CampaignStepResult(StatedResidualResult):
    """The stated levels and the campaign's scalars (``values``), and the whole ``CampaignOutcome`` for the
    report (the residual series, the visits, the schedule search)."""

    outcome: object = field(default=None, compare=False, repr=False)
