"""End-to-end speed through the command line (issues "End to end" and 14), every figure from repeated runs.

Prints, in one run:

1. start-up: ``e2esim validate`` on the default scenario (imports, scenario resolution; target <= 1 s), against
   the floor of any command: the interpreter starting and importing numpy;
2. the default scenario end to end, with a cold array cache (the IRI climatology computed) and with a warm one
   (target <= 8 s on 2 cores, warm), against the reference: the same run through the per-case runner
   (``--per-case``), warm;
3. an analytic sweep of 10,000 cases, serially and on 2 local worker processes: the fixed cost (a one-case run
   of the same scenario: start-up, outputs) and the cost per case beyond it, ``(t_N - t_1) / (N - 1)``;
4. a Monte Carlo sweep (12 cases of 10^6 realisations, samples not stored) on 1 and on 2 local workers, and
   the speed-up of the per-case part (target >= 1.6x).

The million-case sweep and the global map against the per-case runner are in benchmarks/bench_sweeps.py.

Start-up is measured as an installed package starts: from compiled bytecode. ``pip install`` compiles it, and
Python writes it on a first import, but not where ``PYTHONDONTWRITEBYTECODE`` is set (some CI and sandboxes);
there every start would compile e2esim's sources again (about 0.5 s), so the benchmark compiles them first
(``compileall``, as pip does) and says so.

Every figure is the best and the median of ``--repeats`` runs (default 3). The runs use their own array cache
(``E2ESIM_CACHE`` in a temporary folder), never the user's: the first default-scenario run starts from an
empty cache (cold), the others reuse what it stored (warm). The machine's load is printed first: on a shared
machine, compare figures taken in the same run only.

Run with ``python benchmarks/bench_end_to_end.py`` (``--quick``: smaller sweeps, one repeat of each;
``--default-only``: figures 1 and 2 only).
"""

from __future__ import annotations

import argparse
import compileall
import importlib.util
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ROOT / "scenarios" / "biomass_default.yaml"
TARGET_DEFAULT_S = 8.0
TARGET_VALIDATE_S = 1.0
TARGET_MC_SPEEDUP = 1.6

ANALYTIC_SWEEP = """
name: analytic_sweep
scene: {type: forest_agb_model, biome: boreal}
instrument: {type: biomass}
ionosphere: {type: gaussian_faraday, mean_deg: 60, sd_deg: 5}
requirements: [{type: agb_error_bound}, {type: agb_rmse}]
simulation: {mode: analytic}
sweep:
  parameters:
    scene.agb_t_ha: {linspace: [20, 400, N_AGB]}
    instrument.crosstalk.level_db: {linspace: [-40, -20, N_XT]}
    instrument.channel_imbalance.level_db: {linspace: [-40, -25, N_XT]}
output: {plots: [verdicts]}
"""

MC_SWEEP = """
name: mc_sweep
scene: {type: forest_agb_model, biome: boreal}
instrument: {type: biomass}
ionosphere: {type: gaussian_faraday, mean_deg: 60, sd_deg: 5}
requirements: [{type: agb_error_bound}]
simulation: {mode: montecarlo, looks: 100000, realisations: 1000000, keep_samples: false}
sweep:
  parameters:
    scene.agb_t_ha: {linspace: [50, 350, N_AGB]}
    instrument.crosstalk.level_db: XT
output: {plots: [verdicts]}
"""


class Runner:
    """Runs the command line with the benchmark's own array cache."""

    def __init__(self, folder: Path, repeats: int):
        self.folder = folder
        self.repeats = repeats
        self.env = {**os.environ, "E2ESIM_CACHE": str(folder / "cache")}

    def once(self, *args) -> float:
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "e2esim", *map(str, args)], capture_output=True, text=True,
                              cwd=ROOT, env=self.env)
        elapsed = time.perf_counter() - t0
        if proc.returncode != 0:
            raise SystemExit(f"e2esim {' '.join(map(str, args))} failed:\n{proc.stderr}")
        return elapsed

    def run(self, scenario: Path, out: str, *extra) -> float:
        return self.once("run", scenario, "-o", self.folder / out, "--force", "--no-progress", *extra)

    def repeat(self, fn, repeats: int | None = None) -> list:
        return [fn() for _ in range(repeats or self.repeats)]


def summary(times: list) -> str:
    """Best and median of repeated wall-clock times."""
    if len(times) == 1:
        return f"{times[0]:.2f} s (1 run)"
    return f"best {min(times):.2f} s, median {statistics.median(times):.2f} s ({len(times)} runs)"


def verdict(seconds: float, target: float) -> str:
    return f"target <= {target:g} s: {'met' if seconds <= target else 'NOT met'}"


def compile_bytecode() -> None:
    """Compile e2esim's sources to bytecode, as ``pip install`` does (see the module docstring)."""
    package = Path(importlib.util.find_spec("e2esim").origin).parent
    compileall.compile_dir(package, quiet=1)
    written = "" if not os.environ.get("PYTHONDONTWRITEBYTECODE") else " (PYTHONDONTWRITEBYTECODE is set here)"
    print(f"bytecode of {package} compiled first, as an installation does{written}")


def interpreter_with_numpy(runner: Runner) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import numpy"], check=True, env=runner.env)
    return time.perf_counter() - t0


def startup_and_default(runner: Runner) -> None:
    validate = runner.repeat(lambda: runner.once("validate", DEFAULT), max(runner.repeats, 5))
    floor = runner.repeat(lambda: interpreter_with_numpy(runner), max(runner.repeats, 5))
    print(f"1. start-up, e2esim validate {DEFAULT.name}: {summary(validate)}; "
          f"{verdict(min(validate), TARGET_VALIDATE_S)}")
    print(f"   the floor, python -c 'import numpy': {summary(floor)}")
    cold = runner.run(DEFAULT, "default")  # the benchmark's cache is empty: the IRI climatology is computed
    warm = runner.repeat(lambda: runner.run(DEFAULT, "default"))
    per_case = runner.repeat(lambda: runner.run(DEFAULT, "default_per_case", "--per-case"))
    print(f"2. default scenario end to end, warm cache: {summary(warm)}; {verdict(min(warm), TARGET_DEFAULT_S)}")
    print(f"   reference, the per-case runner (--per-case), warm: {summary(per_case)}; the batched run takes "
          f"{min(warm) / min(per_case):.2f}x its time (a Monte Carlo scenario of 5 cases: the Monte Carlo, the "
          "calibration and the plots dominate both)")
    print(f"   cold cache (first run, IRI climatology computed and stored): {cold:.2f} s (1 run)")


def write(runner: Runner, name: str, text: str) -> Path:
    path = runner.folder / name
    path.write_text(text)
    return path


def analytic_sweep(runner: Runner, quick: bool) -> None:
    n_agb, n_xt = (5 if quick else 25), 20
    big = write(runner, "a.yaml", ANALYTIC_SWEEP.replace("N_AGB", str(n_agb)).replace("N_XT", str(n_xt)))
    one = write(runner, "a1.yaml", ANALYTIC_SWEEP.replace("N_AGB", "1").replace("N_XT", "1"))
    n = n_agb * n_xt * n_xt
    fixed = runner.repeat(lambda: runner.run(one, "a_one"))
    serial = runner.repeat(lambda: runner.run(big, "a_serial"))
    workers = runner.repeat(lambda: runner.run(big, "a_workers", "--workers", "2"))
    per_case = (min(serial) - min(fixed)) / (n - 1)
    print(f"3. analytic sweep of {n} cases: serial {summary(serial)}; on 2 workers {summary(workers)}")
    print(f"   fixed cost (the same scenario with one case: start-up, outputs): {summary(fixed)}")
    print(f"   per case beyond it, serially: {per_case * 1e3:.2f} ms "
          f"(best of the sweep minus best of the one-case run, over {n - 1} cases)")


def monte_carlo_sweep(runner: Runner, quick: bool) -> None:
    n_agb = 3 if quick else 6
    big = write(runner, "m.yaml", MC_SWEEP.replace("N_AGB", str(n_agb)).replace("XT", "[-32, -28]"))
    one = write(runner, "m1.yaml", MC_SWEEP.replace("N_AGB", "1").replace("XT", "[-32]"))
    n = 2 * n_agb
    fixed = min(runner.repeat(lambda: runner.run(one, "m_one")))
    one_worker = runner.repeat(lambda: runner.run(big, "m1", "--workers", "1"))
    two_workers = runner.repeat(lambda: runner.run(big, "m2", "--workers", "2"))
    speedup = (min(one_worker) - fixed) / (min(two_workers) - fixed)
    print(f"4. Monte Carlo sweep of {n} cases: 1 worker {summary(one_worker)}; 2 workers {summary(two_workers)}")
    print(f"   speed-up of the per-case part (best times minus the one-case run, {fixed:.2f} s): {speedup:.2f}x "
          f"(target >= {TARGET_MC_SPEEDUP:g}x: {'met' if speedup >= TARGET_MC_SPEEDUP else 'NOT met'}); "
          f"of the whole runs {min(one_worker) / min(two_workers):.2f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller sweeps, one run of each")
    parser.add_argument("--repeats", type=int, default=None, help="runs per figure (default 3; --quick: 1)")
    parser.add_argument("--default-only", action="store_true", help="only the start-up and default-scenario figures")
    args = parser.parse_args()
    repeats = args.repeats or (1 if args.quick else 3)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"machine: {os.cpu_count()} cores, load average {load:.2f} at the start")
    compile_bytecode()
    with tempfile.TemporaryDirectory() as tmp:
        runner = Runner(Path(tmp), repeats)
        startup_and_default(runner)
        if args.default_only:
            return
        analytic_sweep(runner, args.quick)
        monte_carlo_sweep(runner, args.quick)


if __name__ == "__main__":
    main()
