"""Report plots of results against the swept variables (``e2esim.report.sweep_layout``): requirement
margins, the relative AGB error and the moments of the σ_hv error. A sweep with no numeric variable is
drawn case by case, with the case labels on the axis."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from e2esim.report.outliers import axis_cut, mark_cut
from e2esim.report.plot_base import PlotSkipped, save
from e2esim.report.sweep_layout import (
    case_row_height,
    case_ticks,
    facet_axes,
    label_facet,
    legend,
    series_offsets,
    style,
    sweep_layout,
)

STATUS_COLOURS = {"pass": "tab:green", "fail": "tab:red", "not_applicable": "0.6"}
MAX_CASES_BY_LABEL = 60
"""Beyond this many cases a sweep without a numeric variable is drawn against the case number."""
MAX_SIDE_BY_SIDE = 3
"""Up to this many requirements, the margins per case are panels side by side that share the case labels (text is
most of a figure's drawing time); beyond, one panel above the other, each with its labels."""


def plot_verdicts(result, folder: Path, options: dict) -> list:
    names = result.requirement_names
    if not names:
        raise PlotSkipped("the scenario states no requirements")
    layout = sweep_layout(result, options)
    if layout.x_key is None:
        return _verdicts_by_case(result, folder, names)
    fig, axes = facet_axes(layout, rows_per_facet=len(names), height=3.0)
    every = [np.array([c.verdicts[j].margin for c in result.cases]) for j in range(len(names))]
    cuts = [axis_cut(m) for m in every]  # the panels of a requirement share their y axis
    for facet, rows in zip(layout.facets, axes):
        offsets = series_offsets(layout, facet)
        for j, (ax, name) in enumerate(zip(rows, names)):
            unit = result.cases[0].verdicts[j].unit
            for i, (series, dx) in enumerate(zip(facet.series, offsets)):
                x = layout.x_values(series.cases) + dx
                margins = np.array([c.verdicts[j].margin for c in series.cases])
                drawn = cuts[j].clip(margins) if cuts[j] else margins
                st = style(i)
                ax.plot(x, drawn, "-", color=st["color"], lw=1, marker=st["marker"], ms=3.5, label=series.label)
                failed = np.array([c.verdicts[j].status == "fail" for c in series.cases])
                ax.plot(x[failed], drawn[failed], "x", color="tab:red", ms=6, mew=1.5)
                mark_cut(ax, x, margins, cuts[j], unit, horizontal=False)
            if cuts[j]:
                ax.set_ylim(*cuts[j].limits(every[j]))
            ax.axhline(0, color="k", lw=0.8)
            ax.axhspan(min(ax.get_ylim()[0], -1e-9), 0, color="tab:red", alpha=0.06)
            ax.set_ylabel(f"margin ({unit})", fontsize=8)
            ax.set_title(f"{name}" + (f"\n{facet.title}" if facet.title else ""), fontsize=8)
            ax.grid(alpha=0.3)
            ax.tick_params(labelsize=7)
        rows[-1].set_xlabel(layout.x_label, fontsize=8)
    legend(axes[0][0], len(layout.facets[0].series))
    fig.tight_layout()
    return [(save(fig, folder, "verdicts"),
             f"Requirement margins against {layout.x_label} (positive passes; red crosses and the shaded band "
             "fail)" + (f"; one panel per {', '.join(layout.facet_keys)}" if layout.facet_keys else "")
             + "; a case the requirement does not apply to has no margin and no point."
             + _cut_notes(cuts, every, [result.cases[0].verdicts[j].unit for j in range(len(names))]))]


def _verdicts_by_case(result, folder, names) -> list:
    cases = result.cases
    n = len(cases)
    by_label = n <= MAX_CASES_BY_LABEL
    import matplotlib.pyplot as plt

    row = case_row_height(cases) if by_label else 0.0
    side = by_label and 1 < len(names) <= MAX_SIDE_BY_SIDE
    if side:  # the panels share their case labels: written once, left of the first
        fig, grid = plt.subplots(1, len(names), figsize=(3.5 + 3.2 * len(names), 1.2 + row * n), squeeze=False,
                                 sharey=True)
        panels = grid[0]
    else:
        fig, grid = plt.subplots(len(names), 1, figsize=(8, len(names) * (1.2 + (row * n if by_label else 3))),
                                 squeeze=False)
        panels = grid[:, 0]
    every, cuts = [], []
    for j, (ax, name) in enumerate(zip(panels, names)):
        margins = np.array([c.verdicts[j].margin for c in cases])
        cut = axis_cut(margins)
        every.append(margins)
        cuts.append(cut)
        drawn = cut.clip(margins) if cut else margins
        colors = [STATUS_COLOURS[c.verdicts[j].status] for c in cases]
        unit = cases[0].verdicts[j].unit
        positions = [c.index for c in cases]
        if by_label:
            ax.barh(positions, drawn, color=colors)
            if j == 0 or not side:  # a shared axis: labelled and inverted once
                case_ticks(ax, cases, axis="y")
                ax.invert_yaxis()
            ax.axvline(0, color="k", lw=0.8)
            ax.set_xlabel(f"margin ({unit})")
            mark_cut(ax, positions, margins, cut, unit)
            if cut:
                ax.set_xlim(*cut.limits(margins))
        else:
            ax.scatter(positions, drawn, c=colors, s=6)
            ax.axhline(0, color="k", lw=0.8)
            ax.set_xlabel("case number (labels in the case table)")
            ax.set_ylabel(f"margin ({unit})")
            mark_cut(ax, positions, margins, cut, unit, horizontal=False)
            if cut:
                ax.set_ylim(*cut.limits(margins))
        ax.set_title(name, fontsize=9)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return [(save(fig, folder, "verdicts"), "Requirement margins per case (positive passes; green passes, red fails; "
             "a case the requirement does not apply to has no margin and no bar)."
             + _cut_notes(cuts, every, [cases[0].verdicts[j].unit for j in range(len(names))]))]


def _cut_notes(cuts, values, units) -> str:
    """The caption's sentences on values drawn cut (``e2esim.report.outliers``)."""
    return "".join(cut.note(v, u) for cut, v, u in zip(cuts, values, units) if cut is not None)


def _agb_basis(cases) -> str | None:
    for basis in ("analytic", "montecarlo"):
        if all(f"agb.{basis}.q50_percent" in c.scalars for c in cases):
            return basis
    return None


def plot_agb_error_vs_sweep(result, folder: Path, options: dict) -> list:
    basis = _agb_basis(result.cases)
    if basis is None:
        raise PlotSkipped("the cases have no relative AGB error quantiles (no retrieval stage in the chain)")
    layout = sweep_layout(result, options)
    keys = (f"agb.{basis}.q00135_percent", f"agb.{basis}.q50_percent", f"agb.{basis}.q99865_percent")
    if layout.x_key is None:
        return _agb_error_by_case(result, folder, keys, basis)
    fig, axes = facet_axes(layout, height=3.8)
    every = np.array([[c.scalars[k] for k in keys] for c in result.cases])
    cut = axis_cut(every)
    for facet, (ax,) in zip(layout.facets, axes):
        for i, (series, dx) in enumerate(zip(facet.series, series_offsets(layout, facet))):
            values = [np.array([c.scalars[k] for c in series.cases]) for k in keys]
            lo, mid, hi = (cut.clip(v) for v in values) if cut else values
            st = style(i)
            x = layout.x_values(series.cases) + dx
            mark_cut(ax, x, values[2], cut, "%", horizontal=False)
            ax.errorbar(
                x,
                mid,
                yerr=[mid - lo, hi - mid],
                fmt="-",
                marker=st["marker"],
                ms=3.5,
                capsize=2,
                lw=1,
                color=st["color"],
                label=series.label,
            )
        if cut:
            ax.set_ylim(*cut.limits(every))
        ax.axhline(0, color="k", lw=0.8)
        label_facet(ax, layout, facet, "relative AGB error, computed sources (%)")
    legend(axes[0][0], len(layout.facets[0].series))
    fig.tight_layout()
    return [(save(fig, folder, "agb_error_vs_sweep"),
             f"Relative AGB error (every error source, {basis}) against {layout.x_label}: median (marker) and the "
             "0.135 % to 99.865 % interval (bar); series sharing an x value are set slightly apart."
             + (cut.note(every[:, 2], "%") if cut else ""))]


def _agb_error_by_case(result, folder, keys, basis) -> list:
    cases = result.cases
    if len(cases) > MAX_CASES_BY_LABEL:
        raise PlotSkipped(f"{len(cases)} cases and no numeric sweep variable to draw them against; set output.plot_x")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 1.2 + case_row_height(cases, base=0.3) * len(cases)))
    values = [np.array([c.scalars[k] for c in cases]) for k in keys]
    cut = axis_cut(np.concatenate(values))
    lo, mid, hi = (cut.clip(v) for v in values) if cut else values
    y = [c.index for c in cases]
    ax.errorbar(mid, y, xerr=[mid - lo, hi - mid], fmt="o", ms=4, capsize=3, color="tab:blue")
    mark_cut(ax, y, values[2], cut, "%")
    if cut:
        ax.set_xlim(*cut.limits(np.concatenate(values)))
    case_ticks(ax, cases, axis="y")
    ax.invert_yaxis()
    ax.axvline(0, color="k", lw=0.8)
    ax.set_xlabel(f"relative AGB error, computed sources ({basis}, %)")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return [(save(fig, folder, "agb_error_vs_sweep"),
             "Relative AGB error of each case (every error source): median (marker) and the 0.135 % to 99.865 % "
             "interval (bar)." + (cut.note(values[2], "%") if cut else ""))]


def plot_backscatter_vs_sweep(result, folder: Path, options: dict) -> list:
    layout = sweep_layout(result, options)
    if layout.x_key is None:
        raise PlotSkipped("no numeric sweep variable with three or more values to draw the σ_hv error against")
    if not any("analytic.mean" in c.scalars or "montecarlo.mean" in c.scalars for c in result.cases):
        raise PlotSkipped("the cases have no σ_hv error moments")
    fig, axes = facet_axes(layout, rows_per_facet=2, height=3.0, sharey=False)
    positive = all(c.scalars.get("analytic.mean", c.scalars.get("montecarlo.mean", 1)) > 0 for c in result.cases)
    for facet, (ax_b, ax_v) in zip(layout.facets, axes):
        for i, (series, dx) in enumerate(zip(facet.series, series_offsets(layout, facet))):
            x = layout.x_values(series.cases) + dx
            s = [c.scalars for c in series.cases]
            st = style(i)
            if "analytic.mean" in s[0]:
                ax_b.plot(x, [r["analytic.mean"] for r in s], "-", color=st["color"], label=f"analytic, {series.label}")
                ax_v.plot(x, [r["analytic.variance"] for r in s], "-", color=st["color"])
            if "montecarlo.mean" in s[0]:
                ax_b.errorbar(x, [r["montecarlo.mean"] for r in s], yerr=[2 * r["montecarlo.mean_se"] for r in s],
                              fmt=st["marker"], ms=3.5, color=st["color"], label=f"Monte Carlo (±2 SE), {series.label}")
                ax_v.errorbar(x, [r["montecarlo.variance"] for r in s],
                              yerr=[2 * r["montecarlo.variance_se"] for r in s], fmt=st["marker"], ms=3.5,
                              color=st["color"])
        ax_b.set_title(facet.title, fontsize=8)
        ax_b.set_ylabel("mean error of $\\sigma_{hv}$ (m$^2$/m$^2$)", fontsize=8)
        ax_v.set_ylabel("variance of the error (m$^4$/m$^4$)", fontsize=8)
        ax_v.set_xlabel(layout.x_label, fontsize=8)
        for ax in (ax_b, ax_v):
            ax.grid(alpha=0.3)
            ax.tick_params(labelsize=7)
            if positive:
                ax.set_yscale("log")
    legend(axes[0][0], 2 * len(layout.facets[0].series))
    fig.tight_layout()
    return [(save(fig, folder, "backscatter_vs_sweep"),
             f"Mean and variance of the σ_hv error against {layout.x_label}: analytic (lines) and Monte Carlo "
             "(markers with ±2 standard errors), as in Men et al. (2021), Fig. 1.")]
