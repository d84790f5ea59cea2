"""Speed of the cross-polarised error computations (issue "Cross-polarised backscatter error").

Prints, in one run:
1. the fast exact Monte Carlo at the paper's sizes (L = 100000, M = 10000, N = 1) for each Table II case,
   against a fair pixel-level reference timed on a subset and scaled to the same sizes, with the ratio. The
   reference (``pixel_reference``) is the best straightforward pixel-by-pixel implementation: the system
   errors enter ``S_hv_hat = a . s + nu`` only through one row ``a`` per realisation (Men et al. 2021, eq. 1
   with the estimator of eq. 2; ``effective_weights``), computed once, so each pixel costs a 3-element dot
   product (one matrix product per block of realisations) and one noise draw ``nu ~ CN(0, sigma_n / 2)``. The
   library's brute force (``method="brute_force"``, the full 2x2 matrix products per pixel, kept as an
   independent check of the system model) is printed beside it for information;
2. the whole ``e2esim reproduce men2021``;
3. one trade-off curve of 200 points: closed-form conic (Appendix B) and vectorised root finding.
Targets (one core): < 0.1 s per Monte Carlo case, < 10 s for reproduce, < 10 ms per curve.
Run with ``make benchmark`` or ``python benchmarks/bench_crosspol.py`` (add ``--quick`` for a smoke run).
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets say

import numpy as np

from e2esim.allocator import keep_freed_memory
from e2esim.distortion.error_model import HVErrorModel
from e2esim.distortion.montecarlo import simulate
from e2esim.faraday.distribution import ConstantFaraday, GaussianFaraday
from e2esim.polarimetry.system_model import effective_weights
from e2esim.requirements.tradeoff import AGBRequirement, ConicTradeoff, tradeoff_curve
from e2esim.units import variance_from_level_db
from e2esim.verification.men2021 import FIG1_FR, forest, system
from e2esim.verification.men2021_values import TABLE2_ROWS
from e2esim.verification.reproduce import run_checks

PAPER = dict(looks=100_000, realisations=10_000, noise_realisations=1)


def best_of(fn, repeats=3):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def pixel_reference(scene, sys_model, faraday, rng, looks, realisations, noise_realisations=1, scene_vectors=None):
    """Errors (M, N) of sigma_hv_hat = mean_k |a_m . s_k + nu|^2 against the scene's sigma_hv (eq. 17), pixel by
    pixel: one scene of ``looks`` pixels (or ``scene_vectors``), one weight row ``a_m`` per system-error and FR
    realisation (drawn in the order of ``simulate``: system errors and FR, then the scene, then the noise)."""
    errs = sys_model.sample(rng, realisations)
    omega = faraday.sample(rng, realisations)
    a = effective_weights(errs.delta, errs.f, omega, "hv", errs.gain)  # (M, 3): the only per-realisation work
    s = scene.sample(rng, looks) if scene_vectors is None else scene_vectors  # (L, 3)
    looks = s.shape[0]
    sigma_nu = np.sqrt(sys_model.noise_power / 2 / 2)  # nu = (N_hv + N_vh) / 2 ~ CN(0, sigma_n / 2)
    out = np.empty((realisations, noise_realisations))
    block = max(1, 2_000_000 // looks)
    for start in range(0, realisations, block):
        rows = a[start:start + block]
        signal = s @ rows.T  # (L, block): a_m . s_k for every pixel and realisation
        for j in range(noise_realisations):
            nu = sigma_nu * (rng.standard_normal(signal.shape) + 1j * rng.standard_normal(signal.shape))
            out[start:start + block, j] = np.mean(np.abs(signal + nu) ** 2, axis=0)
    return out - np.mean(np.abs(s[:, 1]) ** 2)


def main(quick: bool = False) -> None:
    keep_freed_memory()  # the allocator as e2esim run sets it (both the engine and its reference gain)
    rng = np.random.default_rng(0)
    print("1. Monte Carlo at the paper's sizes, L = 1e5, M = 1e4, N = 1 (Table II cases)")
    brute_sizes = dict(looks=2_000 if quick else 10_000, realisations=50 if quick else 200, noise_realisations=1)
    brute_units = brute_sizes["looks"] * brute_sizes["realisations"]
    paper_units = PAPER["looks"] * PAPER["realisations"] * PAPER["noise_realisations"]
    fast_times, ref_times, brute_times = [], [], []
    rows = TABLE2_ROWS[:2] if quick else TABLE2_ROWS
    for i, (xt, ci, name, fr_deg, _, _) in enumerate(rows, start=1):
        scene, sys_model = forest(name), system(xt, ci)
        fr = GaussianFaraday(np.radians(fr_deg), FIG1_FR.sd)
        t_fast = best_of(lambda: simulate(scene, sys_model, fr, rng, **PAPER))
        t_ref = best_of(lambda: pixel_reference(scene, sys_model, fr, rng, **brute_sizes)) * paper_units / brute_units
        t_brute = best_of(lambda: simulate(scene, sys_model, fr, rng, method="brute_force", **brute_sizes),
                          repeats=1) * paper_units / brute_units
        fast_times.append(t_fast)
        ref_times.append(t_ref)
        brute_times.append(t_brute)
        print(f"   row {i:2d} {name:13s}: fast {t_fast * 1e3:7.1f} ms   pixel reference {t_ref:7.1f} s "
              f"(ratio {t_ref / t_fast:6.0f}x)   matrix-product brute force {t_brute:7.1f} s")
    print(f"   (references timed at L={brute_sizes['looks']}, M={brute_sizes['realisations']} and scaled to the "
          "paper's sizes; pixel reference: one precomputed weight row per realisation)")
    print(f"   fast: mean {np.mean(fast_times) * 1e3:.1f} ms per case (target <= 3 ms); pixel reference: mean "
          f"{np.mean(ref_times):.1f} s per case; speed-up {np.mean(ref_times) / np.mean(fast_times):.0f}x "
          f"(the library's matrix-product brute force: {np.mean(brute_times) / np.mean(ref_times):.1f}x slower "
          "than the pixel reference)")
    _check_reference(rng, quick)

    print("2. e2esim reproduce men2021")
    t0 = time.perf_counter()
    records = run_checks(["men2021"])
    t_rep = time.perf_counter() - t0
    print(f"   {len(records)} checks in {t_rep:.2f} s (target < 10 s)")

    print("3. One trade-off curve of 200 points (boreal 200 t/ha, 99.865 %, +20 % AGB)")
    scene = forest("boreal_200")
    req = AGBRequirement(0.2, 0.99865, "over", 2.2)
    fr = ConstantFaraday(np.pi / 3)
    x = variance_from_level_db(np.linspace(-50, -15, 200), "three_sigma_amplitude")

    def conic():
        ConicTradeoff.from_moments(req, scene, system(-30, -34), fr).imbalance_for_crosstalk(x)

    t_conic = best_of(conic, 5)
    t_root = best_of(lambda: tradeoff_curve(req, HVErrorModel(scene, system(-30, -34), fr, form="paper"), x), 3)
    spread = HVErrorModel(scene, system(-30, -34), GaussianFaraday(np.pi / 3, 0.1))
    t_root_c = best_of(lambda: tradeoff_curve(req, spread, x), 1)
    print(f"   closed-form conic (paper form): {t_conic * 1e3:.2f} ms (target < 10 ms)")
    print(f"   root finding, paper form: {t_root * 1e3:.1f} ms ({t_root / t_conic:.0f}x the conic); "
          f"complete form with Faraday-rotation spread: {t_root_c * 1e3:.1f} ms")


def _check_reference(rng, quick: bool) -> None:
    """The pixel reference computes what the fast path computes: paired errors agree within their standard
    error (same scene, same system-error and FR draws; independent noise)."""
    scene, sys_model = forest("boreal_200"), system(-30, -34)
    vectors = scene.sample(rng, 2_000)
    sizes = dict(looks=2_000, realisations=200 if quick else 1_000, noise_realisations=1, scene_vectors=vectors)
    seed = int(rng.integers(2**31))
    fast = simulate(scene, sys_model, FIG1_FR, np.random.default_rng(seed), **sizes).hv
    ref = pixel_reference(scene, sys_model, FIG1_FR, np.random.default_rng(seed), **sizes)
    d = (fast - ref).ravel()
    z = d.mean() / (d.std(ddof=1) / np.sqrt(d.size))
    print(f"   check: pixel reference - fast path, mean difference z = {z:+.2f} (|z| < 4 expected)")


if __name__ == "__main__":
    main(quick="--quick" in sys.argv)
