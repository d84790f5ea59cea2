"""Speed of the retrieval-uncertainty code and of the backscatter error budget (issue 6 targets).

1. SIMEX (S = 100 per lambda, 4 lambdas) plus a 1000-sample parametric bootstrap on 40 plots, target
   under 20 s on one core. Reference: the same estimator with one scipy.optimize.curve_fit call per fit.
2. The error budget of Ahmed et al. (2014), eqs. (20)-(38), vectorised over 1e5 cases, target under 1 s.
   Reference: the scalar per-case implementation (e2esim.budget.reference), timed on a subset and scaled.

Run: .venv/bin/python benchmarks/bench_retrieval.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, as the target says

import sys
import time
import warnings

import numpy as np
from scipy import optimize

from e2esim.budget.presets import UAVSAR_AHMED2014
from e2esim.budget.reference import budget_scalar, random_cases
from e2esim.budget.result import BudgetInputs, backscatter_budget
from e2esim.retrieval.bootstrap import parametric_bootstrap
from e2esim.retrieval.saturating import SaturatingModel
from e2esim.retrieval.simex import simex
from e2esim.retrieval.synthetic import synthetic_field_plots

TRUE = SaturatingModel(0.055, 0.015, 0.008)
LAMBDAS = (0.5, 1.0, 1.5, 2.0)


def _reference_fit(agb, sigma, p0):
    """One curve_fit call per data set (the straightforward implementation)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            p, _ = optimize.curve_fit(lambda m, a, b, c: TRUE.evaluate(m, np.array([a, b, c])), agb, sigma, p0=p0,
                                      maxfev=2000)
        return p, TRUE.params_valid(p)
    except RuntimeError:
        return p0, False


def reference_simex_bootstrap(fp, rng, n_sim, n_boot):
    naive, _ = _reference_fit(fp.agb, fp.sigma, TRUE.params)
    by_lam = [naive]
    for lam in LAMBDAS:
        fits = []
        for _ in range(n_sim):
            w = np.clip(fp.agb + np.sqrt(lam) * fp.agb_error_sd * rng.standard_normal(fp.agb.size), 0, None)
            d = fp.sigma + np.sqrt(lam) * fp.sigma_error_sd * rng.standard_normal(fp.agb.size)
            p, ok = _reference_fit(w, d, naive)
            if ok:
                fits.append(p)
        by_lam.append(np.mean(fits, axis=0))
    lam_all = np.concatenate([[0.0], LAMBDAS])
    centre = np.array([np.polyval(np.polyfit(lam_all, np.array(by_lam)[:, j], 2), -1.0) for j in range(3)])
    model = TRUE.with_params(centre)
    resid = fp.sigma - model.sigma(fp.agb)
    s_eps = np.sqrt(max(np.sum(resid**2) / (fp.agb.size - 3) - np.mean(fp.sigma_error_sd**2)
                        - np.mean(model.derivative(fp.agb) ** 2 * fp.agb_error_sd**2), 0.0))
    boots = []
    for _ in range(n_boot):
        w = np.clip(fp.agb + fp.agb_error_sd * rng.standard_normal(fp.agb.size), 0, None)
        d = model.sigma(fp.agb) + s_eps * rng.standard_normal(fp.agb.size) + fp.sigma_error_sd * rng.standard_normal(
            fp.agb.size)
        p, ok = _reference_fit(w, d, centre)
        if ok:
            boots.append(p)
    return centre, np.cov(np.array(boots), rowvar=False)


def bench_simex_bootstrap(n_sim=100, n_boot=1000, reference=True):
    rng = np.random.default_rng(2014)
    fp = synthetic_field_plots(TRUE, 40, rng, allometric_error=0.1, backscatter_error=0.05,
                               model_error_sd=0.002, agb_range_t_ha=(5, 350))
    t0 = time.perf_counter()
    sx = simex(TRUE, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd, rng, lambdas=LAMBDAS, n_sim=n_sim)
    boot = parametric_bootstrap(sx.model, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd, rng, n_boot=n_boot)
    fast = time.perf_counter() - t0
    fits = 1 + len(LAMBDAS) * n_sim + n_boot
    print(f"SIMEX (S = {n_sim}, {len(LAMBDAS)} lambdas) + bootstrap (B = {n_boot}) on 40 plots: {fast:.2f} s "
          f"({fits} fits; failures: SIMEX {sx.failures.sum()}, bootstrap {boot.n_failed}); target < 20 s: "
          f"{'met' if fast < 20 else 'MISSED'}")
    t0 = time.perf_counter()
    twostage = parametric_bootstrap(sx.model, fp.agb, fp.sigma, fp.agb_error_sd, fp.sigma_error_sd, rng,
                                    n_boot=n_boot, refit="simex", simex_options={"n_sim": 20})
    print(f"  two-stage bootstrap with SIMEX refits (B = {n_boot}, S = 20): {time.perf_counter() - t0:.2f} s "
          f"({n_boot * (1 + 4 * 20)} fits; {twostage.n_failed} failed)")
    if reference:
        t0 = time.perf_counter()
        centre, cov = reference_simex_bootstrap(fp, np.random.default_rng(7), n_sim, n_boot)
        ref = time.perf_counter() - t0
        print(f"  reference (one scipy curve_fit per fit): {ref:.2f} s; speed-up {ref / fast:.1f}x")
        rel = np.abs(np.sqrt(np.diag(cov)) / np.sqrt(np.diag(boot.covariance)) - 1)
        print(f"  same estimator: SIMEX centre differs by {np.max(np.abs(centre / sx.params - 1)) * 100:.1f} % "
              f"(independent draws), bootstrap SDs by {np.max(rel) * 100:.0f} % (B = {n_boot})")


def _cases(n, rng):
    return random_cases(n, rng, UAVSAR_AHMED2014)


def bench_budget(n=100_000, n_ref=5_000):
    base, arrays, sigma = _cases(n, np.random.default_rng(1))
    inputs = BudgetInputs(**{**base, **arrays})
    backscatter_budget(BudgetInputs(**base), 0.05)  # warm up
    t0 = time.perf_counter()
    b = backscatter_budget(inputs, sigma)
    total = b.total_sd
    fast = time.perf_counter() - t0
    print(
        f"error budget, {n:.0e} cases vectorised: {fast * 1e3:.0f} ms; target < 1 s: {'met' if fast < 1 else 'MISSED'}"
    )
    t0 = time.perf_counter()
    ref = [budget_scalar({**base, **{k: float(v[i]) for k, v in arrays.items()}}, float(sigma[i]))["total"]
           for i in range(n_ref)]
    per_case = (time.perf_counter() - t0) / n_ref
    print(
        f"  reference (scalar, one case at a time): {per_case * 1e6:.0f} us per case, {per_case * n:.1f} s for {n:.0e} "
        f"cases (timed on {n_ref}); speed-up {per_case * n / fast:.0f}x"
    )
    print(f"  largest relative difference from the reference: {np.max(np.abs(np.array(ref) / total[:n_ref] - 1)):.1e}")


if __name__ == "__main__":
    quick = "--quick" in sys.argv
    bench_simex_bootstrap(n_sim=100, n_boot=200 if quick else 1000, reference=not quick)
    bench_budget(n=100_000, n_ref=1000 if quick else 5000)
