"""Regenerate the figures of docs/theory/retrieval.md from synthetic data (seeded, reproducible).

Run: .venv/bin/python docs/theory/make_retrieval_figures.py   (writes docs/theory/img/retrieval_*.png)

Figures in the manner of Ahmed, Siqueira & Hensley (2014): Fig. 15 (backscatter error budget per plot,
with the model error and the allometric error projected into backscatter, eq. 45), Fig. 16 (SIMEX),
Fig. 17 (naive and measurement-error-corrected intervals with the bootstrap cloud) and Fig. 20 (the
intervals inverted to AGB, unbounded where the model saturates).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from e2esim.budget.presets import preset
from e2esim.budget.result import GROUPS, backscatter_budget
from e2esim.retrieval.bootstrap import parametric_bootstrap
from e2esim.retrieval.regression import BOUNDED, band_from_fit, invert_band
from e2esim.retrieval.saturating import SaturatingModel
from e2esim.retrieval.simex import simex
from e2esim.retrieval.synthetic import synthetic_field_plots

OUT = Path(__file__).resolve().parent / "img"
TRUE = SaturatingModel(0.055, 0.015, 0.008)  # an L-band HV curve saturating near 150 t/ha
SEED = 2014
GRID = np.linspace(0.0, 400.0, 801)


def hectare_data(rng):
    """38 'hectares' like the combined Harvard/Howland set: 0-350 t/ha, allometric error ~3 %, the
    hectare-scale budget of Tables III-IV as backscatter error, and an error in equation of 0.006."""
    fp = synthetic_field_plots(TRUE, 38, rng, agb_range_t_ha=(5, 350), allometric_error=0.03,
                               backscatter_error=0.0, model_error_sd=0.006)
    budget = backscatter_budget(preset("uavsar_ahmed2014"), np.clip(fp.sigma_true, 1e-3, None))
    sq = budget.absolute_sd("total")
    sigma = fp.sigma_true + sq * rng.standard_normal(fp.sigma_true.shape)
    return fp, sigma, sq


def fig15(rng):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=False)
    for ax, (area, label) in zip(axes, ((625.0, "25 m subplots"), (10_000.0, "hectares"))):
        agb = np.sort(rng.uniform(5, 350, 40))
        sigma = TRUE.sigma(agb)
        b = backscatter_budget(preset("uavsar_ahmed2014", area_m2=area), sigma)
        for g, style in zip(GROUPS, ("-o", "-s", "-^", "-v")):
            ax.plot(agb, b.absolute_sd(g), style, ms=3, label={"speckle_noise": "speckle, SNR, MNR",
                                                               "temporal": "temporal",
                                                               "calibration": "calibration",
                                                               "area_projection": "area projection"}[g])
        ax.plot(agb, b.absolute_sd("total"), "k-", lw=2, label="total")
        ax.axhline(0.006, color="grey", ls="--", label="model error (0.006)")
        allometric = TRUE.derivative(agb) * 0.03 * agb  # eq. (45) with a 3 % allometric error
        ax.plot(agb, allometric, ":", color="purple", label="allometric, eq. (45)")
        ax.set_xlabel("AGB (t/ha)")
        ax.set_ylabel("error in sigma_HV (m$^2$/m$^2$)")
        ax.set_title(f"UAVSAR budget, {label} (N = {float(b.looks[0]):.0f})")
        ax.set_yscale("log")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(OUT / "retrieval_fig15_budget.png", dpi=120)
    plt.close(fig)


def fig16_17_20(rng):
    fp, sigma, sq = hectare_data(rng)
    naive = TRUE.fit(fp.agb, sigma)
    sx = simex(TRUE, fp.agb, sigma, fp.agb_error_sd, sq, rng, n_sim=200, lambdas=(0.25, 0.5, 1.0, 1.5, 2.0))
    # Fig. 16: SIMEX
    fig, axes = plt.subplots(2, 2, figsize=(9, 7))
    lam = np.linspace(-1, 2, 100)
    curve = sx.extrapolate(lam)
    for j, ax in enumerate(axes.flat[:3]):
        ax.plot(sx.lambdas, sx.params_by_lambda[:, j], "o", label="mean of the simulated fits, eq. (19)")
        ax.plot(lam, curve[:, j], "-", label=f"{sx.extrapolant} extrapolant")
        ax.plot([-1], [sx.params[j]], "r*", ms=12, label="SIMEX estimate (lambda = -1)")
        ax.axhline(TRUE.params[j], color="grey", ls=":", label="truth")
        ax.set_xlabel("lambda")
        ax.set_ylabel(TRUE.param_names[j])
    axes[0, 0].legend(fontsize=7)
    ax = axes[1, 1]
    ax.plot(fp.agb, sigma, "k.", label="plots")
    ax.plot(GRID, naive.model.sigma(GRID), label="naive fit")
    ax.plot(GRID, sx.model.sigma(GRID), label="SIMEX fit")
    ax.plot(GRID, TRUE.sigma(GRID), "k:", label="truth")
    ax.set_xlabel("AGB (t/ha)")
    ax.set_ylabel("sigma_HV (m$^2$/m$^2$)")
    ax.legend(fontsize=7)
    fig.suptitle(f"SIMEX on 38 synthetic hectares ({sx.failures.sum()} of {sx.attempts.sum()} simulated fits failed)")
    fig.tight_layout()
    fig.savefig(OUT / "retrieval_fig16_simex.png", dpi=120)
    plt.close(fig)
    # Fig. 17: naive and corrected bands with the bootstrap cloud
    boot = parametric_bootstrap(sx.model, fp.agb, sigma, fp.agb_error_sd, sq, rng, n_boot=1000)
    nb = band_from_fit(naive, GRID)
    cb = boot.band(GRID)
    fig, ax = plt.subplots(figsize=(7, 5))
    cloud = rng.choice(boot.converged_samples.shape[0], 60, replace=False)
    for k in cloud:
        ax.plot(GRID, TRUE.evaluate(GRID, boot.converged_samples[k]), color="0.85", lw=0.6, zorder=0)
    ax.plot(fp.agb, sigma, "k.", label="synthetic hectares")
    ax.plot(GRID, nb.fit, "b-", label="naive fit")
    ax.fill_between(GRID, nb.conf_lower, nb.conf_upper, color="b", alpha=0.25, label="naive 95 % confidence")
    ax.plot(GRID, nb.pred_lower, "b--", lw=0.8, label="naive 95 % prediction")
    ax.plot(GRID, nb.pred_upper, "b--", lw=0.8)
    ax.plot(GRID, cb.conf_lower, "r-", lw=1.2, label="corrected 95 % confidence (SIMEX + bootstrap)")
    ax.plot(GRID, cb.conf_upper, "r-", lw=1.2)
    ax.set_xlabel("AGB (t/ha)")
    ax.set_ylabel("sigma_HV (m$^2$/m$^2$)")
    ax.set_ylim(0, 0.08)
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title(f"Bootstrap B = 1000 ({boot.n_failed} failed refits); grey: bootstrap curves")
    fig.tight_layout()
    fig.savefig(OUT / "retrieval_fig17_intervals.png", dpi=120)
    plt.close(fig)
    # Fig. 20: intervals inverted to AGB
    obs = sx.model.sigma(np.linspace(2, 300, 150))
    fig, ax = plt.subplots(figsize=(7, 5))
    for band, colour, label in ((nb, "b", "naive confidence"), (cb, "r", "corrected confidence")):
        iv = invert_band(band, obs)
        finite = iv.status == BOUNDED
        ax.fill_between(iv.estimate, np.where(finite, iv.lower, np.nan), np.where(finite, iv.upper, np.nan),
                        color=colour, alpha=0.3, label=f"{label} (bounded)")
        unb = ~finite
        if unb.any():
            ax.plot(iv.estimate[unb], np.full(unb.sum(), GRID[-1]), colour + "^", ms=3,
                    label=f"{label}: unbounded above from {iv.estimate[unb].min():.0f} t/ha")
    ax.plot([0, 300], [0, 300], "k:", lw=0.8)
    ax.set_xlabel("radar AGB estimate (t/ha)")
    ax.set_ylabel("95 % interval of AGB (t/ha)")
    ax.set_ylim(0, GRID[-1] * 1.03)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title("Confidence intervals inverted to AGB (saturation makes them unbounded)")
    fig.tight_layout()
    fig.savefig(OUT / "retrieval_fig20_inverted.png", dpi=120)
    plt.close(fig)


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(SEED)
    fig15(rng)
    fig16_17_20(rng)
    print(f"figures written to {OUT}")


if __name__ == "__main__":
    main()
