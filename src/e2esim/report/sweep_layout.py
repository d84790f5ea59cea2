"""How a sweep is laid out on a figure: which swept variable is the x axis, which one makes the series
(colours) and which the panels (facets), so that plots show results against the physics and stay readable
for sweeps of a thousand cases.

The x axis is ``output.plot_x``, else the first numeric key with at least three values; the series are
``output.plot_group_by``, else the next key that tells cases apart; the other keys make the panels, up to
``MAX_FACETS`` of them (beyond that they join the series). A sweep with no numeric key is drawn by case.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from e2esim.report.labels import axis_label, value_text, wrapped
from e2esim.runner.sweep import differing_keys

MAX_FACETS = 12
MAX_SERIES_IN_LEGEND = 12
MARKERS = "osD^v<>ph*"


@dataclass
class Series:
    label: str
    cases: list  # sorted along x


@dataclass
class Facet:
    title: str
    series: list


@dataclass
class SweepLayout:
    x_key: str | None  # None: one position per case
    series_keys: tuple
    facet_keys: tuple
    facets: list

    @property
    def x_label(self) -> str:
        return axis_label(self.x_key) if self.x_key else "case"

    def x_values(self, cases) -> np.ndarray:
        if self.x_key is None:
            return np.array([c.index for c in cases], dtype=float)
        return np.array([c.inputs[self.x_key] for c in cases], dtype=float)


def _numeric(values) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def sweep_layout(result, options: dict, cases=None) -> SweepLayout:
    cases = list(result.cases if cases is None else cases)
    varying = differing_keys([c.inputs for c in cases])
    x_key = options.get("plot_x")
    if x_key is None:
        x_key = next((k for k in varying if _numeric([c.inputs.get(k) for c in cases])
                      and len({c.inputs.get(k) for c in cases}) >= 3), None)
    rest = [k for k in varying if k != x_key]
    group = options.get("plot_group_by")
    if x_key is None:
        series_keys, facet_keys = (), ()  # drawn by case: every case is its own position
    else:
        series_keys = (group,) if group and group != x_key else tuple(rest[:1])
        others = [k for k in rest if k not in series_keys]
        facet_keys, extra = [], []
        n_facets = 1
        for key in others:
            n = len({repr(c.inputs.get(key)) for c in cases})
            if n_facets * n <= MAX_FACETS:
                facet_keys.append(key)
                n_facets *= n
            else:
                extra.append(key)
        series_keys = series_keys + tuple(extra)
        facet_keys = tuple(facet_keys)
    facets: dict = {}
    for c in cases:
        title = ", ".join(value_text(k, c.inputs.get(k)) for k in facet_keys) or ""
        label = ", ".join(value_text(k, c.inputs.get(k)) for k in series_keys) or "all cases"
        facets.setdefault(title, {}).setdefault(label, []).append(c)
    layout = []
    for title, series in facets.items():
        items = []
        for label, members in series.items():
            if x_key is not None:
                members = sorted(members, key=lambda c: c.inputs[x_key])
            items.append(Series(label, members))
        layout.append(Facet(title, items))
    return SweepLayout(x_key, series_keys, facet_keys, layout)


def facet_axes(layout: SweepLayout, width: float = 5.0, height: float = 3.6, rows_per_facet: int = 1,
               sharey: bool = True):
    """A figure with one panel per facet (and ``rows_per_facet`` rows of panels each); returns (fig, axes
    [facet][row])."""
    n = len(layout.facets)
    ncol = min(n, 2 if n <= 4 else 3)
    nrow = math.ceil(n / ncol)
    fig, axes = plt.subplots(nrow * rows_per_facet, ncol, figsize=(width * ncol, height * nrow * rows_per_facet),
                             squeeze=False, sharex=True, sharey="row" if sharey else False)
    out = []
    for i in range(n):
        r, col = divmod(i, ncol)
        out.append([axes[r * rows_per_facet + k, col] for k in range(rows_per_facet)])
    for i in range(n, nrow * ncol):
        r, col = divmod(i, ncol)
        for k in range(rows_per_facet):
            axes[r * rows_per_facet + k, col].axis("off")
    return fig, out


def label_facet(ax, layout: SweepLayout, facet: Facet, y_label: str) -> None:
    """The facet's panel titled and labelled (the sweep variable on x) in the report's small type, on a light grid."""
    ax.set_title(facet.title, fontsize=8)
    ax.set_xlabel(layout.x_label, fontsize=8)
    ax.set_ylabel(y_label, fontsize=8)
    ax.grid(alpha=0.3)
    ax.tick_params(labelsize=7)


def series_offsets(layout: SweepLayout, facet: Facet) -> list:
    """Horizontal offsets that keep series sharing x values from hiding each other (a dodge of 1.2 % of the
    x range per series)."""
    if layout.x_key is None or len(facet.series) < 2:
        return [0.0] * len(facet.series)
    xs = np.concatenate([layout.x_values(s.cases) for s in facet.series])
    shared = len(np.unique(xs)) < len(xs)
    span = float(np.ptp(xs)) or 1.0
    n = len(facet.series)
    return [((i - (n - 1) / 2) * 0.012 * span if shared else 0.0) for i in range(n)]


def style(i: int) -> dict:
    return {"color": plt.get_cmap("tab10")(i % 10), "marker": MARKERS[(i // 10 + i) % len(MARKERS)]}


def legend(ax, n_series: int) -> None:
    if n_series <= 1:
        return
    if n_series > MAX_SERIES_IN_LEGEND:
        ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0), ncol=1 + n_series // 24)
    else:
        ax.legend(fontsize=7)


CASE_LABEL_WIDTH = {"x": 40, "y": 60}
"""Characters per line of a case label on each axis; longer labels are wrapped (``labels.wrapped``), never cut."""


def case_tick_labels(cases, axis: str = "x") -> list:
    """``<index>: <label>`` of each case, wrapped at the commas between its keys."""
    return [wrapped(f"{c.index}: {c.label}", CASE_LABEL_WIDTH[axis]) for c in cases]


def case_row_height(cases, axis: str = "y", base: float = 0.22) -> float:
    """Height (inches) of a row of a chart with one row per case: ``base``, or more for labels on several lines."""
    lines = max((label.count("\n") + 1 for label in case_tick_labels(cases, axis)), default=1)
    return max(base, 0.06 + 0.14 * lines)


def case_ticks(ax, cases, axis: str = "x", max_labels: int = 40, positions=None) -> None:
    """Case labels, whole, as tick labels at ``positions`` (default: the case numbers); at most ``max_labels``,
    beyond that the axis says "case number"."""
    positions = [c.index for c in cases] if positions is None else list(positions)
    if len(cases) <= max_labels:
        (ax.set_xticks if axis == "x" else ax.set_yticks)(positions, case_tick_labels(cases, axis), fontsize=7,
                                                          **({"rotation": 30, "ha": "right"} if axis == "x" else {}))
    else:
        (ax.set_xlabel if axis == "x" else ax.set_ylabel)("case number (labels in the case table)")
