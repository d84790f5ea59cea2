"""Speed of the multi-pass (ground-cancelled) error computations (issue "Interferometric stacks").

Prints, in one run, against a fair reference computed in the same run:
1. the analytic moments of one case of the 3-pass ground-cancelled chain (BIOMASS interferometric stack, boreal
   forest, system errors at the specification with correlation 0.5 between passes, a gain error, Faraday rotation
   60 +- 5 deg and a 7 deg difference between passes): a new error model each time, so nothing is cached;
   reference: the single-pass moments of Men et al. (2021) (``HVErrorModel``) of the same forest. Target <= 5 ms.
   Also the whole case as the chain asks it (moments, contributions, every source removed, cancellation residual);
2. its exact Monte Carlo at M = 10000 (L = 100000, one scene, all three channels); reference: the single-pass fast
   Monte Carlo at the same sizes. Target <= 1 s;
3. the joint analytic moments of HH, HV and VV of the same case (``StackJointErrorModel``, ground-cancellation.md
   Section 3.2), against the HV moments of item 1 and the single-pass joint moments of issue 12
   (``PolarimetricErrorModel``, co-polarised channels corrected for Faraday rotation) in the same run; the whole
   case as the chain asks it; and one case of the 7-pass (tomographic) stack;
4. the Monte Carlo of item 2 against issue 12's full-covariance Monte Carlo of one pass (noncentral Wishart of the
   same helper, 3 instead of 9 dimensions).
Run with ``make benchmark`` or ``python benchmarks/bench_stack.py``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets say
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from bench_crosspol import best_of

from e2esim.distortion import polarimetric_moments
from e2esim.distortion.covariance_montecarlo import simulate_covariance
from e2esim.distortion.error_model import HVErrorModel
from e2esim.distortion.faraday_correction import FaradayCorrection
from e2esim.distortion.montecarlo import simulate
from e2esim.distortion.polarimetric_model import PolarimetricErrorModel
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.table1 import TABLE1_FORESTS
from e2esim.stack.acquisitions import preset_stack
from e2esim.stack.combination import interpolated
from e2esim.stack.error_model import StackHVErrorModel
from e2esim.stack.faraday import StackFaraday
from e2esim.stack.joint_model import StackJointErrorModel
from e2esim.stack.montecarlo import simulate_stack
from e2esim.stack.scene import StackScene
from e2esim.stack.sites import SITES
from e2esim.stack.system import StackSystemErrors
from e2esim.stack.temporal import TemporalDecorrelation
from e2esim.units import variance_from_level_db

LOOKS, REALISATIONS = 100_000, 10_000


def case(phase: str = "interferometric"):
    biome, agb, hh, hv, vv, r, theta = TABLE1_FORESTS["boreal_200"]
    cov = ScatteringCovariance.from_powers(hh, hv, vv, r, np.radians(theta), agb_t_ha=agb, biome=biome)
    scene = StackScene(preset_stack(phase, np.radians(28.375)), cov, SITES["boreal"], TemporalDecorrelation())
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

    def model(kind=StackHVErrorModel, stack=scene):  # everything a case builds, built again: nothing cached
        return kind(stack, StackSystemErrors(system, 0.5), StackFaraday(fr, np.radians(7.0)),
                    interpolated(stack.acquisitions.kz_rad_m), LOOKS, "scene")

    print("1. Analytic moments of one case of the 3-pass ground-cancelled chain")
    t_stack = best_of(lambda: model().current(), repeats=20)
    t_single = best_of(lambda: HVErrorModel(cov, system, fr, looks=LOOKS).current(), repeats=20)
    print(f"   3-pass ground cancelled: {t_stack * 1e3:6.2f} ms (target <= 5 ms); single pass (Men et al. 2021): "
          f"{t_single * 1e3:6.3f} ms; ratio {t_stack / t_single:5.1f}x")

    def whole_case(kind=StackHVErrorModel):
        m = model(kind)
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

    print("3. Joint analytic moments of HH, HV and VV (co-polarised channels corrected on every pass)")
    t_joint = best_of(lambda: model(StackJointErrorModel).current_joint(), repeats=20)

    def one_pass():
        polarimetric_moments._RECENT.clear()  # nothing cached
        return PolarimetricErrorModel(cov, system, fr, FaradayCorrection("perfect"), LOOKS).current_joint()

    t_pol = best_of(one_pass, repeats=20)
    print(f"   3-pass ground cancelled: {t_joint * 1e3:6.2f} ms; against its HV moments (item 1): ratio "
          f"{t_joint / t_stack:5.1f}x; against one pass, issue 12 ({t_pol * 1e3:5.2f} ms): ratio "
          f"{t_joint / t_pol:5.1f}x")
    t_whole_joint = best_of(lambda: whole_case(StackJointErrorModel), repeats=3)
    print(f"   the whole case: {t_whole_joint * 1e3:6.1f} ms (HV: {t_whole * 1e3:5.1f} ms; ratio "
          f"{t_whole_joint / t_whole:5.1f}x)")
    tomographic = case("tomographic")[1]
    t_tom = best_of(lambda: model(StackJointErrorModel, tomographic).current_joint(), repeats=3)
    t_tom_hv = best_of(lambda: model(StackHVErrorModel, tomographic).current(), repeats=3)
    print(f"   7-pass ground cancelled: {t_tom * 1e3:6.1f} ms (HV: {t_tom_hv * 1e3:5.1f} ms; ratio "
          f"{t_tom / t_tom_hv:5.1f}x)")

    print(f"4. Exact Monte Carlo of every channel, L = {LOOKS}, M = {REALISATIONS}, against one pass (issue 12)")
    t_cov = best_of(lambda: simulate_covariance(cov, system, fr, rng, LOOKS, REALISATIONS,
                                                correction=FaradayCorrection("perfect")), repeats=3)
    print(f"   3-pass ground cancelled (item 2): {t_mc:6.3f} s; one pass, full covariance: {t_cov:6.3f} s; ratio "
          f"{t_mc / t_cov:5.1f}x")


if __name__ == "__main__":
    main()
