"""End-to-end timing of every shipped scenario (issue 28, "Fast everywhere", Build 5): the yardstick a regression
shows on. Nothing here is optimised; every figure is printed next to its target.

Prints, in one run:

1. every scenario of scenarios/ run end to end through the command line (``e2esim run S -o TMP --no-progress``,
   the outputs and plots included), at full size, each twice in a fresh process: first with the benchmark's own
   empty array cache (cold: climatology tables computed and stored), then with the cache it left (warm: the
   issue's targets are for a warm cache), with the warm run's peak memory (``ru_maxrss`` of the ``e2esim``
   process, from ``os.wait4``: the largest single process, worker processes counted on their own).
   biomass_latitude_sweep runs with ``--workers 2``, as the issue's table states it; the others at the command's
   default, ``--workers auto`` (the rest of a run estimated above 2 s after its first block goes to as many
   processes as there are usable cores; the provenance's ``workers`` says what ran). Targets: the issue's table
   where it has the scenario (``TARGETS``), else the one stated here (``DEFAULT_TARGET_S``; the global map:
   bench_sweeps.py's); beside them, the figure the issue recorded when it was filed (not measured here);
2. the realistic analytic sweep of ``benchmarks/realistic_sweep.yaml`` (200,000 cases, ``--workers 2``; target
   <= 40 s);
3. the rows of the issue's table measured by other scripts, with the command that measures them: the Monte Carlo
   per Table II case (benchmarks/bench_crosspol.py, figure 1, same run as its pixel reference) and ``make test``.

``--reference DIR``: a checkout of another commit (with its own ``.venv``, e.g. ``git worktree add DIR BASE &&
make -C DIR .venv/.e2esim-installed``) runs every scenario too, in the same run, printed beside this one.
``--quick``: the reduced sizes of the default test suite (tests/quick_runs.py) and a 2,000-case realistic sweep,
one process each: a smoke run of a few minutes whose figures are not judged against the targets (which are for the
full sizes). ``--only NAME ...``: those scenarios only. ``--skip-realistic``: leave figure 2 out.

Nothing asserts a time. The machine's load is printed first and last: the targets are for two quiet cores, and
on a shared machine only figures of the same run compare.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"
REALISTIC = ROOT / "benchmarks" / "realistic_sweep.yaml"
sys.path.insert(0, str(ROOT / "tests"))
from quick_runs import quick_overrides  # the reduced sizes of the default suite

TARGETS = {  # scenario: (target s, target peak MB or None, the figure when issue 28 was filed)
    "biomass_ground_cancelled_tomographic": (10.0, None, "215 s"),
    "biomass_ground_cancelled": (5.0, 500.0, "29-90 s, 767 MB"),
    "biomass_latitude_sweep": (10.0, None, "69 s (--workers 2)"),
    "biomass_fr_climatology": (10.0, None, "57 s"),
    "biomass_multichannel": (5.0, None, "10-36 s"),
    "biomass_default": (4.0, None, "6-13 s"),
}
"""The issue's table (two cores, warm cache)."""
DEFAULT_TARGET_S = 10.0
"""Stated here for the scenarios the issue's table leaves out: a shipped scenario runs in seconds."""
STATED = {"biomass_global_map": (60.0, "bench_sweeps.py's target for the global map, warm")}
WORKERS = {"biomass_latitude_sweep": 2}
REALISTIC_TARGET_S = 40.0
OTHER_ROWS = [
    ("Monte Carlo per Table II case, paper's sizes", "<= 3 ms, same run as the pixel reference", "4.7 ms",
     "python benchmarks/bench_crosspol.py  (figure 1: fast ms per case beside the pixel reference)"),
    ("make test", "<= 3 min at a load of 2 on two cores", "2:17-5:05",
     "time make test  (README, Tests: the figure and the load it was measured at)"),
]


def load() -> str:
    return f"{os.getloadavg()[0]:.1f}" if hasattr(os, "getloadavg") else "unknown"


def timed(command: list, env: dict) -> tuple:
    """(wall seconds, peak MB of the process, exit status, the tail of its standard error)."""
    with tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=err, env=env, cwd=ROOT)
        try:
            _, status, usage = os.wait4(proc.pid, 0)
        except BaseException:  # Ctrl-C: the run stops with the benchmark
            proc.kill()
            proc.wait()
            raise
        seconds = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        tail = err.read().decode(errors="replace").strip().splitlines()[-1:] or [""]
    return seconds, usage.ru_maxrss / 1024.0, proc.returncode, tail[0][:160]


def run_scenario(e2esim: str, scenario: Path, sets: tuple, workers: int, cache: str, out: str) -> dict:
    """Cold then warm timings of ``scenario`` with the ``e2esim`` executable, each in a fresh process."""
    env = {**os.environ, "E2ESIM_CACHE": cache}
    command = [e2esim, "run", str(scenario), "-o", out, "--force", "--no-progress"]
    command += [a for s in sets for a in ("--set", s)] + (["--workers", str(workers)] if workers > 1 else [])
    cold = timed(command, env)
    warm = timed(command, env) if cold[2] == 0 else cold
    return {"cold": cold[0], "warm": warm[0], "mb": warm[1], "status": warm[2], "error": warm[3]}


def verdict(seconds: float, mb: float, target_s: float, target_mb, quick: bool) -> str:
    if quick:
        return "(quick: not judged)"
    ok = seconds <= target_s and (target_mb is None or mb <= target_mb)
    return "PASS" if ok else "MISS"


def scenarios_figure(names: list, quick: bool, reference: str | None, tmp: str) -> None:
    print("1. every shipped scenario end to end (cold: empty array cache; warm: the cache the cold run left)")
    ours = str(Path(sys.executable).with_name("e2esim"))
    theirs = str(Path(reference) / ".venv" / "bin" / "e2esim") if reference else None
    for name in names:
        target_s, target_mb, at_filing = TARGETS.get(name, (STATED.get(name, (DEFAULT_TARGET_S,))[0], None, None))
        sets = quick_overrides(name) if quick else ()
        workers = WORKERS.get(name, 1)
        row = run_scenario(ours, SCENARIOS / f"{name}.yaml", sets, workers, f"{tmp}/cache", f"{tmp}/{name}")
        limit = f"<= {target_s:g} s" + (f", <= {target_mb:g} MB" if target_mb else "")
        if name not in TARGETS:
            limit += " (stated: " + (STATED[name][1] if name in STATED else "not in the issue's table") + ")"
        where = f" --workers {workers}" if workers > 1 else ""
        if row["status"]:
            print(f"   {name}{where}: FAILED (exit {row['status']}): {row['error']}")
            continue
        print(f"   {name}{where}: warm {row['warm']:6.1f} s (cold {row['cold']:6.1f} s), peak {row['mb']:5.0f} MB   "
              f"target {limit}: {verdict(row['warm'], row['mb'], target_s, target_mb, quick)}"
              + (f"   at filing: {at_filing}" if at_filing else ""))
        if theirs:
            ref = run_scenario(theirs, Path(reference) / "scenarios" / f"{name}.yaml", sets, workers,
                               f"{tmp}/ref-cache", f"{tmp}/ref-{name}")
            shown = (f"warm {ref['warm']:6.1f} s (cold {ref['cold']:6.1f} s), peak {ref['mb']:5.0f} MB"
                     if not ref["status"] else f"FAILED (exit {ref['status']}): {ref['error']}")
            print(f"   {'':{len(name)}}  reference {reference}: {shown}")


def realistic_figure(quick: bool, tmp: str) -> None:
    print("2. realistic analytic sweep, benchmarks/realistic_sweep.yaml, --workers 2")
    scenario = REALISTIC
    if quick:  # 5 AGB values instead of 500: 2,000 cases
        scenario = Path(tmp) / "realistic_quick.yaml"
        scenario.write_text(REALISTIC.read_text().replace("[20, 400, 500]", "[20, 400, 5]"))
    cases = 2_000 if quick else 200_000
    row = run_scenario(str(Path(sys.executable).with_name("e2esim")), scenario, (), 2, f"{tmp}/cache",
                       f"{tmp}/realistic")
    if row["status"]:
        print(f"   FAILED (exit {row['status']}): {row['error']}")
        return
    print(f"   {cases:,} cases: {row['warm']:.1f} s ({row['warm'] / cases * 1e3:.2f} ms per case), main process peak "
          f"{row['mb']:.0f} MB   target <= {REALISTIC_TARGET_S:g} s for 200,000 cases: "
          f"{verdict(row['warm'], 0.0, REALISTIC_TARGET_S, None, quick)}   at filing: 673 s, 1.38 GB")


def other_rows() -> None:
    print("3. the issue's other rows, measured elsewhere")
    for what, target, at_filing, command in OTHER_ROWS:
        print(f"   {what}: target {target}; at filing {at_filing}; measured by: {command}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the test suite's reduced sizes; targets not judged")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="these scenarios only")
    parser.add_argument("--reference", metavar="DIR", help="a checkout (with .venv) timed beside this one")
    parser.add_argument("--skip-realistic", action="store_true", help="leave out the realistic 200,000-case sweep")
    args = parser.parse_args()
    names = args.only or sorted(p.stem for p in SCENARIOS.glob("*.yaml"))
    print(f"load average {load()} on {os.cpu_count()} CPUs; " + ("QUICK sizes (tests/quick_runs.py): targets not "
          "judged" if args.quick else "full sizes") + "; the targets are for two quiet cores")
    with tempfile.TemporaryDirectory(prefix="e2esim-bench-scenarios-") as tmp:
        scenarios_figure(names, args.quick, args.reference, tmp)
        if not args.skip_realistic:
            realistic_figure(args.quick, tmp)
    other_rows()
    print(f"load average at the end {load()}")


if __name__ == "__main__":
    main()
