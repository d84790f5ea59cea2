"""Plot of a multi-channel run: AGB estimators side by side, and the errors of the three channels they use."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Patch

_CAP_PERCENT = 100.0  # bars beyond are drawn at the cap and labelled with their value
_CHANNELS = ("hh", "hv", "vv")


def plot_estimator_comparison(result, folder: Path, options: dict) -> list:
    """Checked value of the first requirement per AGB estimator (``retrieval.estimator`` swept), grouped by the
    other sweep inputs, with each verdict's dominant error source; below, the relative error of sigma_hh,
    sigma_hv, sigma_vv (mean and 3 SD, analytic) of each group."""
    from e2esim.report.labels import wrapped
    from e2esim.report.plot_base import save as _save
    from e2esim.report.plots import series_colors
    from e2esim.runner.sweep import case_labels

    key = next((k for k in result.scenario.sweep_keys if k.endswith("estimator")), None)
    if key is None or not result.requirement_names:
        return []
    estimators = list(dict.fromkeys(c.inputs[key] for c in result.cases))
    others = [k for k in result.scenario.sweep_keys if k != key]
    groups: dict = {}  # each group named by the keys that tell the groups apart, as case labels name them
    names = case_labels([{k: c.inputs.get(k) for k in others} for c in result.cases])
    for c, name in zip(result.cases, names):
        label = "\n".join(name.split(", ")) if others else "all"
        groups.setdefault(label, {})[c.inputs[key]] = c
    fig, (ax, ax_ch) = plt.subplots(2, 1, figsize=(max(7.0, 1.6 * len(groups) + 3), 8.5))
    width = 0.8 / len(estimators)
    x = np.arange(len(groups))
    limit = None
    for j, (est, color) in enumerate(zip(estimators, series_colors(len(estimators)))):
        for i, cases in enumerate(groups.values()):
            c = cases.get(est)
            if c is None:
                continue
            v = c.verdicts[0]
            limit = v.limit
            shown = min(v.value, _CAP_PERCENT)
            pos = i + (j - (len(estimators) - 1) / 2) * width
            ax.bar(pos, shown, width, color=color, edgecolor="k", lw=0.6, hatch="//" if v.status == "fail" else None)
            text = f"{v.value:.3g}" if v.value > _CAP_PERCENT else ""
            ax.text(pos, shown, f"{text}\n{v.dominant}".strip(), rotation=90, ha="center", va="bottom", fontsize=6)
    if limit is not None:
        ax.axhline(limit, color="k", ls="--", lw=0.8)
    ax.set_xticks(x, list(groups), fontsize=7)
    ax.set_ylabel(wrapped(f"{result.requirement_names[0]} (%)", 50), fontsize=8)
    ax.set_ylim(0, _CAP_PERCENT * 1.45)
    colors = series_colors(len(estimators))
    handles = [Patch(facecolor=col, edgecolor="k", label=est) for est, col in zip(estimators, colors)]
    handles.append(Patch(facecolor="w", edgecolor="k", hatch="//", label="fails"))
    ax.legend(handles=handles, fontsize=7, title="estimator", title_fontsize=7)
    ax.grid(alpha=0.3, axis="y")
    width_ch = 0.8 / len(_CHANNELS)
    for j, (ch, color) in enumerate(zip(_CHANNELS, series_colors(len(_CHANNELS)))):
        for i, cases in enumerate(groups.values()):
            s = next(iter(cases.values())).scalars
            if f"{ch}.analytic.relative_mean_percent" not in s:
                continue
            pos = i + (j - 1) * width_ch
            ax_ch.errorbar(pos, s[f"{ch}.analytic.relative_mean_percent"],
                           yerr=3 * s[f"{ch}.analytic.relative_sd_percent"], fmt="o", color=color, capsize=3,
                           label=ch.upper() if i == 0 else None)
    ax_ch.axhline(0, color="k", lw=0.8)
    ax_ch.set_xticks(x, list(groups), fontsize=7)
    ax_ch.set_ylabel("relative error of $\\sigma_{pq}$ (%), mean ± 3 SD", fontsize=8)
    ax_ch.set_yscale("symlog", linthresh=5.0)
    ax_ch.legend(fontsize=7)
    ax_ch.grid(alpha=0.3)
    fig.tight_layout()
    return [(_save(fig, folder, "estimator_comparison"),
             "Top: the checked value of the first requirement for each AGB estimator (HV alone, HH, HV and VV "
             "together, ...), with the dominant error source of each verdict (hatched: fails; values above "
             f"{_CAP_PERCENT:g} % drawn at the cap and printed); dashed: the limit. Bottom: the relative errors of "
             "sigma_hh, sigma_hv and sigma_vv the estimators use (analytic mean and 3 SD; symmetric log scale).")]
