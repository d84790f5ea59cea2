"""Report plot ``sensitivity`` (drawn when ``output.sensitivity: true``): for every requirement, at its worst case,
the elasticity of the checked value to each numeric parameter of the chain (``result.sensitivity``,
``e2esim.runner.sensitivity``) as a tornado chart; its tables are ``e2esim.report.sensitivity_blocks``. Nothing is
computed here."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt

from e2esim.report.plot_base import PlotSkipped, save
from e2esim.report.sensitivity_blocks import by_key, ranked_requirements

TORNADO_BARS = 15
"""Parameters shown per requirement in the tornado chart (the largest margins bought)."""


def _label(p: dict) -> str:
    return f"{p['key']} ({'per dB' if p['kind'] == 'per_db' else 'per ln'})"


def plot_sensitivity(result, folder: Path, options: dict) -> list:
    parts = ranked_requirements(result)
    if not parts:
        raise PlotSkipped("no sensitivity was computed (output.sensitivity: true computes it)")
    table = result.sensitivity
    heights = [1.0 + 0.28 * min(len(r["ranked"]), TORNADO_BARS) for r in parts]
    fig, axes = plt.subplots(len(parts), 1, figsize=(9.5, sum(heights) + 0.4), squeeze=False,
                             gridspec_kw={"height_ratios": heights})
    for ax, req in zip(axes[:, 0], parts):
        params = by_key(req)
        shown = [params[k] for k in req["ranked"][:TORNADO_BARS]]
        values = [p["elasticity"] for p in shown]
        ax.barh(range(len(shown)), values, color=["tab:red" if v > 0 else "tab:blue" for v in values], height=0.7)
        ax.set_yticks(range(len(shown)), [_label(p) for p in shown], fontsize=7)
        ax.invert_yaxis()
        ax.axvline(0, color="k", lw=0.6)
        ax.grid(alpha=0.3, axis="x")
        ax.set_xlabel("elasticity of the checked value", fontsize=8)
        ax.set_title(f"{req['name']}: case {req['case']}", fontsize=9)
    fig.tight_layout()
    return [(save(fig, folder, "sensitivity"),
             "Sensitivity of each requirement's checked value at its worst case: the elasticity d ln V / d ln p of "
             f"the {TORNADO_BARS} parameters that buy the most margin (per dB, d ln V / dp, for a parameter in dB), by "
             f"central differences (steps {100 * table['relative_step']:g} % and {table['db_step']:g} dB; analytic "
             "model). Red: raising the parameter raises the checked value (uses margin); blue: it lowers it.")]
