"""BIOMASS's operational orbit: a 3-day repeat ground track that drifts between stacks (issue 25, item 2).

**Repeat condition.** A ground track repeats after N revolutions in D days when N nodal periods equal D turns of
the Earth relative to the orbit's node (Vallado 2013, Section 11.4.3; Wertz 2009, "Orbit and Constellation
Design", Section 9.3): N T_N = D 2 pi / (omega_E - dOmega/dt). A sun-synchronous node turns with the mean Sun, so
the Earth turns once per mean solar day relative to it and the condition is N T_N = D x 86400 s, with T_N =
2 pi / (du/dt) and du/dt the secular J2 rate of ``visibility.argument_of_latitude_rate`` (Vallado 2013, eqs. 9-41).
``repeat_altitude`` solves it for the altitude (the inclination follows from the sun-synchronous condition, so
both change together); N is the whole number of revolutions nearest the stated orbit's in D days (BIOMASS at
666 km: 43.9996 in 3 days, hence N = 44 and the track repeats at 665.96 km, i = 98.05 deg). The N tracks of one repeat
cycle cross the equator G = 360 deg / N = 8.18 deg apart.

**The drifting track and the mission timeline** (Quegan et al. 2018, Section 2; ESA: "a drifting orbit ... three
images of one area, after which it observes a new area"). Each phase is a run of *stacks*: ``passes`` repeat cycles
on one ground track (the baselines' small drift, hundreds of metres, is neglected), after which the track is moved
east by G / n, n = floor(phase length / (passes x D)) the stacks the phase holds, so that the phase's stacks sweep
the whole gap between neighbouring tracks once. The days after the last stack of a phase (or cycle) are the
manoeuvre to the next one: no acquisition. Phases: commissioning (stacks of one pass: the track crosses the
transponder at a new incidence every cycle), tomographic (stacks of 7 passes, 425 days), interferometric (cycles of
219 days, stacks of 3 passes), as ``orbit.timeline.MissionTimeline`` states them.

**Which passes acquire** (``acquired``). In commissioning every pass with the site in the swath's incidence range
(the 2-D antenna characterisation). In a tomographic phase or interferometric cycle the acquisition plan images
every area once per pass direction (Section 2: "7 passes ... over all continental areas", "3 passes ... global
coverage"), in one of its sub-swaths; the swath's incidence range spans several stack steps, so the site lies in it
in a few consecutive stacks: the plan's stack is taken as the one whose incidence at the site is nearest the middle
of the range (the sub-swath that holds it), all of that stack's passes. An area target (``POINT_SITES``: not a
transponder or corner reflector) is wider than a sub-swath: some part of it is imaged in every stack that has its
centre in the incidence range, and every such pass is kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from e2esim.campaign.visibility import argument_of_latitude_rate
from e2esim.errors import PhysicsInputError
from e2esim.orbit.sunsync import SunSynchronousOrbit
from e2esim.orbit.timeline import MissionTimeline

DAY_S = 86400.0
POINT_SITES = ("transponder", "corner_reflector")
"""Site types the acquisition plan images as points (once per phase or cycle and pass direction); the others are
areas (a desert, an ice sheet, a field of permanent scatterers) taken as wide as the swath's ground range, imaged
by some sub-swath in every stack whose track has the site's centre in the swath's incidence range."""


def _u_rate(altitude_m: float, ltan_h: float) -> float:
    return argument_of_latitude_rate(SunSynchronousOrbit(altitude_m, ltan_h))


def revolutions_in(orbit: SunSynchronousOrbit, days: float) -> float:
    """Nodal revolutions of ``orbit`` in ``days`` mean solar days (the node turns with the mean Sun)."""
    return _u_rate(orbit.altitude_m, orbit.ltan_h) * days * DAY_S / (2 * math.pi)


def repeat_altitude(revolutions: int, days: float, ltan_h: float = 6.0) -> float:
    """Altitude (m) of the circular sun-synchronous orbit whose track repeats after ``revolutions`` in ``days``:
    du/dt (h) = 2 pi N / (D x 86400 s), solved by bisection (du/dt falls monotonically with the altitude)."""
    target = 2 * math.pi * revolutions / (days * DAY_S)
    lo, hi = 200e3, 3000e3
    if not _u_rate(hi, ltan_h) < target < _u_rate(lo, ltan_h):
        raise PhysicsInputError(f"no sun-synchronous orbit between 200 and 3000 km repeats after {revolutions} "
                                f"revolutions in {days:g} days; allowed: a repeat cycle that such an orbit can "
                                f"keep (BIOMASS: 3 days)", key="repeat_days")
    for _ in range(60):  # 2800 km / 2^60: far below a millimetre
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _u_rate(mid, ltan_h) > target else (lo, mid)
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class Stacking:
    """One phase of the drifting track: it starts on ``start_day``, lasts ``length_days`` (or runs in cycles of
    that length to ``end_day``), and holds ``stacks`` stacks of ``passes`` repeat cycles each."""

    name: str
    start_day: float
    end_day: float
    length_days: float
    passes: int
    stacks: int


@dataclass(frozen=True)
class RepeatTrack:
    """The repeat orbit (``orbit``, tuned altitude), its revolutions per repeat and the phases' stacking."""

    orbit: SunSynchronousOrbit
    revolutions: int
    repeat_days: float
    phases: tuple

    @property
    def gap_rad(self) -> float:
        """Equatorial longitude between neighbouring tracks of one repeat cycle (rad): 2 pi / N."""
        return 2 * math.pi / self.revolutions

    def stack_of(self, day) -> tuple:
        """(phase index, cycle id, stack id, track offset in rad) at mission ``day`` (arrays); stack id -1 in a
        manoeuvre (no acquisition) or outside the phases. Cycle ids (a phase, or one interferometric cycle) and
        stack ids are unique over the mission."""
        day = np.asarray(day, float)
        phase = np.full(day.shape, -1)
        group = np.full(day.shape, -1.0)
        stack = np.full(day.shape, -1.0)
        offset = np.zeros(day.shape)
        base = gbase = 0
        for i, p in enumerate(self.phases):
            inside = (day >= p.start_day) & (day < p.end_day)
            cycles = max(1, math.ceil((p.end_day - p.start_day) / p.length_days - 1e-9))
            cycle = np.floor((day - p.start_day) / p.length_days)
            k = np.floor((day - p.start_day - cycle * p.length_days) / (p.passes * self.repeat_days))
            ok = inside & (k < p.stacks)
            phase = np.where(inside, i, phase)
            group = np.where(inside, gbase + cycle, group)
            stack = np.where(ok, base + cycle * p.stacks + k, stack)
            offset = np.where(ok, k * self.gap_rad / p.stacks, offset)
            base += cycles * p.stacks
            gbase += cycles
        return phase, group.astype(int), stack.astype(int), offset

    def acquired(self, day, pass_name, incidence, near: float, far: float, point: bool = True) -> np.ndarray:
        """Which of a site's passes in the swath (mission ``day``, ``pass_name``, ``incidence`` rad) the plan
        acquires: every one in commissioning, and every one inside a stack for an area (``point`` False); for a
        point, in a tomographic phase or an interferometric cycle, per pass direction, those of the stack whose
        incidence is nearest the middle of [near, far]."""
        phase, group, stack, _ = self.stack_of(day)
        names = np.array([p.name for p in self.phases] + ["outside"])[phase]
        keep = ((names == "commissioning") | (not point)) & (stack >= 0)
        if not point:
            return keep
        mid = 0.5 * (near + far)
        for g in np.unique(group[(names != "commissioning") & (stack >= 0)]):
            for p in np.unique(pass_name):
                sel = (group == g) & (pass_name == p) & (stack >= 0)
                if not sel.any():
                    continue
                ids = np.unique(stack[sel])
                dist = [np.mean(np.abs(incidence[sel & (stack == s)] - mid)) for s in ids]
                keep |= sel & (stack == ids[int(np.argmin(dist))])
        return keep


def repeat_track(orbit: SunSynchronousOrbit, days: float, commissioning_days: float, repeat_days: float = 3.0,
                 timeline: MissionTimeline | None = None) -> RepeatTrack:
    """The operational track of ``orbit`` over a mission of ``days``: the altitude tuned to the nearest whole number
    of revolutions in ``repeat_days``, and the phases of ``timeline`` (Quegan et al. 2018, Section 2, by default)
    with its commissioning ``commissioning_days`` long."""
    tl = timeline or MissionTimeline()
    n = round(revolutions_in(orbit, repeat_days))
    tuned = replace(orbit, altitude_m=repeat_altitude(n, repeat_days, orbit.ltan_h), inclination_rad=None)
    spans = [("commissioning", commissioning_days, 1), ("tomographic", tl.tomographic_days, tl.tomographic_passes),
             ("interferometric", tl.interferometric_cycle_days, tl.interferometric_passes)]
    phases, start = [], 0.0
    for name, length, passes in spans:  # a stack's passes come one repeat cycle apart (the timeline's 3 days)
        end = days if name == "interferometric" else min(start + length, days)
        stacks = int(length // (passes * repeat_days))
        if end > start and stacks > 0:
            phases.append(Stacking(name, start, end, length, passes, stacks))
        start = end
    return RepeatTrack(tuned, n, repeat_days, tuple(phases))
