"""Report plot ``sensitivity`` (drawn when ``output.sensitivity: true``) and its table: for every requirement, at its
worst case, the elasticity of the checked value to each numeric parameter of the chain (``result.sensitivity``,
``e2esim.runner.sensitivity``) as a tornado chart, and the parameters ranked by the margin they buy. Nothing is
computed here."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt

from e2esim.report.blocks import Paragraph, Table, fmt, table_blocks
from e2esim.report.plot_base import PlotSkipped, save

TORNADO_BARS = 15
"""Parameters shown per requirement in the tornado chart (the largest margins bought)."""


def _parts(result) -> list:
    table = getattr(result, "sensitivity", None) or {}
    return [r for r in table.get("requirements", ()) if r["ranked"]]


def _by_key(req: dict) -> dict:
    return {p["key"]: p for p in req["parameters"]}


def _label(p: dict) -> str:
    return f"{p['key']} ({'per dB' if p['kind'] == 'per_db' else 'per ln'})"


def plot_sensitivity(result, folder: Path, options: dict) -> list:
    parts = _parts(result)
    if not parts:
        raise PlotSkipped("no sensitivity was computed (output.sensitivity: true computes it)")
    table = result.sensitivity
    heights = [1.0 + 0.28 * min(len(r["ranked"]), TORNADO_BARS) for r in parts]
    fig, axes = plt.subplots(len(parts), 1, figsize=(9.5, sum(heights) + 0.4), squeeze=False,
                             gridspec_kw={"height_ratios": heights})
    for ax, req in zip(axes[:, 0], parts):
        params = _by_key(req)
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


def sensitivity_table(result, req: dict) -> Table:
    """The parameters of one requirement ranked by the margin they buy, then those with no effect or no
    elasticity (each with why)."""
    params = _by_key(req)
    buy = result.sensitivity
    rows = []
    for key in req["ranked"]:
        p = params[key]
        if not p["effect"]:
            continue
        step = f"{buy['buy_db']:g} dB" if p["kind"] == "per_db" else f"{100 * buy['buy_relative']:g} %"
        better = "lower" if p["elasticity"] > 0 else "higher"
        rows.append((key, f"{fmt(p['value'], 4)} {p['unit']}".strip(), fmt(p["elasticity"], 3),
                     "per dB" if p["kind"] == "per_db" else "d ln V / d ln p",
                     f"{fmt(p['margin_bought'], 3)} ({step} {better})", p["note"]))
    rows += [(p["key"], f"{fmt(p['value'], 4)} {p['unit']}".strip(), "–", "", "–", p["note"])
             for p in req["parameters"] if not p["effect"]]
    return Table(("parameter", "value", "elasticity", "as", "margin bought", "note"), tuple(rows))


def sensitivity_blocks(result) -> list:
    """The report's tables: one per requirement with a sensitivity."""
    table = getattr(result, "sensitivity", None)
    if not table:
        return []
    out = []
    if table.get("note"):
        out.append(Paragraph(f"Sensitivity: {table['note']}."))
    for req in _parts(result):
        out += table_blocks(f"{req['name']}: the parameters that buy the most margin (case {req['case']})",
                            sensitivity_table(result, req), SENSITIVITY_INTRO)
    return out


SENSITIVITY_INTRO = (
    "Each numeric parameter of the chain, stepped down and up around its value at the requirement's worst case "
    "(central differences; one-sided where a step leaves the allowed range), each step a run of its own with the same "
    "random numbers; the margin a parameter buys is |elasticity| × the checked value for the improvement stated "
    "(10 % of the parameter, or 1 dB), in the requirement's unit. Parameters with no effect are listed last.")
