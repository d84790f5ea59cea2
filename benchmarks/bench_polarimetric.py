"""Speed of the errors of all channels (issue "Co-polarised channels"), one core.

Prints, in one run:
1. the analytic mean vector and covariance matrix of the HH, HV, VV errors (``polarimetric_error_moments``):
   (a) cases that differ in their error levels (a sweep, a trade-off curve, a margin search): one level
       polynomial per scene and rotation, evaluated for a batch of level pairs; (b) cases that differ in scene
       and Faraday-rotation distribution, a batch through the vectorised kernel; (c) one case alone, nothing
       cached; uncorrected and corrected (residual rotation: a 17 x 17 quadrature). Target <= 50 us per case;
2. the fast exact Monte Carlo of the full 3x3 covariance at the paper's sizes (L = 1e5, M = 1e4, N = 1) for every
   Table I forest, uncorrected and corrected. Target <= 50 ms per case;
each against the brute-force pixel-level Monte Carlo (timed on a subset, scaled to the same sizes), with the ratio.
Run with ``python benchmarks/bench_polarimetric.py`` (``--quick`` for a smoke run).
"""

from __future__ import annotations

import os
import sys

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets say

import numpy as np
from bench_crosspol import best_of

from e2esim.distortion import polarimetric_moments
from e2esim.distortion.channel_moments import unit_covariances
from e2esim.distortion.covariance_montecarlo import simulate_covariance
from e2esim.distortion.faraday_correction import FaradayCorrection
from e2esim.distortion.polarimetric_moments import ErrorPolynomial, evaluate, polarimetric_error_moments
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.scene.table1 import TABLE1_FORESTS
from e2esim.verification.men2021 import forest, system

PAPER = dict(looks=100_000, realisations=10_000, noise_realisations=1)
FR = GaussianFaraday(np.pi / 3, np.pi / 36)
CORRECTIONS = {"uncorrected": FaradayCorrection(),
               "corrected": FaradayCorrection("estimated", GaussianFaraday(0.0, np.radians(0.2)))}


def brute_force_seconds(quick: bool, correction) -> float:
    """The pixel-level Monte Carlo timed at a subset and scaled to the paper's L M N."""
    sizes = dict(looks=2_000 if quick else 10_000, realisations=20 if quick else 100, noise_realisations=1)
    rng = np.random.default_rng(1)
    t = best_of(lambda: simulate_covariance(forest("boreal_200"), system(-30, -34), FR, rng, method="brute_force",
                                            correction=correction, **sizes), repeats=1)
    return t * PAPER["looks"] * PAPER["realisations"] / (sizes["looks"] * sizes["realisations"])


def analytic(quick: bool, brute: dict) -> None:
    print("1. Analytic moments of HH, HV, VV (mean vector and covariance matrix)")
    sys_model = system(-30, -34)
    n_levels = 2_000 if quick else 20_000
    vd = np.logspace(-6, -2, n_levels)
    for name, corr in CORRECTIONS.items():
        # (a) level cases: the polynomial once per scene and rotation, then every level pair
        def level_cases():
            poly = ErrorPolynomial.build(forest("boreal_200").matrix, unit_covariances(sys_model),
                                         *corr.nodes(FR))
            evaluate(poly, vd, vd / 2.5, sys_model.noise_power, looks=PAPER["looks"])

        t_a = best_of(level_cases) / n_levels
        # (b) cases that differ in scene and rotation: the kernel vectorised over a batch
        scenes = np.stack([forest(n).matrix for n in sorted(TABLE1_FORESTS)])
        fr_list = [GaussianFaraday(np.radians(m), np.radians(s)) for m in np.linspace(0, 80, 5 if quick else 20)
                   for s in (1.0, 5.0)]
        batch = len(scenes) * len(fr_list)
        nodes = [corr.nodes(fr) for fr in fr_list]
        weights = np.stack([w for _, _, w in nodes])  # (F, G): the nodes are the same for every distribution
        omega, omega_hat = nodes[0][0], nodes[0][1]
        levels = np.geomspace(1e-5, 1e-3, batch).reshape(len(scenes), len(fr_list))

        def scene_cases():
            poly = ErrorPolynomial.build(scenes[:, None], unit_covariances(sys_model), omega, omega_hat,
                                         weights[None])
            evaluate(poly, levels, levels / 2.5, sys_model.noise_power, looks=PAPER["looks"])

        t_b = best_of(scene_cases) / batch
        # (c) one case, nothing cached
        def one_case():
            polarimetric_moments._RECENT.clear()  # nothing cached
            polarimetric_error_moments(forest("boreal_200"), sys_model, FR, corr, looks=PAPER["looks"])

        t_c = best_of(one_case, 5)
        ref = brute[name]
        print(f"   {name:11s}: (a) {t_a * 1e6:6.1f} us per level case   (b) {t_b * 1e6:7.1f} us per scene/rotation "
              f"case (batch of {batch})   (c) {t_c * 1e3:6.2f} ms for one case alone   "
              f"[brute-force Monte Carlo at the paper's sizes: {ref:.0f} s; ratio to (b) {ref / t_b:.1e}x]")
    print("   target <= 50 us per case")


def monte_carlo(quick: bool, brute: dict) -> None:
    print("2. Fast exact Monte Carlo of the full 3x3 covariance at L = 1e5, M = 1e4, N = 1")
    rng = np.random.default_rng(0)
    names = sorted(TABLE1_FORESTS)[:2] if quick else sorted(TABLE1_FORESTS)
    for label, corr in CORRECTIONS.items():
        times = []
        for name in names:
            times.append(best_of(lambda: simulate_covariance(forest(name), system(-30, -34), FR, rng, correction=corr,
                                                             **PAPER)))
        print(f"   {label:11s}: {' '.join(f'{n} {t * 1e3:5.1f} ms' for n, t in zip(names, times))}")
        print(f"   {'':11s}  mean {np.mean(times) * 1e3:.1f} ms per case (target <= 50 ms); brute force "
              f"{brute[label] / 60:.1f} min per case; ratio {brute[label] / np.mean(times):.0f}x")


def main(quick: bool = False) -> None:
    brute = {name: brute_force_seconds(quick, corr) for name, corr in CORRECTIONS.items()}
    analytic(quick, brute)
    monte_carlo(quick, brute)


if __name__ == "__main__":
    main(quick="--quick" in sys.argv)
