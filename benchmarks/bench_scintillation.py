"""Speed of the scintillation IRF statistics (issue "Scintillation, RFI", Speed).

Prints, in one run:
1. the Monte Carlo of the azimuth compression for one BIOMASS geometry with 200 screen realisations (target
   <= 0.5 s), and the same statistics from the weak-scatter theory for that geometry (the reference is the Monte
   Carlo: both are printed side by side);
2. the analytic path vectorised over 10 000 cases (incidence and C_kL varied; target <= 1 ms per case).
Run with ``python benchmarks/bench_scintillation.py`` (``--quick`` for a smoke run).
"""

from __future__ import annotations

import os
import sys
import time

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


if __name__ == "__main__":
    main("--quick" in sys.argv)
