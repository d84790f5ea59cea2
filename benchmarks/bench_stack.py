"""Speed of the multi-pass (ground-cancelled) error computations (issue "Interferometric stacks").

Prints, in one run, against a fair reference computed in the same run:
1. the analytic moments of one case of the 3-pass ground-cancelled chain (BIOMASS interferometric stack, boreal
   forest, system errors at the specification with correlation 0.5 between passes, a gain error, Faraday rotation
   60 +- 5 deg and a 7 deg difference between passes): a new error model each time, so nothing is cached;
   reference: the single-pass moments of Men et al. (2021) (``HVErrorModel``) of the same forest. Target <= 5 ms.
   Also the whole case as the chain asks it (moments, contributions, every source removed, cancellation residual);
2. its exact Monte Carlo at M = 10000 (L = 100000, one scene, all three channels); reference: the single-pass fast
   Monte Carlo at the same sizes. Target <= 1 s.
Run with ``make benchmark`` or ``python benchmarks/bench_stack.py``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets say
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from bench_crosspol import best_of

from e2esim.distortion.error_model import HVErrorModel
from e2esim.distortion.montecarlo import simulate
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.table1 import TABLE1_FORESTS
from e2esim.stack.acquisitions import preset_stack
from e2esim.stack.combination import interpolated
from e2esim.stack.error_model import StackHVErrorModel
from e2esim.stack.faraday import StackFaraday
from e2esim.stack.montecarlo import simulate_stack
from e2esim.stack.scene import StackScene
from e2esim.stack.sites import SITES
from e2esim.stack.system import StackSystemErrors
from e2esim.stack.temporal import TemporalDecorrelation
from e2esim.units import variance_from_level_db

LOOKS, REALISATIONS = 100_000, 10_000


def case():
    biome, agb, hh, hv, vv, r, theta = TABLE1_FORESTS["boreal_200"]
    cov = ScatteringCovariance.from_powers(hh, hv, vv, r, np.radians(theta), agb_t_ha=agb, biome=biome)
    scene = StackScene(preset_stack("interferometric", np.radians(28.375)), cov, SITES["boreal"],
                       TemporalDecorrelation())
    system = SystemErrorModel(crosstalk_level=float(variance_from_level_db(-30, "three_sigma_amplitude")),
                              imbalance_level=float(variance_from_level_db(-34, "three_sigma_amplitude")),
                              noise_power=10 ** -2.7, gain_sd_db=0.1)
    fr = GaussianFaraday(np.radians(60.0), np.radians(5.0))
    return cov, scene, system, fr


def main() -> None:
    cov, scene, system, fr = case()
    errors = StackSystemErrors(system, 0.5)
    faraday = StackFaraday(fr, np.radians(7.0))
    comb = interpolated(scene.acquisitions.kz_rad_m)

    def model():  # everything a case builds, built again: nothing is cached between repetitions
        return StackHVErrorModel(scene, StackSystemErrors(system, 0.5), StackFaraday(fr, np.radians(7.0)),
                                 interpolated(scene.acquisitions.kz_rad_m), LOOKS, "scene")

    print("1. Analytic moments of one case of the 3-pass ground-cancelled chain")
    t_stack = best_of(lambda: model().current(), repeats=20)
    t_single = best_of(lambda: HVErrorModel(cov, system, fr, looks=LOOKS).current(), repeats=20)
    print(f"   3-pass ground cancelled: {t_stack * 1e3:6.2f} ms (target <= 5 ms); single pass (Men et al. 2021): "
          f"{t_single * 1e3:6.3f} ms; ratio {t_stack / t_single:5.1f}x")

    def whole_case():
        m = model()
        m.current()
        m.contributions()
        for source in m.sources:
            m.without(source).current()
        m.cancellation()

    t_whole = best_of(whole_case, repeats=5)
    print(f"   the whole case (moments, contributions, every source removed, cancellation residual): "
          f"{t_whole * 1e3:6.1f} ms")

    print(f"2. Exact Monte Carlo, L = {LOOKS}, M = {REALISATIONS}, all three channels")
    rng = np.random.default_rng(0)
    t_mc = best_of(lambda: simulate_stack(scene, errors, faraday, comb, rng, LOOKS, REALISATIONS), repeats=3)
    t_ref = best_of(lambda: simulate(cov, system, fr, rng, LOOKS, REALISATIONS), repeats=3)
    print(f"   3-pass ground cancelled: {t_mc:6.3f} s (target <= 1 s); single-pass fast Monte Carlo (HV): "
          f"{t_ref:6.3f} s; ratio {t_mc / t_ref:5.1f}x")


if __name__ == "__main__":
    main()
