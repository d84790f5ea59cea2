"""End-to-end speed (issue "End to end"): prints, in one run,

1. the default scenario through the command line, end to end (target < 30 s on 2 cores);
2. an analytic sweep of 10,000 cases, serially and on 2 local worker processes (target < 30 s);
3. a Monte Carlo sweep (12 cases of 10^6 realisations, samples not stored) on 1 and on 2 local workers, and
   the speed-up (target >= 1.6x).

Run with ``python benchmarks/bench_end_to_end.py`` (``--quick`` for a smoke run with smaller sweeps).
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

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
    instrument.crosstalk.level_db: {linspace: [-40, -20, 20]}
    instrument.channel_imbalance.level_db: {linspace: [-40, -25, 20]}
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
    instrument.crosstalk.level_db: [-32, -28]
output: {plots: [verdicts]}
"""


def timed_run(args) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "e2esim", "run", *args, "--force", "--no-progress"],
                          capture_output=True, text=True, cwd=ROOT)
    elapsed = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    return elapsed


def main(quick: bool = False) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        t = timed_run([str(ROOT / "scenarios" / "biomass_default.yaml"), "-o", str(tmp / "default")])
        print(f"1. default scenario end to end: {t:.1f} s (target < 30 s)")

        n_agb = 5 if quick else 25
        (tmp / "a.yaml").write_text(ANALYTIC_SWEEP.replace("N_AGB", str(n_agb)))
        n = n_agb * 400
        t1 = timed_run([str(tmp / "a.yaml"), "-o", str(tmp / "a1")])
        t2 = timed_run([str(tmp / "a.yaml"), "-o", str(tmp / "a2"), "--workers", "2"])
        print(f"2. analytic sweep of {n} cases: {t1:.1f} s serial, {t2:.1f} s on 2 workers "
              f"({t1 / n * 1e3:.2f} ms per case serially; target < 30 s)")

        (tmp / "m.yaml").write_text(MC_SWEEP.replace("N_AGB", "3" if quick else "6"))
        m1 = timed_run([str(tmp / "m.yaml"), "-o", str(tmp / "m1"), "--workers", "1"])
        m2 = timed_run([str(tmp / "m.yaml"), "-o", str(tmp / "m2"), "--workers", "2"])
        print(f"3. Monte Carlo sweep: {m1:.1f} s on 1 worker, {m2:.1f} s on 2 workers: speed-up {m1 / m2:.2f}x "
              "(target >= 1.6x)")


if __name__ == "__main__":
    main(quick="--quick" in sys.argv)
