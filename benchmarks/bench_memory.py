"""Memory of big runs (issue 22, "Memory of big runs"): the peak memory per case of ``e2esim run`` for every
requirement type, against the figure the documentation states and against a reference measured in the same run.

Every run is ``e2esim run`` (the command a user types) in a fresh process, on a variant of
``benchmarks/realistic_sweep.yaml``: HV error + random-error budget + power law, 500 AGB x 20 crosstalk x 20
Faraday-rotation spreads (200,000 cases). Each variant runs twice, with 20 Faraday-rotation spreads and with 7
(70,000 cases): the same scenes, instruments and error budgets (the run's catalogs of distinct values, bounded
by ``e2esim.runner.blocks.CATALOG_ENTRIES``: docs/architecture.md), and blocks of the same size (4096 cases,
on two workers too), fewer cases. What grows per case is the difference of the two peaks over the difference
of their case counts: the figure the documentation states (``e2esim.limits.MEMORY_PER_CASE_BYTES``).
The peak of the larger run over its cases is printed beside it (fixed costs and catalogs included).

Variants (the requirements of the scenario): ``minimal`` (the reference: the lightest chain, no error budget, a
+-20 % bound and an RMSE, as in benchmarks/bench_sweeps.py), ``bound`` (agb_error_bound), ``level_margins``
(agb_error_bound with level margins), ``tradeoff_curve`` (agb_error_bound with its trade-off curve: root finding
per point and case, some 15 ms a case at the default 121 points, so 31 points and 26 AGB values, 80 against 20
spreads, 41,600 and 10,400 cases; the curves go to disk with their block, so what stays per case does not
depend on their points), ``rmse`` (agb_rmse), ``rmse_absolute`` (agb_rmse_absolute) and ``realistic`` (level
margins and RMSE: the run of the issue), the last also on ``--workers 2`` (the main process, and the process tree
as the sum of its proportional set sizes, PSS, sampled every 0.1 s: pages the workers share with the main
process counted once) and resumed (``--resume`` of a run whose journal holds every case: reading the journal
back and writing the outputs).

Peaks are ``ru_maxrss`` of the main process (``os.wait4``; it starts from this small process's size at the fork).
Nothing is asserted: the figures are printed for a person to read, each with PASS or MISS against the documented
figure. The machine's load is printed first: on a shared machine compare figures taken in the same run only.

Run with ``python benchmarks/bench_memory.py`` (about 25 minutes on two cores); ``--quick``: 150 AGB values
(60,000 and 21,000 cases; under --workers 2 the smaller run then has smaller blocks), no trade-off curve unless
named, a smoke run of a few minutes; ``--variants a,b``: only those.
"""

from __future__ import annotations

import argparse
import copy
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "benchmarks" / "realistic_sweep.yaml"
sys.path.insert(0, str(ROOT / "src"))

BOUND = {"type": "agb_error_bound", "sources": "systematic", "bound_percent": 20, "confidence_percent": 99.865}
RMSE = {"type": "agb_rmse", "max_percent": 20}
VARIANTS = {
    "minimal": [BOUND, RMSE],
    "bound": [BOUND],
    "level_margins": [{**BOUND, "level_margins": True}],
    "tradeoff_curve": [{**BOUND, "tradeoff_curve": True}],
    "rmse": [RMSE],
    "rmse_absolute": [{"type": "agb_rmse_absolute", "max_t_ha": 20}],
    "realistic": [{**BOUND, "level_margins": True}, RMSE],
}
SPREADS = (7, 20)  # Faraday-rotation spreads of the smaller and the larger run
TRADEOFF = (26, (20, 80), 31)  # the trade-off curve's AGB values, spreads (10,400 and 41,600 cases) and points


def variant(name: str, agb: int, spreads: int) -> dict:
    """The scenario of variant ``name`` with ``agb`` AGB values and ``spreads`` Faraday-rotation spreads."""
    raw = yaml.safe_load(SCENARIO.read_text())
    raw["name"] = f"memory_{name}"
    raw["requirements"] = copy.deepcopy(VARIANTS[name])
    if name == "tradeoff_curve":
        raw["requirements"][0]["curve_points"] = TRADEOFF[2]
    if name == "minimal":
        raw["propagation"] = [raw["propagation"][0]]  # no error budget: the lightest chain
    sweep = raw["sweep"]["parameters"]
    sweep["scene.agb_t_ha"]["linspace"][2] = agb
    sweep["ionosphere.sd_deg"]["linspace"][2] = spreads
    return raw


def sizes(name: str, agb: int) -> list:
    """(AGB values, spreads) of the smaller and the larger run of variant ``name``."""
    if name == "tradeoff_curve":
        return [(TRADEOFF[0], s) for s in TRADEOFF[1]]
    return [(agb, s) for s in SPREADS]


def cases_of(raw: dict) -> int:
    n = 1
    for axis in raw["sweep"]["parameters"].values():
        n *= axis["linspace"][2]
    return n


# Measuring one process tree -----------------------------------------------------------------------------------
def _tree(pid: int) -> list:
    out = [pid]
    try:
        for task in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{task}/children") as fh:
                for child in fh.read().split():
                    out += _tree(int(child))
    except OSError:
        pass
    return out


def _pss_kib(pid: int) -> int:
    try:
        with open(f"/proc/{pid}/smaps_rollup") as fh:
            for line in fh:
                if line.startswith("Pss:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def measured(command: list) -> dict:
    """Run ``command``; its main process's peak (``ru_maxrss``, MiB), the peak sum of its process tree's PSS
    (MiB; 0 where there is no /proc), the largest number of processes seen, and the wall time."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    tree_peak, processes = 0, 1
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        pids = _tree(proc.pid)
        tree_peak = max(tree_peak, sum(_pss_kib(p) for p in pids))
        processes = max(processes, len(pids))
        time.sleep(0.1)
    error = proc.stderr.read().decode(errors="replace")
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{error[-3000:]}")
    return {"main_mib": usage.ru_maxrss / 1024, "tree_mib": tree_peak / 1024, "processes": processes,
            "seconds": time.perf_counter() - t0}


def e2esim(*args) -> list:
    return [sys.executable, "-m", "e2esim", *args]


def run_variant(raw: dict, folder: Path, mode: str) -> dict:
    """Peaks of ``e2esim run`` of ``raw`` in ``mode``: "serial", "workers" (--workers 2) or "resume" (--resume of
    a journal holding every case, made by ``make_journal`` in a process of its own)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "scenario.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    out = folder / "out"
    if mode == "resume":
        subprocess.run([sys.executable, __file__, "--make-journal", str(path), str(out)], cwd=ROOT, check=True)
        args = ["--resume"]
    else:
        args = ["--force"] + (["--workers", "2"] if mode == "workers" else [])
    return {**measured(e2esim("run", str(path), "-o", str(out), "--no-progress", *args)), "cases": cases_of(raw)}


def make_journal(path: str, out: str) -> None:
    """An interrupted run of ``path`` in ``out`` whose journal holds every case (killed before its outputs)."""
    from e2esim.runner.journal import Journal
    from e2esim.runner.outputs import prepare_folder
    from e2esim.runner.run import run_scenario
    from e2esim.runner.scenario import Scenario

    resolved = Scenario.load(path).resolve()
    lock = prepare_folder(Path(out), force=True)
    journal = Journal(Path(out), resolved)
    journal.start(resume=False)
    run_scenario(resolved, progress=False, journal=journal, spill_folder=out)
    journal.close()
    lock.release()


# The figures --------------------------------------------------------------------------------------------------
def say(text: str) -> None:
    print(text, flush=True)


def per_case(full: dict, smaller: dict, key: str) -> float:
    """Bytes per further case from the smaller run to the larger one."""
    return (full[key] - smaller[key]) * 2**20 / (full["cases"] - smaller["cases"])


def block_cases(cases: int, mode: str) -> int:
    """The cases of a block of a run of ``cases`` cases (``e2esim.runner.run.block_tasks``): on two workers, small
    enough that each gets eight blocks."""
    from e2esim.runner.run import BLOCK_CASES

    return max(1, min(BLOCK_CASES, math.ceil(cases / 16))) if mode == "workers" else BLOCK_CASES


def figure(name: str, mode: str, full: dict, smaller: dict, documented: float, reference: float | None) -> float:
    grow = per_case(full, smaller, "main_mib")
    met = "PASS" if grow <= documented else "MISS"
    blocks = [block_cases(run["cases"], mode) for run in (smaller, full)]
    if blocks[0] != blocks[1]:  # the blocks in flight differ: their memory is not the cases'
        met = f"not judged (blocks of {blocks[0]:,} and {blocks[1]:,} cases)"
    line = (f"   {name:<15} {mode:<8} {full['cases']:>8,} cases: peak {full['main_mib']:7.1f} MiB "
            f"({full['main_mib'] * 2**20 / full['cases']:6.0f} B/case all told; {smaller['cases']:,} cases: "
            f"{smaller['main_mib']:.1f} MiB); grows {grow:6.0f} B per case, documented <= {documented:.0f}: {met}")
    if reference:
        line += f"; {grow / reference:.1f}x the reference" if reference > 0 else ""
    if mode == "workers":
        tree = per_case(full, smaller, "tree_mib")
        judged = met if blocks[0] != blocks[1] else "PASS" if tree <= documented else "MISS"
        line += (f"; process tree (PSS, {full['processes']} processes) {full['tree_mib']:.1f} MiB, grows "
                 f"{tree:.0f} B per case: {judged}")
    say(line + f"; {full['seconds']:.0f} s")
    return grow


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agb", type=int, default=None, help="AGB values (default 500; --quick 150)")
    parser.add_argument("--quick", action="store_true", help="150 AGB values: a smoke run")
    parser.add_argument("--variants", default=None,
                        help=f"comma-separated variants (default all: {', '.join(VARIANTS)})")
    parser.add_argument("--make-journal", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.make_journal:
        make_journal(*args.make_journal)
        return
    from e2esim.limits import MEMORY_PER_CASE_BYTES

    agb = args.agb or (150 if args.quick else 500)
    chosen = args.variants or ",".join(v for v in VARIANTS if not (args.quick and v == "tradeoff_curve"))
    names = [v for v in chosen.split(",") if v]
    unknown = sorted(set(names) - set(VARIANTS))
    if unknown:
        raise SystemExit(f"unknown variants {unknown}; known: {', '.join(VARIANTS)}")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    say(f"machine: {os.cpu_count()} cores, load average {load:.2f} at the start")
    say(f"memory per case of e2esim run, main process (ru_maxrss): {agb} AGB x 20 crosstalk x {SPREADS[1]} "
        f"Faraday-rotation spreads against {SPREADS[0]} spreads; documented: <= {MEMORY_PER_CASE_BYTES} bytes per "
        "case (e2esim.limits.MEMORY_PER_CASE_BYTES)")
    reference = None
    with tempfile.TemporaryDirectory() as tmp:
        for name in (["minimal"] if "minimal" in names else []) + [n for n in names if n != "minimal"]:
            modes = ("serial", "workers", "resume") if name == "realistic" else ("serial",)
            for mode in modes:
                runs = [run_variant(variant(name, a, spreads), Path(tmp) / f"{name}-{mode}-{spreads}", mode)
                        for a, spreads in sizes(name, agb)]
                grow = figure(name, mode, runs[1], runs[0], MEMORY_PER_CASE_BYTES,
                              None if name == "minimal" else reference)
                if name == "minimal":
                    reference = grow
    if reference is not None:
        say("   (reference: the minimal chain, serial, measured first in this run)")


if __name__ == "__main__":
    main()
