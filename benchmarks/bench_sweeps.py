"""Batched sweeps (issue 14, "Batched sweeps"): speed and memory of the batched sweep engine, every figure from
repeated runs, each against a reference measured in the same run.

Prints, in one run:

1. an analytic sweep of 1,000,000 cases (``--cases``; AGB x crosstalk x channel imbalance, a grid as near to a
   cube as the count's divisors allow) end to end through the batched engine: scenario resolution, the run and
   the outputs (results.h5, summary.json, the report and its plots), each timed, and their total
   (target <= 20 s);
2. the reference: the per-case runner (``engine="per_case"``) on a sweep of the same three axes with 200 cases
   (``--reference-cases``): seconds per case, and the speed-up per case of the batched run of figure 1
   (target >= 200x; the run alone, and end to end). The batched engine runs the same 200 cases too, and every
   case's scalars must equal the per-case runner's to a relative 1e-12: the script stops (AssertionError)
   if one does not;
3. peak memory (``ru_maxrss``) of the sweep of figure 1 end to end at a quarter of its cases and at all of them
   (250,000 and 1,000,000: a quarter of the AGB values, the same instruments), each in a fresh process (target
   <= 4 GiB), and how the peak grows with the size (target: bounded by the block size, not by the sweep size).
   The reference: the full sweep with its finished blocks kept in memory (``spill=False``,
   ``e2esim.runner.spill``), as the runner did before they were spilled.
   Measured first, while this process is still small: on Linux a child's ``ru_maxrss`` starts from its parent's
   peak at the fork (it survives ``exec``), so children of a parent that ran figure 1 would report at least that
   parent's 2 GiB. ``VmHWM`` of /proc/self/status, the high-water mark of the child's own memory, is printed
   beside it;
4. the global map ``scenarios/biomass_global_map.yaml`` (1 deg forest cells, 12 months x 2 passes x solar
   maximum; docs/user-guide.md, "Global maps"), each run in a fresh process, so that the climatology table
   kept in memory does not carry over: first with the benchmark's own empty climatology cache (cold: the
   IRI/IGRF table of every month computed and stored), then with the cache it left (warm; target <= 60 s).
   ``--map-quick`` runs a 10 x 10 deg region instead and says so (the target is then not judged);
   ``--map-cache DIR`` uses that climatology cache instead of an empty one (e.g. ~/.cache/e2esim, where
   ``e2esim run`` keeps it by default), so that the first run is cold only if DIR lacks the tables.

The sweep and map runs use ``--workers`` local processes (default 2: the target is stated for two cores); the
per-case speed-up is also printed process for process, from one serial run of the same sweep.

Every figure is the best and the median of ``--repeats`` runs (default 3); the verdicts (PASS or MISS) are
judged on the best. Nothing here asserts a time: the figures are printed for a person to read. The machine's
load is printed first: on a shared machine, compare figures taken in the same run only.

Run with ``python benchmarks/bench_sweeps.py`` (``--quick``: 20,000 cases, one run of each, no memory figure,
the region map: a smoke run of seconds; ``--skip-memory``, ``--skip-map``: leave those figures out).
"""

from __future__ import annotations

import argparse
import copy
import gc
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GLOBAL_MAP = ROOT / "scenarios" / "biomass_global_map.yaml"
TARGET_SWEEP_S = 20.0
TARGET_SWEEP_CASES = 1_000_000
TARGET_SPEEDUP = 200.0
TARGET_MEMORY_GIB = 4.0
TARGET_MAP_S = 60.0
RTOL = 1e-12  # issue 14: the batched engine gives the per-case runner's numbers to 1e-12
QUICK_CASES = 20_000
MAP_REGION = {"lat": [-5, 5], "lon": [15, 25]}  # --map-quick: a 10 x 10 deg block of the Congo basin (tropical band)
RESULT = "BENCH-RESULT "  # a child's one line of results on standard output

SWEEP = {
    "name": "analytic_sweep",
    "scene": {"type": "forest_agb_model", "biome": "boreal"},
    "instrument": {"type": "biomass"},
    "ionosphere": {"type": "gaussian_faraday", "mean_deg": 60, "sd_deg": 5},
    "propagation": {"type": "hv_backscatter_error"},
    "retrieval": {"type": "power_law"},
    "requirements": [{"type": "agb_error_bound", "sources": "systematic"}, {"type": "agb_rmse"}],
    "simulation": {"mode": "analytic", "seed": 1},
    "sweep": {"parameters": {}},
    # ``plots: []`` is refused (the list must not be empty); ``auto`` draws, for a run of more than
    # e2esim.io.summary.LARGE_RUN_CASES cases, only the plots that read the run's columns (the error budget)
    "output": {"plots": ["auto"]},
}
AXES = (("scene.agb_t_ha", 20, 400), ("instrument.crosstalk.level_db", -40, -20),
        ("instrument.channel_imbalance.level_db", -40, -25))


# The scenarios ------------------------------------------------------------------------------------------------
def grid_sizes(cases: int) -> tuple:
    """(N1, N2, N3) with N1 * N2 * N3 == cases, the largest as small as the divisors of ``cases`` allow, in
    decreasing order (the AGB axis the longest: each AGB value is one scene, each pair of the other two one
    instrument)."""
    divisors = [d for d in range(1, math.isqrt(cases) + 1) if cases % d == 0]
    divisors = sorted(set(divisors + [cases // d for d in divisors]))
    best = None
    for a in divisors:
        for b in divisors:
            if (cases // a) % b:
                continue
            sizes = tuple(sorted((a, b, cases // a // b), reverse=True))
            if best is None or sizes < best:
                best = sizes
    return best


def sweep_sizes(cases: int, instruments_of: int | None = None) -> tuple:
    """The grid of ``cases`` cases (``grid_sizes``); with ``instruments_of``, the crosstalk and imbalance axes of
    that sweep's grid and an AGB axis as long as ``cases`` needs: the same distinct modules, fewer cases."""
    if instruments_of is None:
        return grid_sizes(cases)
    _, n_xt, n_imb = grid_sizes(instruments_of)
    return cases // (n_xt * n_imb), n_xt, n_imb


def sweep_raw(cases: int, instruments_of: int | None = None) -> dict:
    """The analytic sweep scenario (module docstring, figure 1) with ``cases`` cases (``sweep_sizes``), a dict."""
    raw = copy.deepcopy(SWEEP)
    raw["sweep"]["parameters"] = {key: {"linspace": [start, stop, n]}
                                  for (key, start, stop), n in zip(AXES, sweep_sizes(cases, instruments_of))}
    return raw


def sweep_shape(cases: int, instruments_of: int | None = None) -> str:
    return " x ".join(f"{n} {key.split('.')[-2] if key.endswith('level_db') else 'AGB'}"
                      for (key, _, _), n in zip(AXES, sweep_sizes(cases, instruments_of)))


def resolve_sweep(cases: int, instruments_of: int | None = None):
    from e2esim.runner.scenario import Scenario

    return Scenario(sweep_raw(cases, instruments_of), "bench_sweeps.yaml").resolve()


def map_overrides(quick: bool) -> list:
    if not quick:
        return []
    lat, lon = (json.dumps(MAP_REGION[k]) for k in ("lat", "lon"))
    return [f"sweep.map.lat_range_deg={lat}", f"sweep.map.lon_range_deg={lon}",
            f"ionosphere.table_lat_range_deg={lat}", f"ionosphere.table_lon_range_deg={lon}"]


# Timing -------------------------------------------------------------------------------------------------------
def end_to_end(resolve, folder: Path, workers: int = 1, spill: bool | None = None) -> dict:
    """Resolve, run (batched engine, on ``workers`` local processes) and write the outputs into ``folder``; the
    seconds of each, the total, the case count, the peak resident memory (GiB) after the run and after the
    outputs, and the largest peak of a worker process (0 for a serial run). spill : as ``run_scenario``."""
    from e2esim.io.array_cache import open_cache
    from e2esim.runner.outputs import write_outputs
    from e2esim.runner.run import run_scenario

    t0 = time.perf_counter()
    resolved = resolve()
    t1 = time.perf_counter()
    result = run_scenario(resolved, progress=False, workers=workers, spill=spill, spill_folder=folder,
                          cache=open_cache)  # as e2esim run
    t2 = time.perf_counter()
    peak_run = peak_gib()
    write_outputs(result, folder)
    t3 = time.perf_counter()
    return {"cases": len(resolved.cases), "resolve": t1 - t0, "run": t2 - t1, "outputs": t3 - t2, "total": t3 - t0,
            "workers": workers, "peak_run_gib": peak_run, "peak_gib": peak_gib(), "hwm_gib": high_water_gib(),
            "worker_peak_gib": children_peak_gib() if workers > 1 else 0.0}


def peak_gib() -> float:
    """Peak resident memory of this process so far (ru_maxrss: KiB on Linux, bytes on macOS), in GiB."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**30 if sys.platform == "darwin" else peak / 2**20


def children_peak_gib() -> float:
    """The largest peak resident memory of a finished child process (the run's workers), in GiB."""
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return peak / 2**30 if sys.platform == "darwin" else peak / 2**20


def high_water_gib() -> float | None:
    """``VmHWM`` (peak resident memory of this process's own address space) in GiB; None where there is no
    /proc (not Linux)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 2**20  # kB
    except OSError:
        pass
    return None


def own_peak(run: dict) -> str:
    """A child's peak memory as its own high-water mark (``ru_maxrss`` inherits the parent's peak on Linux)."""
    return f"{run['peak_gib'] if run['hwm_gib'] is None else run['hwm_gib']:.2f} GiB"


def summary(times: list) -> str:
    """Best and median of repeated wall-clock times."""
    if len(times) == 1:
        return f"{times[0]:.2f} s (1 run)"
    return f"best {min(times):.2f} s, median {statistics.median(times):.2f} s ({len(times)} runs)"


def parts(run: dict) -> str:
    return f"resolve {run['resolve']:.2f} s, run {run['run']:.2f} s, outputs {run['outputs']:.2f} s"


def verdict(value: float, target: float, unit: str = " s", at_least: bool = False) -> str:
    met = value >= target if at_least else value <= target
    return f"target {'>=' if at_least else '<='} {target:g}{unit}: {'PASS' if met else 'MISS'}"


def times(ratio: float) -> str:
    return f"{ratio:.0f}x" if ratio >= 10 else f"{ratio:.1f}x"


def say(text: str) -> None:
    print(text, flush=True)


# Children: one measurement in a fresh process -----------------------------------------------------------------
def child(kind: str, cases: int, quick_map: bool, workers: int, instruments_of: int | None = None) -> None:
    """Run one measurement and print its figures as one JSON line (``RESULT``)."""
    with tempfile.TemporaryDirectory() as tmp:
        if kind in ("sweep", "sweep_in_memory"):
            figures = end_to_end(lambda: resolve_sweep(cases, instruments_of), Path(tmp) / "out", workers,
                                 spill=False if kind == "sweep_in_memory" else None)
        else:
            from e2esim.runner.scenario import Scenario

            figures = end_to_end(lambda: Scenario.load(GLOBAL_MAP, overrides=map_overrides(quick_map)).resolve(),
                                 Path(tmp) / "out", workers)
    print(RESULT + json.dumps(figures), flush=True)


def in_child(kind: str, cases: int = 0, quick_map: bool = False, env: dict | None = None, workers: int = 1,
             instruments_of: int | None = None) -> dict:
    """The figures of ``child`` run in a fresh Python process, with its wall time (start-up and imports included)
    as ``process``."""
    command = [sys.executable, __file__, "--child", kind, "--cases", str(cases), "--workers", str(workers)]
    command += ["--map-quick"] if quick_map else []
    command += ["--instruments-of", str(instruments_of)] if instruments_of else []
    t0 = time.perf_counter()
    proc = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, env={**os.environ, **(env or {})})
    elapsed = time.perf_counter() - t0
    lines = [line for line in proc.stdout.splitlines() if line.startswith(RESULT)]
    if proc.returncode != 0 or not lines:
        raise SystemExit(f"the {kind} child ({' '.join(command[2:])}) failed with status {proc.returncode}:\n"
                         f"{proc.stderr[-4000:]}")
    return {**json.loads(lines[-1][len(RESULT):]), "process": elapsed}


# The figures --------------------------------------------------------------------------------------------------
def batched_sweep(cases: int, repeats: int, folder: Path, workers: int) -> list:
    """Figure 1: the sweep end to end, ``repeats`` times in this process, on ``workers`` local processes."""
    say(f"1. analytic sweep of {cases:,} cases ({sweep_shape(cases)}), batched engine on {workers} worker "
        f"process{'es' if workers > 1 else ''} (--workers), end to end (outputs included):")
    runs = []
    for i in range(repeats):
        runs.append(end_to_end(lambda: resolve_sweep(cases), folder / f"sweep{i}", workers))
        say(f"   run {i + 1}: {parts(runs[-1])}; total {runs[-1]['total']:.2f} s")
        gc.collect()
    best = min(runs, key=lambda r: r["total"])
    if cases == TARGET_SWEEP_CASES:
        judged = verdict(best["total"], TARGET_SWEEP_S)
    else:  # fixed costs (imports, plots) do not scale: a smaller sweep is not judged against the target
        judged = (f"target ({TARGET_SWEEP_CASES:,} cases in <= {TARGET_SWEEP_S:g} s) not judged at {cases:,} cases; "
                  f"scaled linearly to {TARGET_SWEEP_CASES:,}: {best['total'] * TARGET_SWEEP_CASES / cases:.1f} s")
    say(f"   total: {summary([r['total'] for r in runs])}; {judged}")
    for name in ("resolve", "run", "outputs"):
        times = [r[name] for r in runs]
        say(f"   {name}: {summary(times)}; {min(times) / cases * 1e6:.2f} us per case (best)")
    return runs


def serial_run(cases: int) -> float:
    """Seconds of the run alone of figure 1's sweep on one process (the per-core speed-up of figure 2)."""
    from e2esim.runner.run import run_scenario

    resolved = resolve_sweep(cases)
    t0 = time.perf_counter()
    run_scenario(resolved, progress=False)
    return time.perf_counter() - t0


def reference(runs: list, cases: int, reference_cases: int, repeats: int, serial_s: float | None = None) -> None:
    """Figure 2: the per-case runner on ``reference_cases`` cases of the same axes, the batched engine on the same
    cases, the numbers compared case by case, and the speed-ups."""
    from e2esim.runner.run import run_scenario

    run_scenario(resolve_sweep(8), progress=False, engine="per_case")  # warm-up: what only the per-case runner imports
    resolved = resolve_sweep(reference_cases)
    per_case, batched = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        slow = run_scenario(resolved, progress=False, engine="per_case")
        per_case.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        fast = run_scenario(resolved, progress=False)
        batched.append(time.perf_counter() - t0)
    checked = compare_cases(fast, slow)
    per_case_s = min(per_case) / reference_cases
    say(f"2. reference: the per-case runner on {reference_cases} cases ({sweep_shape(reference_cases)}): "
        f"{summary(per_case)}; {per_case_s * 1e3:.3f} ms per case (best)")
    say(f"   the batched engine on the same cases: {summary(batched)}; "
        f"{min(batched) / reference_cases * 1e6:.1f} us per case; {times(per_case_s * reference_cases / min(batched))} "
        f"the per-case runner")
    say(f"   same numbers: the {checked:,} scalars of the {reference_cases} cases agree to a relative {RTOL:g} "
        "(checked)")
    if runs:
        run_s = min(r["run"] for r in runs) / cases
        total_s = min(r["total"] for r in runs) / cases
        workers = runs[0].get("workers", 1)
        speedup = per_case_s / run_s
        small = (f" (at {cases:,} cases, where fixed costs weigh more than at {TARGET_SWEEP_CASES:,})"
                 if cases < TARGET_SWEEP_CASES else "")
        say(f"   speed-up per case of the batched run of figure 1 ({cases:,} cases, {workers} process"
            f"{'es' if workers > 1 else ''}), the run alone: {times(speedup)} "
            f"({run_s * 1e6:.2f} us against {per_case_s * 1e6:.0f} us per case); "
            f"{verdict(speedup, TARGET_SPEEDUP, 'x', at_least=True)}{small}")
        if serial_s is not None:
            say(f"   per core: the same sweep's run alone on one process took {serial_s:.2f} s "
                f"({serial_s / cases * 1e6:.2f} us per case): {times(per_case_s * cases / serial_s)} the per-case "
                f"runner, process for process")
        say(f"   end to end (resolution and outputs per case included, the per-case runner's run alone): "
            f"{times(per_case_s / total_s)} ({total_s * 1e6:.2f} us per case)")


def compare_cases(batched, per_case) -> int:
    """Raise AssertionError unless every case's scalars agree (names in the same order; values to ``RTOL``,
    a requirement's margin relative to its checked value, as the margin is the difference of two close
    numbers; NaN equal to NaN). Returns the number of values compared."""
    bad, count = [], 0
    assert len(batched.cases) == len(per_case.cases)
    for i, (got, expected) in enumerate(zip(batched.cases, per_case.cases)):
        a, b = got.scalars, expected.scalars
        if list(a) != list(b):
            raise AssertionError(f"case {i}: the scalars differ in name: {sorted(set(a) ^ set(b))}")
        for name, x in b.items():
            y = a[name]
            count += 1
            scale = abs(b.get(name[:-len("margin")] + "value", 0.0)) if name.endswith(".margin") else 0.0
            if math.isnan(x) or math.isnan(y):
                same = math.isnan(x) and math.isnan(y)
            else:
                same = x == y or abs(x - y) <= RTOL * max(abs(x), abs(y), scale)
            if not same:
                bad.append(f"case {i} {name}: batched {y!r}, per case {x!r}")
    if bad:
        raise AssertionError(f"{len(bad)} of {count} scalars differ beyond {RTOL:g}:\n" + "\n".join(bad[:20]))
    return count


def memory_runs(cases: int, workers: int) -> list:
    """Figure 3, measured: the sweep end to end at a quarter of ``cases`` and at ``cases``, and the reference (all
    cases, blocks kept in memory), each in a fresh process (started before this process has run anything:
    module docstring)."""
    return [in_child("sweep", cases // 4, workers=workers, instruments_of=cases),
            in_child("sweep", cases, workers=workers), in_child("sweep_in_memory", cases, workers=workers)]


def memory(runs: list) -> None:
    """Figure 3, printed."""
    small, large, kept = runs
    say("3. peak memory (ru_maxrss) of the sweep end to end, each in a fresh process (measured before figure 1); "
        f"{verdict(large['peak_gib'], TARGET_MEMORY_GIB, ' GiB')}:")
    shapes = (sweep_shape(small["cases"], large["cases"]), sweep_shape(large["cases"]))
    for run, shape in zip((small, large), shapes):
        hwm = "" if run["hwm_gib"] is None else f", VmHWM {run['hwm_gib']:.2f} GiB"
        workers = (f"; largest worker process {run['worker_peak_gib']:.2f} GiB" if run.get("workers", 1) > 1
                   else "")
        say(f"   {run['cases']:>9,} cases ({shape}): {run['peak_gib']:.2f} GiB{hwm} (after the run "
            f"{run['peak_run_gib']:.2f} GiB){workers}; {parts(run)}, total {run['total']:.2f} s "
            f"(process {run['process']:.2f} s)")

    def growth(key):  # bytes per further case, from the quarter to the whole sweep
        return (large[key] - small[key]) * 2**30 / (large["cases"] - small["cases"])

    say(f"   grows with the sweep: {large['peak_gib'] / small['peak_gib']:.2f}x the peak for "
        f"{large['cases'] / small['cases']:.0f}x the cases (the same instruments); {growth('peak_gib'):.0f} bytes per "
        f"further case ({growth('peak_run_gib'):.0f} by the end of the run; the rest while the outputs read one "
        "column at a time)")
    say(f"   reference, the {kept['cases']:,} cases with their finished blocks kept in memory: {kept['peak_gib']:.2f} "
        f"GiB (after the run {kept['peak_run_gib']:.2f} GiB); spilled, the peak is "
        f"{large['peak_gib'] / kept['peak_gib']:.2f}x of it")


def global_map(quick: bool, repeats: int, cache: str | None, workers: int) -> None:
    """Figure 4: the global map (or the region of ``--map-quick``), cold once and warm ``repeats`` times."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = cache or str(Path(tmp) / "cache")
        env = {"E2ESIM_CACHE": folder}
        found = len(list(Path(folder).glob("*.h5"))) if Path(folder).is_dir() else 0
        cold = in_child("map", quick_map=quick, env=env, workers=workers)
        warm = [in_child("map", quick_map=quick, env=env, workers=workers) for _ in range(repeats)]
    what = (f"REGION ONLY (--map-quick): lat {MAP_REGION['lat']}, lon {MAP_REGION['lon']} deg, not the global map"
            if quick else "the whole globe")
    say(f"4. map {GLOBAL_MAP.relative_to(ROOT)}: {what}; 1 deg, 12 months x 2 passes x solar max, "
        f"{cold['cases']:,} cases; each run in a fresh process")
    first = ("cold (an empty climatology cache: the table of every month computed and stored)" if cache is None
             else f"first run, with the cache {folder} as found ({found} tables)")
    say(f"   {first}: total {cold['total']:.2f} s ({parts(cold)}; process {cold['process']:.2f} s)")
    best = min(warm, key=lambda r: r["total"])
    judged = "target not judged (a region, not the global map)" if quick else verdict(best["total"], TARGET_MAP_S)
    say(f"   warm cache: total {summary([r['total'] for r in warm])}; {judged}")
    say(f"   best warm run: {parts(best)}; process {best['process']:.2f} s (start-up and imports included); "
        f"peak memory {own_peak(best)} (VmHWM)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=None,
                        help=f"cases of the sweep of figure 1 (default {TARGET_SWEEP_CASES:,}; "
                             f"--quick: {QUICK_CASES:,})")
    parser.add_argument("--reference-cases", type=int, default=200, help="cases of the per-case reference (200)")
    parser.add_argument("--repeats", type=int, default=None, help="runs per figure (default 3; --quick: 1)")
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke run: {QUICK_CASES:,} cases, one run of each, no memory figure, the region map")
    parser.add_argument("--skip-memory", action="store_true", help="leave out the peak-memory figure")
    parser.add_argument("--skip-map", action="store_true", help="leave out the global-map figure")
    parser.add_argument("--map-quick", action="store_true",
                        help=f"a region (lat {MAP_REGION['lat']}, lon {MAP_REGION['lon']} deg) instead of the globe")
    parser.add_argument("--map-cache", default=None,
                        help="climatology cache folder of the map runs (default: an empty temporary one)")
    parser.add_argument("--workers", type=int, default=2,
                        help="worker processes of the sweep and map runs (default 2: the target's two cores)")
    parser.add_argument("--child", choices=("sweep", "sweep_in_memory", "map"), help=argparse.SUPPRESS)
    parser.add_argument("--instruments-of", type=int, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    cases = args.cases or (QUICK_CASES if args.quick else TARGET_SWEEP_CASES)
    if args.child:
        child(args.child, cases, args.map_quick, args.workers, args.instruments_of)
        return
    repeats = args.repeats or (1 if args.quick else 3)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    say(f"machine: {os.cpu_count()} cores, load average {load:.2f} at the start")
    measured = None if args.skip_memory or args.quick else memory_runs(cases, args.workers)  # first: docstring
    with tempfile.TemporaryDirectory() as tmp:
        runs = batched_sweep(cases, repeats, Path(tmp), args.workers)
    serial_s = serial_run(cases) if args.workers > 1 else None
    reference(runs, cases, args.reference_cases, repeats, serial_s)
    if measured:
        memory(measured)
    if not args.skip_map:
        global_map(args.map_quick or args.quick, repeats, args.map_cache, args.workers)


if __name__ == "__main__":
    main()
