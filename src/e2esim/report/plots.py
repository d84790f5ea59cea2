"""Plots of a run, each written as a PNG (atomically) and returned with its caption.

The plot types mirror the figures of Men et al. (2021): bias and variance against a swept parameter
(Fig. 1), error histograms with the Gaussian fit (Fig. 2), trade-off curves (Figs. 3-8) and the
contributions of each error source (Figs. 9-10); plus requirement margins and AGB error against a sweep.
"""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from e2esim import registry
from e2esim.errors import ModuleLookupError
from e2esim.io.summary import LARGE_RUN_CASES
from e2esim.maps.grid import is_map_sweep
from e2esim.report.labels import wrapped
from e2esim.report.map_plots import SITE_KEYS
from e2esim.report.plot_base import (
    PlotSkipped,
    colors,
    figure_settings,
    older_objects_left_to_rest,
    panel_grid,
    save,
    tight_layout_in,
)
from e2esim.report.plot_processes import draw_all
from e2esim.report.sweep_layout import legend, sweep_layout
from e2esim.units import level_db_from_variance


def plot_error_histograms(result, folder: Path, options: dict) -> list:
    cases = [c for c in result.cases if c.get("backscatter.error") is not None
             and c.get("backscatter.error").samples() is not None]
    if not cases:
        raise PlotSkipped("no case has Monte Carlo samples of the σ_hv error (simulation.mode analytic)")
    shown = cases[: options.get("histogram_cases", 12)]
    more = (
        f" The first {len(shown)} of {len(cases)} cases are shown (output.histogram_cases)."
        if len(cases) > len(shown)
        else ""
    )
    cases = shown
    fig, axes = panel_grid(len(cases), 3, (4, 3))
    for i, (ax, c) in enumerate(zip(axes, cases)):
        model = c.get("backscatter.error")
        e = np.ravel(model.samples())
        ax.hist(e, bins=60, density=True, color="0.7", histtype="stepfilled")
        mu, sd = e.mean(), e.std(ddof=1)
        x = np.linspace(e.min(), e.max(), 300)
        ax.plot(x, _gaussian_pdf(x, mu, sd), "r-", lw=1.2, label="Gaussian fit")
        an = model.current() if model.unavailable is None else None
        if an is not None:
            ax.plot(x, _gaussian_pdf(x, float(an.mean), float(an.sd)), "b--", lw=1, label="analytic")
        ax.set_title(wrapped(c.label, 50), fontsize=8)
        if i + 3 >= len(cases):  # the bottom panel of each column: the panels share what x means
            ax.set_xlabel("error of $\\sigma_{hv}$ (m$^2$/m$^2$)", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    return [(save(fig, folder, "error_histograms"),
             "Histograms of the simulated σ_hv errors with the Gaussian of the same mean and variance (red) and "
             "the analytic Gaussian (blue, dashed), as in Men et al. (2021), Fig. 2." + more)]


def _gaussian_pdf(x, mean: float, sd: float) -> np.ndarray:
    """Density of N(mean, sd^2) (numpy: scipy.stats costs two seconds to import)."""
    return np.exp(-0.5 * ((x - mean) / sd) ** 2) / (sd * np.sqrt(2 * np.pi))


def plot_tradeoff(result, folder: Path, options: dict) -> list:
    every = [c for c in result.cases if any(v.curves for v in c.verdicts)]
    if not every:
        raise PlotSkipped("no verdict has a trade-off curve (set tradeoff_curve: true in an agb_error_bound "
                          "requirement; the error model needs crosstalk and channel-imbalance levels)")
    cases = every[:12]
    fig, axes = panel_grid(len(cases), 2, (6, 4.5))
    styles = {"over": "-", "under": "--"}
    labels = []  # per panel: its axis labels and legend entries
    for ax, c in zip(axes, cases):
        verdicts = [v for v in c.verdicts if v.curves]
        for v, color in zip(verdicts, colors(len(verdicts))):
            x = v.curves["crosstalk_db"]
            for side in ("over", "under"):
                key = f"{side}.imbalance_db"
                if key in v.curves:
                    ax.plot(x, v.curves[key], styles[side], color=color, label=f"{v.name} ({side})")
        inst = c.get("instrument")
        if inst is not None and np.isfinite(inst.crosstalk_db) and np.isfinite(inst.imbalance_db):
            ax.plot(inst.crosstalk_db, inst.imbalance_db, "k*", ms=12, label=f"{inst.name} specification (stated)")
        conv = inst.level_convention if inst is not None else "variance"
        residual = _residual_point(c.get("backscatter.error"), conv)
        if residual is not None:
            ax.plot(*residual, "o", ms=8, mfc="none", mec="tab:purple", mew=2, label="residual after calibration")
        ax.set_title(wrapped(c.label, 70), fontsize=9)
        ax.grid(alpha=0.3)
        labels.append((f"crosstalk (dB, {conv})", f"channel imbalance (dB, {conv})", _legend_entries(ax)))
    _label_panels(fig, axes, labels, columns=2)
    tight_layout_in(fig, (0, _legend_room(fig, labels), 1, 1))
    more = f" The first {len(cases)} of {len(every)} cases are shown." if len(every) > len(cases) else ""
    return [(save(fig, folder, "tradeoff", tight=False),
             "Trade-off curves between crosstalk and channel imbalance (Men et al. 2021, eq. 19, Figs. 3-8): "
             "below a curve the requirement holds. Solid: overestimation, dashed: underestimation. "
             "The star marks the specification as the scenario states it, the circle the residual levels after "
             "calibration (what the propagation applies; the level margins are measured from it)." + more)]


def _legend_entries(ax) -> tuple:
    """What a legend of ``ax`` shows: (label, line style, colour, marker) of each labelled line."""
    return tuple((ln.get_label(), ln.get_linestyle(), str(ln.get_color()), str(ln.get_marker()))
                 for ln in ax.get_lines() if not ln.get_label().startswith("_"))


def _label_panels(fig, axes, labels, columns: int) -> None:
    """Axis labels and legends of a grid of panels. Panels that all have the same ones (the usual case: the same
    requirements and convention in every case) share them: x labels on the bottom panel of each column, y labels
    on the first column, one legend below the panels; text is most of a figure's drawing time, and twelve copies
    of one legend say no more than one. Otherwise each panel has its own."""
    shared = len({entry for entry in labels}) == 1
    n = len(axes)
    for i, (ax, (x_label, y_label, _)) in enumerate(zip(axes, labels)):
        if not shared or i + columns >= n:
            ax.set_xlabel(x_label)
        if not shared or i % columns == 0:
            ax.set_ylabel(y_label)
        if not shared:
            ax.legend(fontsize=6)
    if shared:
        fig.legend(handles=[ln for ln in axes[0].get_lines() if not ln.get_label().startswith("_")],
                   loc="lower center", ncol=2, fontsize=7, frameon=False)


def _legend_room(fig, labels) -> float:
    """The fraction of the figure's height below the panels for a shared legend (``_label_panels``), else 0."""
    if not fig.legends:
        return 0.0
    rows = -(-len(labels[0][2]) // 2)
    return (0.2 * rows + 0.15) / fig.get_figheight()


def _residual_point(model, convention: str):
    """(crosstalk, channel imbalance) in dB of the error model's current levels, None if it has not both."""
    levels = getattr(model, "levels", {})
    if not all(levels.get(k, 0.0) > 0 for k in ("crosstalk", "channel_imbalance")):
        return None
    return tuple(float(level_db_from_variance(levels[k], convention)) for k in ("crosstalk", "channel_imbalance"))


def plot_contributions(result, folder: Path, options: dict) -> list:
    layout = sweep_layout(result, options)
    if layout.x_key is None:
        raise PlotSkipped("no numeric sweep variable with three or more values to draw the shares against")
    if "analytic.mean" not in result.cases[0].scalars:
        raise PlotSkipped("no analytic moments (simulation.mode montecarlo)")
    groups = {(f"{f.title}, " if f.title else "") + s.label: s.cases for f in layout.facets for s in f.series}
    x_key = layout.x_key
    fig, (ax_b, ax_v) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    bias_parts = {"channel imbalance": "analytic.bias_imbalance", "crosstalk": "analytic.bias_crosstalk",
                  "noise": "analytic.bias_noise"}
    var_parts = {"channel imbalance": "analytic.var_imbalance", "crosstalk": "analytic.var_crosstalk",
                 "interaction": "analytic.var_interaction"}
    linestyles = ["-", "--", ":", "-."]
    for (label, cases), ls in zip(groups.items(), linestyles * 10):
        x = np.array([c.inputs[x_key] for c in cases], dtype=float)
        for (part, key), color in zip(bias_parts.items(), colors(3)):
            frac = [c.scalars[key] / c.scalars["analytic.mean"] for c in cases]
            ax_b.plot(x, frac, ls, color=color, label=f"{part}, {label}")
        for (part, key), color in zip(var_parts.items(), colors(3)):
            frac = [c.scalars[key] / c.scalars["analytic.variance"] for c in cases]
            ax_v.plot(x, frac, ls, color=color, label=f"{part}, {label}")
    ax_b.set_ylabel("fraction of the mean error")
    ax_v.set_ylabel("fraction of the variance")
    ax_v.set_xlabel(layout.x_label)
    for ax in (ax_b, ax_v):
        ax.grid(alpha=0.3)
        legend(ax, 3 * len(groups))
    fig.tight_layout()
    return [(save(fig, folder, "contributions"),
             "Share of the mean and variance of the σ_hv error from channel imbalance, crosstalk, noise and their "
             "interaction (Men et al. 2021, Appendix C, Figs. 9-10).")]


AUTO_PLOTS = ("verdicts", "backscatter_vs_sweep", "agb_error_vs_sweep", "error_histograms", "tradeoff")
"""``auto``: these of e2esim's plot types (every plot type, a plug-in's too, is registered in the entry-point
group ``e2esim.plots``: function(result, folder, options) -> [(file name, caption)]; ``PlotSkipped`` says why
one draws nothing)."""
MAP_AUTO_PLOTS = ("global_maps", "map_fraction")
"""``auto`` of a map sweep: its maps instead of per-case plots."""
ALWAYS_PLOTS = ("error_budget",)
"""Drawn in every report that has requirements: the error budget is what a review asks first."""
COLUMN_PLOTS = ("error_budget", "global_maps", "map_fraction")
"""The plots of a run with more than ``LARGE_RUN_CASES`` cases: those that read the run's columns. The others
draw every case as a point, a bar or a histogram, which neither reads nor scales; ``auto`` adds none of them."""


def requested_plots(result) -> list:
    """The plot types of a run: ``output.plots`` (``auto`` expanded), the site map of a site sweep, and the
    error budget."""
    wanted = []
    large = len(result.scenario.cases) > LARGE_RUN_CASES
    auto = MAP_AUTO_PLOTS if is_map_sweep(result.scenario) else () if large else AUTO_PLOTS
    for name in result.scenario.output["plots"]:
        wanted.extend(auto if name == "auto" else [name])
    if any(k in result.scenario.sweep_keys for k in SITE_KEYS):
        wanted.append("site_map")
    if result.requirement_names:
        wanted = [*ALWAYS_PLOTS, *wanted]
    if getattr(result, "sensitivity", None):  # output.sensitivity: true
        wanted.append("sensitivity")
    return list(dict.fromkeys(wanted))


def make_plots(result, folder: Path, warnings: list | None = None, steps=None, helper: bool | None = None,
               meanwhile=None) -> list:
    """Write the plots of ``result``; return [(file name, caption)]. A requested plot that cannot be drawn is
    reported on standard error and added to ``warnings`` as "<plot>: <why>". ``steps``: a
    ``e2esim.runner.progress.StepProgress`` that counts each plot, or None. The plots are drawn by this process
    and a forked helper at once (``e2esim.report.plot_processes``; ``helper`` False: here only); ``meanwhile``
    (the output files that need no plot, or None) is called in this process before it draws."""
    options = result.scenario.output
    requested = set(options["plots"]) - {"auto"}
    large = len(result.scenario.cases) > LARGE_RUN_CASES

    def draw(name: str) -> tuple:
        """([(file name, caption)], why nothing was drawn)."""
        try:
            if large and name not in COLUMN_PLOTS:
                raise PlotSkipped(f"the run has {len(result.scenario.cases)} cases, more than {LARGE_RUN_CASES}: "
                                  "draw from results.h5 (e2esim.open_results, Results.to_xarray)")
            plot = registry.plot(name)  # a registered plot type (entry-point group e2esim.plots)
            with figure_settings():
                return plot(result, folder, options), "the plot function drew nothing for this run"
        except PlotSkipped as why:
            return [], str(why)
        except ModuleLookupError as why:  # a plug-in's plot that cannot be imported
            return [], str(why)

    def done(name: str) -> None:
        with contextlib.nullcontext() if steps is None else steps.step(name):
            pass

    names = requested_plots(result)
    out = []
    with older_objects_left_to_rest():
        drawn = draw_all(names, draw, done, helper, meanwhile)
    for name, (made, reason) in zip(names, drawn):
        if made:
            out.extend(made)
        elif name in requested or name in ALWAYS_PLOTS:  # plots of "auto" that do not apply are left out quietly
            message = f"{name}: not drawn: {reason}"
            print(f"e2esim: warning: plot {message}", file=sys.stderr)
            if warnings is not None:
                warnings.append(message)
    return out
