"""The BIOMASS mission timeline of Quegan et al. (2018), Section 2, as dates on which a site is imaged.

Phases, one after the other from the mission start:

* Commissioning Phase (CP): 3 months, 21 passes over a transponder at different incidence angles;
* Tomographic Phase (TP): 425 days (about 14 months) giving 7 passes, 3 days apart, over every
  continental area outside the SOTR zone;
* Interferometric Phase (IP): the rest of the 5-year mission, in cycles of 219 days (about 7 months),
  each giving 3 passes with a 3-day repeat (3-baseline Pol-InSAR).

The paper gives the phase lengths and the stacks, not when within a phase a given site is imaged (that is
the acquisition plan). Here a site's stack starts at a fraction ``site_slot`` of the free time of each
phase or cycle (0: first possible day, 1: last), 0.5 by default; the 21 commissioning passes are spread
evenly over the CP. The BIOMASS mission paper quotes other lengths (a 14-month tomographic phase, Pol-InSAR
coverage every 7 months: Quegan et al. 2019, Remote Sens. Environ. 227, 44-60, abstract); every number here is
a parameter.
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass

from e2esim.errors import PhysicsInputError
from e2esim.limits import MAX_DATES, shorten

PHASES = ("commissioning", "tomographic", "interferometric", "mission")

BIOMASS_LAUNCH = "2025-04-29"
"""Launch of BIOMASS on Vega-C (ESA); the default mission start."""


@dataclass(frozen=True)
class MissionTimeline:
    """Phase lengths and stacks of the mission (Quegan et al. 2018, Section 2; defaults are the paper's).

    start : first day of the commissioning phase (ISO date). commissioning_days : CP length (3 months).
    commissioning_passes : passes over the transponder during the CP. tomographic_days, tomographic_passes,
    tomographic_repeat_days : TP length, passes per site and days between them. interferometric_cycle_days,
    interferometric_passes, interferometric_repeat_days : IP cycle length, passes per cycle and repeat.
    mission_years : total mission length. site_slot : where within each phase or cycle a site's stack
    starts, as a fraction of the free days (0 to 1).
    """

    start: str = BIOMASS_LAUNCH
    commissioning_days: float = 91.0
    commissioning_passes: int = 21
    tomographic_days: float = 425.0
    tomographic_passes: int = 7
    tomographic_repeat_days: float = 3.0
    interferometric_cycle_days: float = 219.0
    interferometric_passes: int = 3
    interferometric_repeat_days: float = 3.0
    mission_years: float = 5.0
    site_slot: float = 0.5

    def __post_init__(self):
        _parse_date(self.start, "start")
        if not 0.0 <= self.site_slot <= 1.0:
            raise PhysicsInputError(f"site_slot {self.site_slot} is outside [0, 1]")
        for name in ("tomographic", "interferometric"):
            n = getattr(self, f"{name}_passes")
            span = (n - 1) * getattr(self, f"{name}_repeat_days")
            length = self.tomographic_days if name == "tomographic" else self.interferometric_cycle_days
            if span > length:
                raise PhysicsInputError(f"{n} {name} passes {getattr(self, f'{name}_repeat_days')} days apart do not "
                                        f"fit in {length} days")

    @property
    def start_date(self) -> dt.datetime:
        return _parse_date(self.start)

    @property
    def end_date(self) -> dt.datetime:
        return self.start_date + dt.timedelta(days=365.25 * self.mission_years)

    def phase_bounds(self) -> dict:
        """``{phase: (first day, end)}`` as datetimes, the IP running to the end of the mission."""
        cp0 = self.start_date
        tp0 = cp0 + dt.timedelta(days=self.commissioning_days)
        ip0 = tp0 + dt.timedelta(days=self.tomographic_days)
        return {"commissioning": (cp0, tp0), "tomographic": (tp0, ip0), "interferometric": (ip0, self.end_date)}

    def acquisition_dates(self, phase: str = "mission") -> list:
        """Dates (datetime, 00:00 local) on which the site is imaged in ``phase`` (or the whole mission)."""
        if phase not in PHASES:
            raise PhysicsInputError(f"phase {phase!r} is not one of {', '.join(PHASES)}")
        bounds = self.phase_bounds()
        out: list = []
        if phase in ("commissioning", "mission"):
            c0, c1 = bounds["commissioning"]
            step = (c1 - c0) / self.commissioning_passes
            out += [_day(c0 + step * (k + 0.5)) for k in range(self.commissioning_passes)]
        if phase in ("tomographic", "mission"):
            t0, _ = bounds["tomographic"]
            out += self._stack(t0, self.tomographic_days, self.tomographic_passes, self.tomographic_repeat_days)
        if phase in ("interferometric", "mission"):
            i0, i1 = bounds["interferometric"]
            cycle = dt.timedelta(days=self.interferometric_cycle_days)
            c = i0
            while c + cycle <= i1 + dt.timedelta(days=1e-6):
                out += self._stack(c, self.interferometric_cycle_days, self.interferometric_passes,
                                   self.interferometric_repeat_days)
                c += cycle
        return out

    def _stack(self, begin: dt.datetime, length_days: float, passes: int, repeat_days: float) -> list:
        free = length_days - (passes - 1) * repeat_days
        first = begin + dt.timedelta(days=self.site_slot * max(free - 1.0, 0.0))
        return [_day(first + dt.timedelta(days=k * repeat_days)) for k in range(passes)]

    def phase_of(self, date: dt.datetime) -> str:
        for name, (a, b) in self.phase_bounds().items():
            if a <= date < b:
                return name
        return "outside"


def period_dates(start: str, end: str, step_days: float) -> list:
    """Dates from ``start`` to ``end`` (ISO, inclusive) every ``step_days`` days, at most
    ``e2esim.limits.MAX_DATES`` of them. Errors name the argument at fault (``PhysicsInputError.key``)."""
    a, b = _parse_date(start, "start"), _parse_date(end, "end")
    if b < a:
        raise PhysicsInputError(f"period end {end} is before its start {start}", key="end")
    if not step_days > 0 or not math.isfinite(step_days):
        raise PhysicsInputError(f"step_days must be a finite number > 0, got {step_days}", key="step_days")
    span = (b - a) / dt.timedelta(days=1)
    count = math.floor(span / step_days) + 1
    if count > MAX_DATES:
        raise PhysicsInputError(f"{count:,} dates from {start} to {end} every {step_days:g} days exceed the limit of "
                                f"{MAX_DATES:,} dates; use a larger step_days or a shorter period", key="step_days")
    out = []
    for k in range(count + 1):
        if k * step_days > span + 1:  # past the end: stop before a huge step could overflow a timedelta
            break
        try:
            d = a + dt.timedelta(days=k * step_days)
        except OverflowError:
            break
        if d > b:
            break
        out.append(_day(d))
    return out


def _day(when: dt.datetime) -> dt.datetime:
    return dt.datetime(when.year, when.month, when.day)


def _parse_date(text: str, key: str | None = None) -> dt.datetime:
    try:
        return dt.datetime.fromisoformat(str(text))
    except ValueError as exc:
        raise PhysicsInputError(f"{shorten(repr(text))} is not an ISO date (YYYY-MM-DD)", key=key) from exc
