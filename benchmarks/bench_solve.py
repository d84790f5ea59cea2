"""The inverse solve (issue 23, "Speed"): ``e2esim solve`` against the brute-force sweep that gives the same answer,
measured in the same run.

Prints, for an analytic scenario of 1,000 cases (50 AGB values x 20 Faraday-rotation spreads over a boreal
forest, the HV error of Men et al. (2021) with the random-error budget of the 200 m product; the +-20 % bound at
99.865 % and the 20 % RMSE):

1. a one-parameter solve of the crosstalk (``instrument.crosstalk.level_db`` in [-40, -20] dB) for the worst case
   over the 1,000 cases (target <= 2 s), and for every case; the brute-force reference sweeps the crosstalk over a
   grid with the solve's accuracy (0.01 dB: 2,001 values x 1,000 cases, one batched run of the engine) and takes
   the largest value where every case passes, and where each case passes; the worst-case answer and every case's
   answer of the per-case solve must agree with it to 0.01 dB (the script stops, AssertionError, if they do not);
2. the boundary of crosstalk and channel imbalance (100 points, imbalance in [-45, -15] dB) over the worst case of
   the 1,000 cases (target <= 10 s); the brute-force reference sweeps the imbalance at 0.01 dB (3,001 values) at
   ``--brute-points`` of the 100 points (default 3: the full grid would be 3 x 10^8 cases), checks them against
   the solve's boundary there (every requirement in every case: where one requirement is met by no value, no
   value) and is scaled to 100 points.

Nothing here asserts a time. The machine's load is printed first and last: on a shared machine compare figures of
the same run only. Both paths run the engine serially (one process; numpy may use a second thread); each figure is
the wall-clock time and the CPU time of the process (all its threads). The target is stated for two cores.
Run with ``python benchmarks/bench_solve.py`` (``--quick``: 200 cases, 0.1 dB grids: a smoke run).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import e2esim
from e2esim.api import load_scenario
from e2esim.flowdown.evaluate import Evaluator
from e2esim.flowdown.keys import solve_key

XT, CI = "instrument.crosstalk.level_db", "instrument.channel_imbalance.level_db"


def scenario(agb_values: int) -> dict:
    return {
        "name": "bench_solve",
        "scene": {"type": "forest_agb_model", "biome": "boreal"},
        "instrument": {"type": "biomass"},
        "ionosphere": {"type": "gaussian_faraday", "mean_deg": 5, "sd_deg": 5},
        "propagation": [{"type": "hv_backscatter_error"},
                        {"type": "backscatter_error_budget", "preset": "biomass_200m"}],
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_error_bound", "sources": "systematic", "bound_percent": 20,
                          "confidence_percent": 99.865},
                         {"type": "agb_rmse", "max_percent": 40}],
        "simulation": {"mode": "analytic", "seed": 1},
        "sweep": {"parameters": {"scene.agb_t_ha": {"linspace": [50, 400, agb_values]},
                                 "ionosphere.sd_deg": {"linspace": [1, 20, 20]}}},
    }


CPU = {"wall": 0.0, "cpu": 0.0}


def timed(f):
    """(f(), wall seconds); the process's CPU seconds of the call (all its threads) are left in ``CPU``."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = f()
    CPU["wall"], CPU["cpu"] = time.perf_counter() - t0, time.process_time() - c0
    return out, CPU["wall"]


def cpu_words() -> str:
    return f"{CPU['cpu']:.2f} s CPU"


def load_words() -> str:
    one, five, fifteen = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return f"load average {one:.2f}, {five:.2f}, {fifteen:.2f} (1, 5, 15 min) on {os.cpu_count()} CPUs"


def brute_limits(raw, keys, grid, fixed=None) -> tuple:
    """By one sweep over the grid of the last key: the largest grid value where every case meets each requirement
    (the worst case; NaN where none), per requirement, and the largest where each case does, (R, n)."""
    loaded = load_scenario(raw)
    resolved = loaded.resolve()
    evaluator = Evaluator(loaded, resolved, tuple(solve_key(resolved, k) for k in keys))
    points = grid[:, None] if fixed is None else np.stack([np.full(grid.size, fixed), grid], 1)
    m = evaluator.grid_margins(points)  # (R, n, G)
    passes = np.where(np.isnan(m), np.inf, m) >= 0  # (R, n, G)
    ok = np.all(passes, axis=1)  # (R, G)
    per_case = np.where(passes.any(axis=2), np.max(np.where(passes, grid, -np.inf), axis=2), np.nan)
    return [float(grid[row].max()) if row.any() else float("nan") for row in ok], per_case, evaluator.rows


def check_every_case(every, per_case, step: float) -> int:
    """How many case answers of the per-case solve the brute-force sweep confirms (every one, or AssertionError):
    "met at" v: the largest passing grid value lies in [v - step, v]; "every value meets it": the top of the range;
    "no value meets it": none passes."""
    checked = 0
    for answer, brute in zip(every.answers, per_case):
        for state, value, limit in zip(answer.state, answer.value, brute):
            if state == "met at":
                assert value - step - 1e-9 <= limit <= value + 1e-9, ("case answers disagree", value, limit)
            elif state == "every value meets it":
                assert limit == -20.0, ("case answers disagree", state, limit)
            elif state == "no value meets it":
                assert np.isnan(limit), ("case answers disagree", state, limit)
            checked += 1
    return checked


def main(quick: bool, brute_points: int) -> None:
    print(f"start: {load_words()}; one process (its CPU seconds are printed beside the wall-clock seconds)")
    agb_values = 10 if quick else 50
    step = 0.1 if quick else 0.01
    raw = scenario(agb_values)
    n = agb_values * 20
    print(f"1. one-parameter solve of {XT} over {n} cases")
    worst, t_worst = timed(lambda: e2esim.solve(raw, XT, bounds=(-40, -20), worst_case=True))
    cpu_worst = cpu_words()
    every, t_every = timed(lambda: e2esim.solve(raw, XT, bounds=(-40, -20)))
    cpu_every = cpu_words()
    grid = np.round(np.arange(-40, -20 + step / 2, step), 6)
    (limits, per_case, rows), t_brute = timed(lambda: brute_limits(raw, [XT], grid))
    cpu_brute = cpu_words()
    for answer, limit in zip(worst.answers, limits):
        states = set(answer.state)
        if np.isfinite(answer.limit):
            print(f"   {answer.requirement}: solve {answer.limit:.4f} dB, brute force {limit:.2f} dB")
            assert answer.limit - step <= limit <= answer.limit + 1e-9, "the brute-force sweep and the solve disagree"
        else:
            print(f"   {answer.requirement}: solve: {', '.join(states)}; brute force: largest passing value {limit}")
            expected = {"every value meets it": -20.0, "no value meets it": float("nan")}.get(next(iter(states)))
            assert len(states) == 1 and (limit == expected or (np.isnan(limit) and np.isnan(expected)))
    confirmed = check_every_case(every, per_case, step)
    print(f"   the per-case solve's {confirmed} case answers agree with the brute-force sweep's, case by case")
    print(f"   worst case: {t_worst:.2f} s, {cpu_worst} ({worst.calls} engine runs, {worst.rows} rows; target <= 2 s)")
    print(f"   every case: {t_every:.2f} s, {cpu_every} ({every.calls} runs, {every.rows} rows; target <= 2 s)")
    print(f"   brute force at {step} dB: {t_brute:.2f} s, {cpu_brute} ({rows} cases): {t_brute / t_worst:.0f}x the "
          f"worst-case solve, {t_brute / t_every:.0f}x the per-case solve")

    points = 20 if quick else 100
    print(f"2. boundary of {XT} and {CI}: {points} points over the worst case of {n} cases")
    found, t_boundary = timed(lambda: e2esim.solve(raw, [XT, CI], bounds=[(-40, -20), (-45, -15)], points=points))
    print(f"   {t_boundary:.2f} s, {cpu_words()} ({found.calls} engine runs, {found.rows} rows; target <= 10 s)")
    grid = np.round(np.arange(-45, -15 + step / 2, step), 6)
    picks = np.linspace(0, points - 1, brute_points).round().astype(int)
    t_total = 0.0
    for p in picks:
        (limits, _, _), t = timed(lambda p=p: brute_limits(raw, [XT, CI], grid, fixed=found.x[p]))
        t_total += t
        # every requirement in every case: a requirement that no grid value meets leaves none (NaN)
        limit = float("nan") if np.any(np.isnan(limits)) else min(limits)
        print(f"   {XT} = {found.x[p]:.2f}: solve {found.y[p]:.4f} dB ({found.state[p]}), brute force {limit:.2f} dB")
        if found.state[p] == "met at":
            assert found.y[p] - step <= limit <= found.y[p] + 1e-9, "the brute-force sweep and the solve disagree"
        else:
            expected = {"every value meets it": -15.0, "no value meets it": float("nan")}[found.state[p]]
            assert limit == expected or (np.isnan(limit) and np.isnan(expected)), "the sweep and the solve disagree"
    scaled = t_total / len(picks) * points
    print(f"   brute force at {step} dB: {t_total:.2f} s for {len(picks)} points, {scaled:.1f} s scaled to {points}: "
          f"{scaled / t_boundary:.0f}x the boundary solve")
    print(f"end: {load_words()}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--brute-points", type=int, default=3)
    args = parser.parse_args()
    main(args.quick, args.brute_points)
