"""Speed of the scintillation IRF statistics (issue "Scintillation, RFI", Speed).

Prints, in one run:
1. the Monte Carlo of the azimuth compression for one BIOMASS geometry with 200 screen realisations (target
   <= 0.5 s), and the same statistics from the weak-scatter theory for that geometry (the reference is the Monte
   Carlo: both are printed side by side);
2. the analytic path vectorised over 10 000 cases (incidence and C_kL varied; target <= 1 ms per case);
3. the global map with scintillation and RFI (scenarios/biomass_global_map_scintillation_rfi.yaml at 1 deg, the full
   map; target <= 60 s on two cores): after a warm-up run (the month's climatology table), the batched engine
   (error terms in blocks) on a 1 deg region (one month, both passes and solar levels) and, as its reference in the
   same run, the per-case engine on a part of that region, each in one process; each as seconds per case (the run of the
   resolved scenario, no outputs written, no products kept: the full map's run keeps none), in wall-clock and CPU
   seconds, extrapolated to the full map's case count (counted from the resolved scenario) over two cores and
   printed as such: an estimate, not a measurement of the full map;
4. with ``--end-to-end`` (or ``--full-map``) instead of figure 3: the 1 deg map with scintillation and RFI measured
   end to end, outputs included, on two workers, next to the 60 s target, with the same map without the error terms
   as its reference in the same run (``end_to_end_map``; with ``--quick`` a region, not the whole map).
Run with ``python benchmarks/bench_scintillation.py`` (``--quick`` for a smoke run; ``--skip-map`` leaves figures 3
and 4 out).
"""

from __future__ import annotations

import copy
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets say

import numpy as np

from e2esim.scintillation.aperture import biomass_aperture, two_way_structure
from e2esim.scintillation.irf import monte_carlo_irf
from e2esim.scintillation.irf_analytic import analytic_irf


def best_of(repeats, call):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = call()
        times.append(time.perf_counter() - start)
    return min(times), result


def main(quick: bool = False) -> None:
    aperture = biomass_aperture(np.radians(28.0))
    c_kl = 10.0 ** 23.6

    def structure(lag):
        return two_way_structure(lag, aperture, c_kl, 2.67, 10e3)

    rng = np.random.default_rng(1)
    seconds, mc = best_of(3, lambda: monte_carlo_irf(rng, structure, 200))
    _, an = best_of(1, lambda: analytic_irf(structure))
    print(f"Monte Carlo, 200 realisations, one geometry: {seconds:.3f} s (target <= 0.5 s)")
    print(f"{'metric':<22}{'MC median':>12}{'theory':>10}{'MC p90':>10}{'theory':>10}")
    for name in ("peak_loss_db", "resolution_ratio", "shift_cells", "islr_db"):
        print(f"{name:<22}{mc[name + '_median']:>12.4f}{float(an[name + '_median']):>10.4f}"
              f"{mc[name + '_p90']:>10.4f}{float(an[name + '_p90']):>10.4f}")
    cases = 1000 if quick else 10_000
    incidence = np.radians(np.linspace(23.0, 33.75, cases))
    strengths = 10.0 ** np.linspace(22.5, 25.0, cases)
    block = biomass_aperture(incidence)
    seconds, _ = best_of(3, lambda: analytic_irf(lambda lag: two_way_structure(lag, block, strengths, 2.67, 10e3)))
    print(f"analytic path, {cases} cases: {seconds:.3f} s, {1e3 * seconds / cases:.3f} ms per case "
          "(target <= 1 ms)")


SCINTILLATION_MAP = Path(__file__).resolve().parents[1] / "scenarios" / "biomass_global_map_scintillation_rfi.yaml"


def map_scenario(step_deg: float = 1.0, lat=None, lon=None, months=None) -> dict:
    """The scintillation/RFI map at ``step_deg``, over a region and months when given."""
    import yaml

    data = yaml.safe_load(SCINTILLATION_MAP.read_text())
    data["sweep"]["map"]["step_deg"] = step_deg
    data["ionosphere"]["grid_step_deg"] = step_deg
    data["output"] = {"plots": ["map_fraction"]}
    if lat is not None:
        data["sweep"]["map"]["lat_range_deg"], data["sweep"]["map"]["lon_range_deg"] = list(lat), list(lon)
    if months is not None:
        data["sweep"]["map"]["months"] = list(months)
    return data


def map_figures(quick: bool, full: bool) -> None:
    """Figure 3 (module docstring)."""
    from e2esim import api
    from e2esim.runner.run import run_scenario
    from e2esim.runner.scenario import Scenario

    if full:
        end_to_end_map(quick)
        return
    full_cases = len(Scenario(map_scenario(), str(SCINTILLATION_MAP)).resolve().cases)
    region = ((-4, 4), (14, 26)) if quick else ((-6, 6), (10, 34))
    part = ((-2, 2), (18, 22))
    api.run(map_scenario(1.0, (-1, 1), (20, 22), [3]))  # warm-up: the month's climatology table, imports
    figures = {}
    for engine, (lat, lon) in (("batched", region), ("per_case", part)):
        data = map_scenario(1.0, lat, lon, [3])
        resolved = Scenario(copy.deepcopy(data), str(SCINTILLATION_MAP)).resolve()
        start, cpu_start = time.perf_counter(), time.process_time()
        run_scenario(resolved, progress=False, engine=engine, keep_products=False)  # as the full map (> 2000 cases)
        seconds, cpu = time.perf_counter() - start, time.process_time() - cpu_start
        figures[engine] = (len(resolved.cases), seconds, cpu)
        print(f"scintillation/RFI map, 1 deg region lat {lat} lon {lon}, March, {engine} engine, one process: "
              f"{len(resolved.cases)} cases in {seconds:.1f} s ({cpu:.1f} s CPU), "
              f"{1e3 * seconds / len(resolved.cases):.2f} ms per case ({1e3 * cpu / len(resolved.cases):.2f} ms CPU) "
              f"(load average {os.getloadavg()[0]:.1f})")
    per_case = {k: s / n for k, (n, s, _) in figures.items()}
    cpu_per_case = {k: c / n for k, (n, _, c) in figures.items()}
    full = {k: v * full_cases / 2 for k, v in per_case.items()}
    print(f"full 1 deg map: {full_cases} cases; extrapolated from the seconds per case above over two cores (an "
          f"estimate): batched {full['batched']:.0f} s (target <= 60 s: {'PASS' if full['batched'] <= 60 else 'MISS'}),"
          f" per-case reference {full['per_case']:.0f} s; speed-up per case "
          f"{per_case['per_case'] / per_case['batched']:.1f}x")
    print(f"  from the CPU seconds per case (less sensitive to the machine's load): batched "
          f"{cpu_per_case['batched'] * full_cases:.0f} s CPU, {cpu_per_case['batched'] * full_cases / 2:.0f} s over "
          f"two idle cores; per-case reference {cpu_per_case['per_case'] * full_cases:.0f} s CPU")

END_TO_END_REGION = ((-4, 4), (-66, -58))
"""The region of ``--end-to-end --quick``: 1 deg cells of the central Amazon, every month, pass and solar level."""


def end_to_end_map(quick: bool) -> None:
    """Figure 4: the 1 deg map with scintillation and RFI end to end (``e2esim.run`` into a folder: the run and every
    output, results.nc, summary.json, the report and its plots, as the shipped scenario asks them), on two worker
    processes, next to the 60 s target; as its reference in the same run, the same map without the error terms (the
    map's own chain), run first, so that the month climatology tables are in the array cache for both. ``quick``: a
    region (``END_TO_END_REGION``), not the whole map, whose time is not comparable with the target."""
    import tempfile

    from e2esim import api

    lat, lon = END_TO_END_REGION if quick else (None, None)
    where = f"region lat {lat} lon {lon}" if quick else "the whole map"
    times = {}
    for name in ("without error terms (reference)", "with scintillation and RFI"):
        data = map_scenario(1.0, lat, lon)
        data["output"] = {"plots": ["global_maps", "map_fraction"]}  # the shipped scenario's outputs
        if name.startswith("without"):
            data["error_terms"] = []
        with tempfile.TemporaryDirectory() as folder:
            before, start = os.times(), time.perf_counter()
            results = api.run(data, output=Path(folder) / "run", workers=2)
            seconds, after = time.perf_counter() - start, os.times()
        cpu = sum(after[:4]) - sum(before[:4])  # this process and its workers, user and system
        times[name] = seconds
        print(f"1 deg map {name}, {where}, {results.n_cases} cases, end to end (outputs included), 2 workers: "
              f"{seconds:.1f} s wall, {cpu:.1f} s CPU (load average {os.getloadavg()[0]:.1f})")
    seconds = times["with scintillation and RFI"]
    target = "" if quick else f" (target <= 60 s: {'PASS' if seconds <= 60 else 'MISS'})"
    print(f"  with scintillation and RFI: {seconds:.1f} s{target}; the map without them "
          f"{times['without error terms (reference)']:.1f} s in the same run")


if __name__ == "__main__":
    main("--quick" in sys.argv)
    if "--skip-map" not in sys.argv:
        map_figures("--quick" in sys.argv, "--end-to-end" in sys.argv or "--full-map" in sys.argv)
