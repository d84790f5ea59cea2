"""Orbit modules (kind ``orbit``): where and when the mission looks at the scenario's site.

The module fills ``CaseState.geometry`` with an ``AcquisitionGeometry``: every (date, pass, swath position)
at which the site is imaged, with incidence, heading, look vector, local time and ionospheric pierce point.
"""

from __future__ import annotations

import numpy as np

from e2esim import products as P
from e2esim.errors import PhysicsInputError
from e2esim.module import Stage
from e2esim.orbit.acquisition import Site, acquisitions, swath_incidences
from e2esim.orbit.sunsync import PASSES, SunSynchronousOrbit
from e2esim.orbit.timeline import BIOMASS_LAUNCH, PHASES, MissionTimeline, period_dates
from e2esim.params import Ordered, Param, ParamGroup, with_defaults

PASS_CHOICES = ("both", "ascending", "descending", "dawn", "dusk")

_SITE = SITE_PARAMS = ParamGroup("site", "the target imaged", (
    Param("name", "str", "label of the site", default="site"),
    Param("lat_deg", "float", "geocentric latitude", unit="deg", minimum=-90.0, maximum=90.0),
    Param("lon_deg", "float", "east longitude", unit="deg", minimum=-180.0, maximum=360.0),
))

_ACQ = ParamGroup("acquisitions", "the dates on which the site is imaged", (
    Param("mode", "str", "period: every step_days from start to end; timeline: the mission phases of Quegan et al. "
          "(2018), Section 2", default="period", choices=("period", "timeline")),
    Param("start", "str", "first date of the period (ISO)", default="2026-01-01"),
    Param("end", "str", "last date of the period (ISO)", default="2026-12-31"),
    Param("step_days", "float", "days between acquisitions in the period (3: the repeat interval)", default=3.0,
          unit="day", exclusive_minimum=0.0, maximum=36525.0),
    Param("phase", "str", "timeline mode: which phase's acquisitions", default="mission", choices=PHASES),
    Param("mission_start", "str", "timeline mode: first day of the commissioning phase (ISO)", default=BIOMASS_LAUNCH),
    Param("site_slot", "float", "timeline mode: where in each phase/cycle the site's stack starts (0 first day, "
          "1 last)", default=0.5, minimum=0.0, maximum=1.0),
))


class SunSynchronousOrbitModule(Stage):
    """A side-looking SAR on a circular sun-synchronous orbit imaging one site.

    Orbit: inclination from the sun-synchronous condition, local time of the ascending node, left or right
    looking, Earth rotation in the ground velocity (e2esim.orbit.sunsync). Geometry: zero-Doppler
    line of sight at ``swath_samples`` incidences equally spaced in ground range across the swath
    (e2esim.orbit.geometry). Dates: a period or the mission timeline (e2esim.orbit.timeline).
    """

    kind = "orbit"
    type_name = "sun_synchronous"
    summary = "circular sun-synchronous orbit, side-looking geometry and acquisition dates of a site"
    params = (
        Param("altitude_km", "float", "orbit altitude", unit="km", minimum=150.0, maximum=6000.0),
        Param("ltan_hours", "float", "local mean solar time of the ascending node", unit="h", minimum=0.0,
              exclusive_maximum=24.0),
        Param("look_side", "str", "side the radar looks to", default="left", choices=("left", "right")),
        Param("incidence_near_deg", "float", "incidence angle at near range", unit="deg", exclusive_minimum=0.0,
              exclusive_maximum=90.0),
        Param("incidence_far_deg", "float", "incidence angle at far range", unit="deg", exclusive_minimum=0.0,
              exclusive_maximum=90.0),
        Param("swath_samples", "int", "positions across the swath (equal ground-range intervals)", default=5,
              minimum=1, maximum=101),
        Param("earth_rotation", "bool", "include the Earth's rotation in heading and zero-Doppler geometry",
              default=True),
        Param("passes", "str", "passes that image the site", default="both", choices=PASS_CHOICES),
        Param("pierce_height_km", "float", "height of the ionospheric pierce points reported in the geometry",
              default=350.0, unit="km", minimum=50.0, maximum=2000.0),
        _SITE,
        _ACQ,
        Ordered("pierce_height_km", "altitude_km"),
        Ordered("incidence_near_deg", "incidence_far_deg"),
    )
    provides = (P.GEOMETRY,)

    def setup(self):
        c = self.si
        self.orbit = SunSynchronousOrbit(c["altitude_m"], c["ltan_hours"], c["look_side"], c["earth_rotation"])
        passes = self._passes(c["passes"])
        lon_deg = self.config["site"]["lon_deg"]  # wrapped to [-180, 180) in degrees, as given
        site = Site(c["site"]["name"], c["site"]["lat_rad"], np.radians(((lon_deg + 180.0) % 360.0) - 180.0))
        try:
            dates, phases = self._dates(c["acquisitions"])
        except PhysicsInputError as exc:  # name the key below the section: acquisitions.<argument>
            raise PhysicsInputError(str(exc), key="acquisitions." + (exc.key or "start")) from exc
        inc = swath_incidences(self.orbit, c["incidence_near_rad"], c["incidence_far_rad"], c["swath_samples"])
        try:
            self.geometry = acquisitions(self.orbit, site, dates, passes, inc, phases, c["pierce_height_m"])
        except PhysicsInputError as exc:  # out of reach of a pass: the site's latitude
            raise PhysicsInputError(str(exc), key=exc.key or "site.lat_deg") from exc

    def _passes(self, choice: str) -> tuple:
        if choice == "both":
            return PASSES
        if choice in PASSES:
            return (choice,)
        return (self.orbit.pass_for_label(choice),)

    @staticmethod
    def _dates(acq: dict) -> tuple:
        if acq["mode"] == "period":
            dates = period_dates(acq["start"], acq["end"], acq["step_days"])
            return dates, ("period",) * len(dates)
        try:
            timeline = MissionTimeline(start=acq["mission_start"], site_slot=acq["site_slot"])
        except PhysicsInputError as exc:
            raise PhysicsInputError(str(exc), key="mission_start" if exc.key == "start" else exc.key) from exc
        dates = timeline.acquisition_dates(acq["phase"])
        return dates, tuple(timeline.phase_of(d) for d in dates)

    def forward(self, case):
        return {"geometry": self.geometry}


class BiomassOrbit(SunSynchronousOrbitModule):
    """ESA BIOMASS: 666 km dawn-dusk sun-synchronous orbit, ascending node at 06:00, left-looking,
    incidence 23 deg to 33.75 deg (CEOS EO Handbook, BIOMASS mission summary; ESA's BIOMASS coverage material;
    Quegan et al. 2018, Section 4.2)."""

    type_name = "biomass_orbit"
    summary = "ESA BIOMASS orbit preset: 666 km dawn-dusk (LTAN 06:00), left-looking, incidence 23-33.75 deg"
    params = with_defaults(
        SunSynchronousOrbitModule.params,
        {"altitude_km": 666.0, "ltan_hours": 6.0, "look_side": "left", "incidence_near_deg": 23.0,
         "incidence_far_deg": 33.75},
    )
