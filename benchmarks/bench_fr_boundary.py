"""The cost of one row of the Faraday-rotation bias x SD boundary (issue 23, item 7) and of the stack scenarios.

Prints, in one run (CPU seconds of this process, so that the load of a shared machine counts less, and wall
seconds; the load average first):

1. one row of the boundary of ``calibration.0.bias_deg`` x ``calibration.0.sd_deg`` of
   scenarios/biomass_fr_requirement.yaml: ``Evaluator.grid_margins`` at ``--points`` (bias, SD) points over the
   scenario's 2 cases (dawn, dusk), divided by the rows (cases x points). Every (bias, SD) gives new residual
   nodes; the kernel's coefficients in the residual (``e2esim.stack.residual_fourier``) are built by the first
   call (outside the timing) and shared by every later row through the Evaluator's memo, so the figure times the
   rows of a solve, plus those builds (printed first), is its cost (a 100-point boundary is about 2,000 rows);
2. the kernel alone (``stack.channel_forms.channel_node_polynomials`` at one row's nodes: 133 Faraday-rotation
   nodes x 17 residual nodes, 3 passes), with and without the issue-12 expansion at those nodes;
3. with ``--scenarios``, the wall and CPU seconds of ``e2esim run`` of biomass_ground_cancelled and
   biomass_ground_cancelled_tomographic (in this process, plots included).

Run the same script on the code before a change for the reference (it reads only public functions). Nothing here
asserts a time. Run with ``python benchmarks/bench_fr_boundary.py [--points 4] [--scenarios]``.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from e2esim.api import load_scenario
from e2esim.flowdown.evaluate import Evaluator
from e2esim.flowdown.keys import solve_key

ROOT = Path(__file__).resolve().parents[1]
KEYS = ("calibration.0.bias_deg", "calibration.0.sd_deg")


def timed(fn):
    """(result, wall s, CPU s of this process)."""
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w, time.process_time() - c


def boundary_rows(points: int) -> None:
    loaded = load_scenario(str(ROOT / "scenarios" / "biomass_fr_requirement.yaml"))
    resolved = loaded.resolve()
    evaluator = Evaluator(loaded, resolved, tuple(solve_key(resolved, k) for k in KEYS))
    grid = np.stack([np.linspace(0.0, 10.0, points), np.linspace(2.0, 12.0, points)], 1)
    _, wall, cpu = timed(lambda: evaluator.grid_margins(grid[:1] + 0.5))  # the geometry and the coefficients once
    print(f"1. the first row of each case (geometry, climatology, the residual coefficients): {cpu:.2f} s CPU "
          f"({wall:.2f} s wall)")
    _, wall, cpu = timed(lambda: evaluator.grid_margins(grid))
    rows = evaluator.n * points
    print(f"1. FR bias x SD boundary: {rows} rows ({evaluator.n} cases x {points} points) in {wall:.2f} s wall, "
          f"{cpu:.2f} s CPU: {cpu / rows:.3f} s CPU per row ({wall / rows:.3f} s wall); a 100-point boundary of "
          f"about 2,000 rows: about {cpu / rows * 2000 / 60:.0f} min CPU")


def kernel_alone() -> None:
    from e2esim.distortion.expansion import expansion
    from e2esim.stack import channel_forms, joint_moments

    captured = []
    original = joint_moments.channel_node_polynomials

    def capture(*inputs):
        captured.append(inputs)
        return original(*inputs)

    joint_moments.channel_node_polynomials = capture
    try:
        loaded = load_scenario(str(ROOT / "scenarios" / "biomass_fr_requirement.yaml"))
        resolved = loaded.resolve()
        evaluator = Evaluator(loaded, resolved, tuple(solve_key(resolved, k) for k in KEYS))
        if hasattr(evaluator, "memo"):  # node by node, as a plain run: the kernel at one row's nodes is captured
            evaluator.memo.repeated_geometry = False
        evaluator.grid_margins(np.array([[1.0, 3.0]]))
    finally:
        joint_moments.channel_node_polynomials = original
    inputs = max(captured, key=lambda a: a[2].shape[0])
    _, wall, cpu = timed(lambda: expansion(inputs[2], inputs[3]))
    print(f"2. at {inputs[2].shape[0]} nodes x {inputs[2].shape[1]} passes: the expansion {cpu:.3f} s CPU "
          f"({wall:.3f} s wall)", end="; ")
    channel_forms.channel_node_polynomials(*inputs)  # the expansion cached: the kernel's own work below
    _, wall, cpu = timed(lambda: channel_forms.channel_node_polynomials(*inputs))
    print(f"the kernel {cpu:.3f} s CPU ({wall:.3f} s wall)")


def scenarios() -> None:
    from e2esim.cli import main as cli

    for name in ("biomass_ground_cancelled", "biomass_ground_cancelled_tomographic"):
        with tempfile.TemporaryDirectory() as folder:
            _, wall, cpu = timed(lambda: cli(["run", str(ROOT / "scenarios" / f"{name}.yaml"), "-o", folder,
                                              "--force"]))
        print(f"3. e2esim run {name}: {wall:.1f} s wall, {cpu:.1f} s CPU of this process (plots drawn in "
              "processes of their own are not in the CPU figure)")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--points", type=int, default=4)
    parser.add_argument("--scenarios", action="store_true")
    args = parser.parse_args()
    print(f"load average (1 min): {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    kernel_alone()
    boundary_rows(args.points)
    if args.scenarios:
        scenarios()
