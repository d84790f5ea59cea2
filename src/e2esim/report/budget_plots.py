"""Report plot ``error_budget``: for every requirement, the part of the checked value each error source accounts for
(the verdict's shares, which sum to it, or where it has none its attribution; ``e2esim.io.error_budget``), as
stacked horizontal bars per case with the checked value and the limit. Sweeps of more than ``MAX_BAR_CASES``
cases show three cases: the worst, the median and the best."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from e2esim.io.error_budget import (
    SHAPLEY,
    budget_source_name,
    budget_split,
    source_groups,
    unattributed,
    verdict_budget,
)
from e2esim.report.outliers import axis_cut, mark_cut
from e2esim.report.plot_base import PlotSkipped, save, tight_layout_in
from e2esim.report.sweep_layout import case_row_height, case_ticks
from e2esim.requirements.source_names import coupling_words

MAX_BAR_CASES = 30
LEGEND_ROW = 0.22
"""Inches of a row of the legend below the panels."""
COUPLED_LABEL = "not attributed to one source (coupled sources)"
GROUP_HATCH = {"systematic": "", "random": "//", "regression": "..", "model": "xx", "assumed": "\\\\"}


def budget_cases(result, j: int) -> tuple[list, str]:
    """The cases whose budget is drawn for requirement j, and a phrase saying which."""
    table = result.table
    applies = table.applies(j)
    indices = np.nonzero(applies)[0] if applies.any() else np.arange(table.n)
    if len(indices) <= MAX_BAR_CASES:
        return [result.cases[int(i)] for i in indices], "every case"
    ordered = indices[np.argsort(table.requirements[j].margin[indices], kind="stable")]
    picked = sorted({int(ordered[0]), int(ordered[len(ordered) // 2]), int(ordered[-1])})
    return [result.cases[i] for i in picked], "the worst, the median and the best case"


def plot_error_budget(result, folder: Path, options: dict) -> list:
    names = result.requirement_names
    if not names:
        raise PlotSkipped("the scenario states no requirements")
    panels = []
    for j in range(len(names)):
        cases, which = budget_cases(result, j)
        rows = [verdict_budget(c.verdicts[j], source_groups(c)) for c in cases]
        if any(rows):
            panels.append((j, cases, which, rows))
    if not panels:
        raise PlotSkipped("no verdict attributes its value to error sources (the error model cannot be evaluated "
                          "analytically; see the notes)")
    sources = list(dict.fromkeys(r["source"] for _, _, _, rows in panels for case_rows in rows for r in case_rows))
    colours = {s: plt.get_cmap("tab20")(i % 20) for i, s in enumerate(sources)}
    heights = [1.4 + case_row_height(cases, base=0.32) * len(cases) for _, cases, _, _ in panels]
    fig, axes = plt.subplots(len(panels), 1, figsize=(9.5, sum(heights)), squeeze=False,
                             gridspec_kw={"height_ratios": heights})
    drawn: dict = {}
    notes = []
    coupled: set = set()
    shapley: set = set()
    for ax, (j, cases, which, rows) in zip(axes[:, 0], panels):
        unit = cases[0].verdicts[j].unit
        checked = np.array([c.verdicts[j].value for c in cases])
        ends = [s for case_rows in rows for s in _stack_ends(case_rows)]
        cut = axis_cut(np.concatenate([checked, ends]), reference=[cases[0].verdicts[j].limit])
        clip = cut.clip if cut else np.asarray
        bars: dict = {}  # (legend entry, colour, hatch, edge colour) -> [y], [width], [left]: one barh call each
        for y, (c, case_rows) in enumerate(zip(cases, rows)):
            right = left = 0.0
            for r in case_rows:
                value = _part(r)
                if not np.isfinite(value) or value == 0.0:
                    continue
                start = right if value > 0 else left + value
                lo, hi = clip([start, start + abs(value)])  # a bar beyond the cut axis stops at its edge
                if hi > lo:
                    key = (f"{budget_source_name(r['source'], cases)} ({r['group']})", colours[r["source"]],
                           GROUP_HATCH.get(r["group"], ""), "white")
                    _add_bar(bars, key, y, lo, hi)
                right, left = (right + value, left) if value > 0 else (right, left + value)
            v = c.verdicts[j]
            shared = unattributed(v)
            if budget_split(v) == SHAPLEY:
                shapley.add(f"{c.index}")
                coupled.update(r["source"] for r in case_rows if _part(r))
            rest = v.value - right - left if shared is None else shared
            if np.isfinite(rest) and rest != 0 and (shared is not None or (rest > 0 and right > 0)):
                start = right if rest > 0 else left + rest
                lo, hi = clip([start, start + abs(rest)])
                if hi > lo:
                    _add_bar(bars, (COUPLED_LABEL, "0.85", "", "0.6"), y, lo, hi)
                    if shared is not None and abs(rest) > 0.01 * abs(v.value):
                        coupled.update(r["source"] for r in case_rows if _part(r))
        for (label, colour, hatch, edge), (ys, widths, lefts) in bars.items():
            drawn.setdefault(label, ax.barh(ys, widths, left=lefts, color=colour, edgecolor=edge, hatch=hatch,
                                            height=0.7))
        ax.plot(clip(checked), range(len(cases)), "kd", ms=5, ls="none")
        mark_cut(ax, range(len(cases)), checked, cut, unit)
        if cut:
            ax.set_xlim(*cut.limits(np.concatenate([checked, ends]), [cases[0].verdicts[j].limit]))
            notes.append(cut.note(checked, unit))
        ax.axvline(cases[0].verdicts[j].limit, color="tab:red", lw=1.2, ls="--")
        ax.axvline(0, color="k", lw=0.6)
        case_ticks(ax, cases, axis="y", positions=range(len(cases)))
        ax.invert_yaxis()
        ax.set_xlabel(f"{unit}", fontsize=8)
        ax.set_title(f"{names[j]}: {which}", fontsize=9)
        ax.grid(alpha=0.3, axis="x")
    legend_h = LEGEND_ROW * -(-len(drawn) // 3) + 0.15  # inches below the panels: three columns of entries
    fig.set_figheight(sum(heights) + legend_h)
    fig.legend(list(drawn.values()), list(drawn.keys()), loc="lower center", ncol=3, fontsize=7)
    tight_layout_in(fig, (0, legend_h / fig.get_figheight(), 1, 1))
    why = (f" Where the sources couple: {coupling_words(sorted(coupled))}." if coupled else "")
    if shapley:
        why += (" There (the Euler split would leave more than 1 % of the checked value to no source: case"
                f"{'s' if len(shapley) > 1 else ''} {', '.join(sorted(shapley, key=int))}) the bars are the Shapley "
                "split instead, which adds up with no remainder (docs/theory/error-budget.md, Section 3a).")
    return [(save(fig, folder, "error_budget", tight=False),
             "Error budget of each requirement: the part of the checked value each error source accounts for (bars, "
             "hatched: random-error budget; dotted: regression; cross-hatched: retrieval model; back-hatched: "
             "assumed), the checked value (black diamond) and the limit (red dashed line). The parts add up to the "
             "checked value: each source's share of the mean square (RMSE) or of the Gaussian quantile (bounds) of "
             "the σ error, by the Euler principle (docs/theory/error-budget.md); grey is the part no single source "
             "accounts for, where the error model couples its sources (zero where they add)." + why + "".join(notes))]


def _add_bar(bars: dict, key: tuple, y: int, lo: float, hi: float) -> None:
    """Note a bar from ``lo`` to ``hi`` in row ``y`` under ``key``; the bars of one key are drawn by one ``barh``
    (a call per bar cost more than the rest of the figure's building)."""
    ys, widths, lefts = bars.setdefault(key, ([], [], []))
    ys.append(y)
    widths.append(hi - lo)
    lefts.append(lo)


def _part(row) -> float:
    """The length of a source's bar: its part of the checked value by the line's split (its removal attribution where
    it has none)."""
    return row["contribution"] if row.get("part") is None else row["part"]


def _stack_ends(case_rows) -> list:
    """Where a case's stacked bars end, on either side of zero (what the axis must reach)."""
    parts = [_part(r) for r in case_rows if np.isfinite(_part(r))]
    return [sum(p for p in parts if p > 0), sum(p for p in parts if p < 0)]
