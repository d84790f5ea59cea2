"""Plot of multi-pass (stack) runs: the AGB error against the Faraday-rotation difference between the passes.

The x axis is each case's ``estimator.faraday_difference_sd_deg`` (the SD of the difference of two passes'
Faraday rotation, an output of ``stack_backscatter_error``), so it works whether the sweep sets that SD directly
or varies what it is derived from (TEC variability, inter-pass correlation, site, pass). Cases are grouped by
every other sweep key; one panel per requirement, with its limit.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from e2esim.report.plot_base import save_png, tight_layout_in

X_SCALAR = "estimator.faraday_difference_sd_deg"


def _group_label(case) -> str:
    """The case label without the Faraday-difference key (that is the x axis)."""
    parts = [p for p in case.label.split(", ") if "faraday_difference" not in p]
    return ", ".join(parts) or "all"


def plot_agb_error_vs_faraday_difference(result, folder: Path, options: dict) -> list:
    cases = [c for c in result.cases if X_SCALAR in c.scalars]
    names = result.requirement_names
    if not cases or not names:
        return []
    groups: dict = {}
    for c in cases:
        groups.setdefault(_group_label(c), []).append(c)
    legend_h = 0.16 * -(-len(groups) // 2) + 0.3  # inches: two columns of entries
    fig, axes = plt.subplots(1, len(names), figsize=(6 * len(names), 4.0 + legend_h), squeeze=False)
    cmap = plt.get_cmap("tab20")
    for j, (ax, name) in enumerate(zip(axes[0], names)):
        for i, (label, members) in enumerate(groups.items()):
            members.sort(key=lambda c: c.scalars[X_SCALAR])
            x = [c.scalars[X_SCALAR] for c in members]
            y = [c.verdicts[j].value for c in members]
            ax.plot(x, y, "-o", ms=3, color=cmap(i % 20), label=label if j == 0 else None)
        limit = cases[0].verdicts[j]
        ax.axhline(limit.limit, color="k", ls="--", lw=0.8)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("SD of the Faraday-rotation difference between two passes (deg)")
        ax.set_ylabel(f"checked AGB error ({limit.unit})")
        ax.grid(alpha=0.3)
    fig.legend(loc="lower center", ncol=2, fontsize=6, frameon=False)
    tight_layout_in(fig, (0, legend_h / (4.0 + legend_h), 1, 1))
    return [(save_png(fig, Path(folder) / "agb_error_vs_faraday_difference.png", tight=False),
             "The AGB error each requirement checks against the SD of the Faraday-rotation difference between two "
             "passes (the case's, from the TEC variability or as swept); the dashed line is the requirement's limit.")]
