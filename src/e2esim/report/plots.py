"""Plots of a run, each written as a PNG (atomically) and returned with its caption.

The plot types mirror the figures of Men et al. (2021): bias and variance against a swept parameter
(Fig. 1), error histograms with the Gaussian fit (Fig. 2), trade-off curves (Figs. 3-8) and the
contributions of each error source (Figs. 9-10); plus requirement margins and AGB error against a sweep.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

from e2esim.io.atomic import atomic_path  # noqa: E402
from e2esim.report.faraday_plots import plot_faraday_climatology, plot_faraday_distributions  # noqa: E402
from e2esim.report.stack_plots import plot_agb_error_vs_faraday_difference  # noqa: E402

_DPI = 110


def _save(fig, folder: Path, name: str) -> str:
    path = folder / f"{name}.png"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=_DPI, format="png")  # layout done by tight_layout
    plt.close(fig)
    return path.name


def numeric_sweep_keys(result) -> list:
    keys = []
    for key in result.scenario.sweep_keys:
        values = [c.inputs.get(key) for c in result.cases]
        numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
        if numeric and len(set(values)) >= 3:  # a line against x needs at least three x values
            keys.append(key)
    return keys


def _x_and_groups(result, x_key, group_key):
    if x_key is None:
        keys = numeric_sweep_keys(result)
        if not keys:
            return None, None
        x_key = keys[0]
    others = [k for k in result.scenario.sweep_keys if k != x_key]
    if group_key is not None:
        others = [group_key]
    groups: dict = {}
    for c in result.cases:
        label = ", ".join(f"{k.split('.')[-1]}={c.inputs.get(k)}" for k in others) or "all"
        groups.setdefault(label, []).append(c)
    for label in groups:
        groups[label].sort(key=lambda c: c.inputs[x_key])
    return x_key, groups


def plot_verdicts(result, folder: Path, options: dict) -> list:
    names = result.requirement_names
    if not names:
        return []
    n = len(result.cases)
    fig, axes = plt.subplots(len(names), 1, figsize=(8, len(names) * (1.1 + 0.22 * min(n, 60))), squeeze=False)
    for j, (ax, name) in enumerate(zip(axes[:, 0], names)):
        margins = np.array([c.verdicts[j].margin for c in result.cases])
        passed = np.array([c.verdicts[j].passed for c in result.cases])
        if n <= 60:
            y = np.arange(n)
            ax.barh(y, margins, color=np.where(passed, "tab:green", "tab:red"))
            ax.set_yticks(y, [_short(c.label) for c in result.cases], fontsize=7)
            ax.invert_yaxis()
        else:
            ax.scatter(np.arange(n), margins, c=np.where(passed, "tab:green", "tab:red"), s=6)
            ax.set_xlabel("case")
        ax.axvline(0, color="k", lw=0.8) if n <= 60 else ax.axhline(0, color="k", lw=0.8)
        unit = result.cases[0].verdicts[j].unit
        (ax.set_xlabel if n <= 60 else ax.set_ylabel)(f"margin ({unit})")
        ax.set_title(name, fontsize=9)
    fig.tight_layout()
    return [(_save(fig, folder, "verdicts"), "Requirement margins per case (positive passes; green pass, red fail).")]


def plot_backscatter_vs_sweep(result, folder: Path, options: dict) -> list:
    x_key, groups = _x_and_groups(result, options.get("plot_x"), options.get("plot_group_by"))
    if x_key is None:
        return []
    fig, (ax_b, ax_v) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    for (label, cases), color in zip(groups.items(), _colors(len(groups))):
        x = np.array([c.inputs[x_key] for c in cases], dtype=float)
        s = [c.scalars for c in cases]
        if "analytic.mean" in s[0]:
            ax_b.plot(x, [r["analytic.mean"] for r in s], "-", color=color, label=f"analytic, {label}")
            ax_v.plot(x, [r["analytic.variance"] for r in s], "-", color=color)
        if "montecarlo.mean" in s[0]:
            ax_b.errorbar(x, [r["montecarlo.mean"] for r in s], yerr=[2 * r["montecarlo.mean_se"] for r in s],
                          fmt="o", ms=4, color=color, label=f"Monte Carlo (±2 SE), {label}")
            ax_v.errorbar(x, [r["montecarlo.variance"] for r in s],
                          yerr=[2 * r["montecarlo.variance_se"] for r in s], fmt="o", ms=4, color=color)
    ax_b.set_ylabel("mean error of $\\sigma_{hv}$ (m$^2$/m$^2$)")
    ax_v.set_ylabel("variance of the error (m$^4$/m$^4$)")
    ax_v.set_xlabel(x_key)
    for ax in (ax_b, ax_v):
        ax.grid(alpha=0.3)
        if np.all([r.get("analytic.mean", r.get("montecarlo.mean", 1)) > 0 for c in result.cases for r in [c.scalars]]):
            ax.set_yscale("log")
    ax_b.legend(fontsize=7)
    fig.tight_layout()
    return [(_save(fig, folder, "backscatter_vs_sweep"),
             f"Mean and variance of the σ_hv error against {x_key}: analytic (lines) and Monte Carlo "
             "(markers with ±2 standard errors), as in Men et al. (2021), Fig. 1.")]


def plot_error_histograms(result, folder: Path, options: dict) -> list:
    cases = [c for c in result.cases if c.get("backscatter.error") is not None
             and c.get("backscatter.error").samples() is not None]
    cases = cases[: options.get("histogram_cases", 12)]
    if not cases:
        return []
    ncol = min(3, len(cases))
    nrow = math.ceil(len(cases) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4 * ncol, 3 * nrow), squeeze=False)
    for ax, c in zip(axes.ravel(), cases):
        model = c.get("backscatter.error")
        e = np.ravel(model.samples())
        ax.hist(e, bins=60, density=True, color="0.7")
        mu, sd = e.mean(), e.std(ddof=1)
        x = np.linspace(e.min(), e.max(), 300)
        ax.plot(x, stats.norm.pdf(x, mu, sd), "r-", lw=1.2, label="Gaussian fit")
        an = model.current() if model.unavailable is None else None
        if an is not None:
            ax.plot(x, stats.norm.pdf(x, float(an.mean), float(an.sd)), "b--", lw=1, label="analytic")
        ax.set_title(_short(c.label, 50), fontsize=8)
        ax.set_xlabel("error of $\\sigma_{hv}$ (m$^2$/m$^2$)", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in axes.ravel()[len(cases):]:
        ax.axis("off")
    axes.ravel()[0].legend(fontsize=7)
    fig.tight_layout()
    return [(_save(fig, folder, "error_histograms"),
             "Histograms of the simulated σ_hv errors with the Gaussian of the same mean and variance (red) and "
             "the analytic Gaussian (blue, dashed), as in Men et al. (2021), Fig. 2.")]


def plot_tradeoff(result, folder: Path, options: dict) -> list:
    cases = [c for c in result.cases if any(v.curves for v in c.verdicts)][:12]
    if not cases:
        return []
    ncol = min(2, len(cases))
    nrow = math.ceil(len(cases) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(6 * ncol, 4.5 * nrow), squeeze=False)
    styles = {"over": "-", "under": "--"}
    for ax, c in zip(axes.ravel(), cases):
        verdicts = [v for v in c.verdicts if v.curves]
        for v, color in zip(verdicts, _colors(len(verdicts))):
            x = v.curves["crosstalk_db"]
            for side in ("over", "under"):
                key = f"{side}.imbalance_db"
                if key in v.curves:
                    ax.plot(x, v.curves[key], styles[side], color=color, label=f"{v.name} ({side})")
        inst = c.get("instrument")
        if inst is not None and np.isfinite(inst.crosstalk_db) and np.isfinite(inst.imbalance_db):
            ax.plot(inst.crosstalk_db, inst.imbalance_db, "k*", ms=12, label=f"{inst.name} specification")
        conv = inst.convention if inst is not None else "variance"
        ax.set_xlabel(f"crosstalk (dB, {conv})")
        ax.set_ylabel(f"channel imbalance (dB, {conv})")
        ax.set_title(_short(c.label, 70), fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6)
    for ax in axes.ravel()[len(cases):]:
        ax.axis("off")
    fig.tight_layout()
    return [(_save(fig, folder, "tradeoff"),
             "Trade-off curves between crosstalk and channel imbalance (Men et al. 2021, eq. 19, Figs. 3-8): "
             "below a curve the requirement holds. Solid: overestimation, dashed: underestimation. "
             "The star marks the instrument's specification.")]


def plot_contributions(result, folder: Path, options: dict) -> list:
    x_key, groups = _x_and_groups(result, options.get("plot_x"), options.get("plot_group_by"))
    if x_key is None or "analytic.mean" not in result.cases[0].scalars:
        return []
    fig, (ax_b, ax_v) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    bias_parts = {"channel imbalance": "analytic.bias_imbalance", "crosstalk": "analytic.bias_crosstalk",
                  "noise": "analytic.bias_noise"}
    var_parts = {"channel imbalance": "analytic.var_imbalance", "crosstalk": "analytic.var_crosstalk",
                 "interaction": "analytic.var_interaction"}
    linestyles = ["-", "--", ":", "-."]
    for (label, cases), ls in zip(groups.items(), linestyles * 10):
        x = np.array([c.inputs[x_key] for c in cases], dtype=float)
        for (part, key), color in zip(bias_parts.items(), _colors(3)):
            frac = [c.scalars[key] / c.scalars["analytic.mean"] for c in cases]
            ax_b.plot(x, frac, ls, color=color, label=f"{part}, {label}")
        for (part, key), color in zip(var_parts.items(), _colors(3)):
            frac = [c.scalars[key] / c.scalars["analytic.variance"] for c in cases]
            ax_v.plot(x, frac, ls, color=color, label=f"{part}, {label}")
    ax_b.set_ylabel("fraction of the mean error")
    ax_v.set_ylabel("fraction of the variance")
    ax_v.set_xlabel(x_key)
    for ax in (ax_b, ax_v):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6)
    fig.tight_layout()
    return [(_save(fig, folder, "contributions"),
             "Share of the mean and variance of the σ_hv error from channel imbalance, crosstalk, noise and their "
             "interaction (Men et al. 2021, Appendix C, Figs. 9-10).")]


def _spread_duplicates(x: np.ndarray, span: float) -> np.ndarray:
    """Offset cases that share an x value a little, so their markers do not hide each other."""
    out = x.astype(float).copy()
    for value in np.unique(x):
        idx = np.flatnonzero(x == value)
        if idx.size > 1:
            out[idx] += (np.arange(idx.size) - (idx.size - 1) / 2) * 0.012 * span
    return out


def _legend(ax, n_series: int) -> None:
    if n_series > 8:
        ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0), ncol=1 + n_series // 24)
    else:
        ax.legend(fontsize=7)


def plot_agb_error_vs_sweep(result, folder: Path, options: dict) -> list:
    x_key, groups = _x_and_groups(result, options.get("plot_x"), options.get("plot_group_by"))
    if x_key is None:
        return []
    fig, ax = plt.subplots(figsize=(9 if len(groups) > 8 else 7, 4.8))
    all_x = np.array([c.inputs[x_key] for c in result.cases], dtype=float)
    span = float(np.ptp(all_x)) or 1.0
    for (label, cases), color in zip(groups.items(), _colors(len(groups))):
        x = np.array([c.inputs[x_key] for c in cases], dtype=float)
        unique = len(np.unique(x)) == len(x)
        basis = "analytic" if "agb.analytic.q50_percent" in cases[0].scalars else "montecarlo"
        if f"agb.{basis}.q50_percent" not in cases[0].scalars:
            continue
        lo = np.array([c.scalars[f"agb.{basis}.q00135_percent"] for c in cases])
        mid = np.array([c.scalars[f"agb.{basis}.q50_percent"] for c in cases])
        hi = np.array([c.scalars[f"agb.{basis}.q99865_percent"] for c in cases])
        xs = x if unique else _spread_duplicates(x, span)
        ax.errorbar(xs, mid, yerr=[mid - lo, hi - mid], fmt="o-" if unique else "o", ms=3, capsize=2, lw=1,
                    color=color, label=f"{label} ({basis})")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xlabel(x_key)
    ax.set_ylabel("relative AGB error (%)")
    ax.grid(alpha=0.3)
    _legend(ax, len(groups))
    fig.tight_layout()
    return [(_save(fig, folder, "agb_error_vs_sweep"),
             f"Relative AGB error against {x_key}: median (marker) and the 0.135 % to 99.865 % interval (bar); cases "
             "that share an x value are drawn side by side.")]


PLOTTERS = {
    "verdicts": plot_verdicts,
    "backscatter_vs_sweep": plot_backscatter_vs_sweep,
    "error_histograms": plot_error_histograms,
    "tradeoff": plot_tradeoff,
    "contributions": plot_contributions,
    "agb_error_vs_sweep": plot_agb_error_vs_sweep,
    "faraday_distributions": plot_faraday_distributions,
    "faraday_climatology": plot_faraday_climatology,
    "agb_error_vs_faraday_difference": plot_agb_error_vs_faraday_difference,
}
AUTO_PLOTS = ("verdicts", "backscatter_vs_sweep", "agb_error_vs_sweep", "error_histograms", "tradeoff")


def make_plots(result, folder: Path) -> list:
    """Write the plots the scenario asks for; return [(file name, caption)]."""
    options = result.scenario.output
    wanted = []
    for name in options["plots"]:
        wanted.extend(AUTO_PLOTS if name == "auto" else [name])
    out = []
    for name in dict.fromkeys(wanted):
        out.extend(PLOTTERS[name](result, folder, options))
    return out


def _short(text: str, width: int = 60) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"


def _colors(n: int) -> list:
    cmap = plt.get_cmap("tab10")
    return [cmap(i % 10) for i in range(max(n, 1))]
