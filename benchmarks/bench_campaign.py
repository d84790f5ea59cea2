"""The calibration campaign (issue 25, "Speed"), each path next to a fair reference measured in the same run.

1. A five-year campaign over 10 sites (the four presets and six corner reflectors), every acquisition and the
   residual of every parameter on every day (target <= 5 s), on the operational repeat orbit (``repeat_orbit``).
   Reference for the passes: the obvious search, the range rate to the site sampled every 10 s over the mission
   (the track's stack offsets applied) and its zero crossings refined by bisection (one area site, scaled by 10
   sites); it must find the same passes (checked on the site it runs).
2. The schedule search: 0..12 transponder passes per year x every subset of the 9 targets of opportunity (6,656
   schedules), one batched Kalman filter per parameter (target <= 30 s on two cores). Reference: one filter per
   schedule (``run_campaign``), timed on 64 schedules and scaled; their margins must agree with the batched ones.
3. The schedule search decided by the requirement through the chain (``e2esim.flowdown.campaign_schedule``), on
   scenarios/biomass_calibration_campaign.yaml as shipped (five years, daily, 4 sites, 0..6 passes per year: 56
   schedules): one campaign run and one batched analytic chain run over every schedule's candidate worst epochs
   (target <= 30 s, the search's). Reference: the chain at every date of one schedule (``--quick``: skipped).

Nothing here asserts a time. The machine's load is printed first: on a shared machine compare figures of the same
run only. Run with ``python benchmarks/bench_campaign.py`` (``--quick``: 0..3 passes per year).
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import numpy as np

from e2esim.campaign.campaign import CampaignSetup, find_acquisitions, run_campaign, search_schedules
from e2esim.campaign.drift import YEAR_DAYS, DriftModel
from e2esim.campaign.repeat_orbit import repeat_track
from e2esim.campaign.sites import PRESETS, CalibrationSite
from e2esim.campaign.visibility import DAY_S, satellite_state
from e2esim.orbit.frames import EARTH_MEAN_RADIUS, to_ecef
from e2esim.orbit.sunsync import SunSynchronousOrbit

REFLECTORS = [(-25.0, 135.0), (-15.0, 20.0), (5.0, -60.0), (35.0, 100.0), (-40.0, -70.0), (50.0, 10.0)]


def setup(years: float) -> CampaignSetup:
    sites = tuple(PRESETS.values()) + tuple(
        CalibrationSite(f"reflector_{i}", math.radians(lat), math.radians(lon), "corner_reflector",
                        ("gain", "imbalance"), 35.0, 25.0, stability=0.02) for i, (lat, lon) in enumerate(REFLECTORS))
    drift = {"gain": DriftModel(0.5, 2e-4, 0.1, 0.1), "crosstalk": DriftModel(0.03, 2e-8, 0.003),
             "imbalance": DriftModel(0.1, 1e-6, 0.01, 0.01), "pointing": DriftModel(0.1, 1e-6, 0.01, 0.02),
             "pattern": DriftModel(0.1, 1e-6, 0.01, 0.02)}
    track = repeat_track(SunSynchronousOrbit(666e3), years * YEAR_DAYS, 91.0)  # the operational repeat orbit
    return CampaignSetup(track.orbit, sites, drift, years * YEAR_DAYS, math.radians(23.0),
                         math.radians(33.75), first_node_s=480.0, track=track)


def sampled_passes(s: CampaignSetup, site) -> np.ndarray:
    """The reference: range rate sampled every 10 s, sign changes refined by bisection; passes in the swath."""
    target = to_ecef(np.array(site.lat), np.array(site.lon), EARTH_MEAN_RADIUS)

    def rate(t):
        r, v = satellite_state(s.orbit, t, s.first_node_s, s.track.stack_of(t / DAY_S)[3])
        return np.einsum("ij,ij->i", r - target, v)

    found = []
    for start in np.arange(0.0, s.days * DAY_S, 10 * DAY_S):  # ten days at a time (overlapping by one sample)
        t = np.arange(start, min(start + 10 * DAY_S + 10.0, s.days * DAY_S), 10.0)
        f = rate(t)
        lo = t[:-1][(f[:-1] < 0) & (f[1:] >= 0)]
        hi = lo + 10.0
        for _ in range(40):
            mid = (lo + hi) / 2
            neg = rate(mid) < 0
            lo, hi = np.where(neg, mid, lo), np.where(neg, hi, mid)
        found.append((lo + hi) / 2)
    t = np.concatenate(found)
    # inside a stack only: a crossing at a stack boundary is the track's jump, a manoeuvre is no acquisition
    stack = s.track.stack_of(t / DAY_S)[2]
    t = t[(stack >= 0) & (stack == s.track.stack_of((t - 30.0) / DAY_S)[2])
          & (stack == s.track.stack_of((t + 30.0) / DAY_S)[2])]
    r, v = satellite_state(s.orbit, t, s.first_node_s, s.track.stack_of(t / DAY_S)[3])
    los = r - target
    inc = np.arccos(los @ target / np.linalg.norm(los, axis=1) / np.linalg.norm(target))
    left = np.einsum("ij,ij->i", np.cross(r, v), target - r) > 0
    keep = left & (inc >= s.near) & (inc <= s.far)
    return t[keep], inc[keep]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    years, per_year = (5.0, 3) if args.quick else (5.0, 12)
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    s = setup(years)
    times, cpu = [], []
    for _ in range(2):  # the first in a process also reads PyIRI's coefficient files (once per process)
        t0, c0 = time.perf_counter(), time.process_time()
        acq = find_acquisitions(s)
        result = run_campaign(s, 2, tuple(x.name for x in s.sites if x.type != "transponder"), acq)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    t_campaign = times[0]
    print(f"1. campaign: {years:g} years, {len(s.sites)} sites, {acq.day.size:,} acquisitions (each with its "
          f"climatology Faraday rotation and scintillation), {result.days.size:,} days x 5 parameters: "
          f"{t_campaign:.2f} s first in the process, {times[1]:.2f} s again (CPU {cpu[0]:.2f} s, {cpu[1]:.2f} s; "
          f"target <= 5 s)")
    t0 = time.perf_counter()
    ref, ref_inc = sampled_passes(s, s.sites[1])  # Selima, an area: every pass in a stack is acquired
    t_ref = time.perf_counter() - t0
    mine = np.sort(acq.day[acq.site == 1]) * DAY_S
    matched = np.min(np.abs(mine[:, None] - ref[None, :]), axis=1) < 0.05
    inner = (ref_inc > s.near + 1e-4) & (ref_inc < s.far - 1e-4)
    assert np.all(np.min(np.abs(ref[inner][:, None] - mine[None, :]), axis=1) < 0.05)  # every inner pass found
    print(f"   reference passes (sampled every 10 s), one site: {t_ref:.2f} s, x{len(s.sites)} sites = "
          f"{t_ref * len(s.sites):.1f} s; {matched.sum()} of {mine.size} passes the same within 0.05 s, every "
          f"reference pass inside the swath found ({ref.size} in all)")
    limits = {"gain": 0.3**2, "crosstalk": 10 ** (-3.0) / 9, "imbalance": 10 ** (-2.5) / 9}
    t0, c0 = time.perf_counter(), time.process_time()
    search = search_schedules(s, limits, per_year, acq=acq)
    t_search, c_search = time.perf_counter() - t0, time.process_time() - c0
    print(f"2. schedule search: {search.cost.size:,} schedules: {t_search:.2f} s, CPU {c_search:.2f} s "
          "(target <= 30 s); answer: "
          + ("none" if search.best is None else f"{search.per_year[search.best]} passes/year with "
             f"{', '.join(search.opportunity[search.best]) or 'no target of opportunity'}"))
    pick = np.linspace(0, search.cost.size - 1, 64).astype(int)
    after = result.days >= s.commissioning_days
    t0 = time.perf_counter()
    for i in pick:
        one = run_campaign(s, int(search.per_year[i]), search.opportunity[i], acq)
        worst = min(np.min(10 * np.log10(limits[p] / one.variance[p][after])) for p in limits)
        assert abs(worst - search.margin_db[i]) < 1e-6, (i, worst, search.margin_db[i])
    t_one = (time.perf_counter() - t0) / pick.size
    print(f"   reference (one filter per schedule): {t_one:.3f} s each, x{search.cost.size:,} = "
          f"{t_one * search.cost.size:.0f} s; margins agree on the {pick.size} schedules run")
    if not args.quick:
        chain_search()


def chain_search() -> None:
    from e2esim.flowdown.campaign_schedule import chain_schedule_search
    from e2esim.runner.scenario import Scenario

    path = Path(__file__).resolve().parents[1] / "scenarios" / "biomass_calibration_campaign.yaml"
    scenario = Scenario.load(path)
    t0 = time.perf_counter()
    found = chain_schedule_search(scenario)
    t_chain = time.perf_counter() - t0
    b = found.best
    print(f"3. schedule search through the chain: {found.cost.size} schedules, {found.rows:,} chain rows: "
          f"{t_chain:.2f} s (target <= 30 s); answer: "
          + ("none" if b is None else f"{found.per_year[b]} passes/year with "
             f"{', '.join(found.opportunity[b]) or 'no target of opportunity'}, margin {found.agb_margin[b]:.3g} "
             f"{found.unit} at day {found.worst_day[b]:g}"))
    days = np.arange(91.0, 5 * YEAR_DAYS, 1.0)
    raw = {**scenario.raw, "output": {**scenario.raw["output"], "answer": False}}
    raw["calibration"] = [{**raw["calibration"][0], "transponder_per_year": int(found.per_year[b]),
                           "opportunity": list(found.opportunity[b])}]
    raw["sweep"] = {"parameters": {"calibration.0.epoch_day": [float(d) for d in days]}}
    t0 = time.perf_counter()
    from e2esim.runner.run import run_scenario

    margin = np.asarray(run_scenario(Scenario(raw, str(path)).resolve(), progress=False).table.requirements[0].margin)
    print(f"   reference (the chain at every one of {days.size:,} dates, one schedule): "
          f"{time.perf_counter() - t0:.2f} s; its worst margin {margin.min():.6g} at day {days[margin.argmin()]:g}")


if __name__ == "__main__":
    main()
