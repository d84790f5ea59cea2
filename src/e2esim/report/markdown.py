"""report.md: what a person reads after a run: verdicts, key numbers per case, plots, provenance."""

from __future__ import annotations

import math

from e2esim.io.atomic import write_text_atomic
from e2esim.io.summary import requirement_overview

_MAX_TABLE_ROWS = 200  # longer sweeps: the table shows the first rows; results.h5 has them all


def _fmt(x, digits=4) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if isinstance(x, float) and math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def verdict_lines(result) -> list:
    """Plain-text requirement summary (also printed by ``e2esim run``)."""
    lines = []
    for row in requirement_overview(result):
        status = "PASS" if row["all_passed"] else "FAIL"
        lines.append(
            f"{status}  {row['name']}: {row['passed_cases']}/{row['passed_cases'] + row['failed_cases']} cases pass; "
            f"worst margin {_fmt(row['worst_margin'], 3)} {row['unit']} (case {row['worst_case']}: "
            f"{row['worst_case_label']})"
        )
    return lines


def render_report(result, plots: list) -> str:
    sc = result.scenario
    title = sc.output.get("title") or sc.name
    out = [f"# {title}", ""]
    if sc.description:
        out += [sc.description.strip(), ""]
    out += ["## Requirement verdicts", ""]
    if result.requirement_names:
        out += ["| requirement | verdict | cases passing | worst margin | worst case |", "|---|---|---|---|---|"]
        for row in requirement_overview(result):
            out.append(
                f"| {row['name']} | {'PASS' if row['all_passed'] else 'FAIL'} | "
                f"{row['passed_cases']}/{row['passed_cases'] + row['failed_cases']} | "
                f"{_fmt(row['worst_margin'], 3)} {row['unit']} | {row['worst_case']}: {row['worst_case_label']} |"
            )
    else:
        out.append("The scenario states no requirements.")
    out += ["", "## Cases", ""]
    out += _case_table(result)
    comparison = _comparison_table(result)
    if comparison:
        out += ["", "## Analytic model against Monte Carlo", "",
                "Relative differences (Monte Carlo − analytic) / analytic of the mean and variance of the σ_hv "
                "error (Men et al. 2021, eq. 18), with their standard errors; |z| up to about 3 is agreement "
                "within sampling uncertainty.", ""]
        out += comparison
    margins = _margin_table(result)
    if margins:
        out += ["", "## Level margins", "",
                "How far each error source could change, alone, before the verdict flips (analytic model, by "
                "root finding); limits in the instrument's level convention.", ""]
        out += margins
    if plots:
        out += ["", "## Plots", ""]
        for name, caption in plots:
            out += [f"![{caption}]({name})", "", f"*{caption}*", ""]
    out += ["", "## Provenance", "", "| item | value |", "|---|---|"]
    for key, value in result.provenance.items():
        out.append(f"| {key} | {value} |")
    out += ["", "The resolved scenario is stored in results.h5 (`/provenance/resolved_scenario`).", ""]
    return "\n".join(out)


def _case_table(result) -> list:
    cols = [("σ_hv", "scene.sigma_hv", 4), ("bias (analytic)", "analytic.mean", 4),
            ("SD (analytic)", "analytic.sd", 4), ("bias (MC)", "montecarlo.mean", 4), ("SD (MC)", "montecarlo.sd", 4),
            ("AGB err. 0.135 %", "agb.analytic.q00135_percent", 3), ("AGB err. 99.865 %", "agb.analytic.q99865_percent", 3),
            ("AGB err. 99.865 % (MC)", "agb.montecarlo.q99865_percent", 3)]
    present = [c for c in cols if any(c[1] in case.scalars for case in result.cases)]
    header = ["case", "inputs"] + [c[0] for c in present] + list(result.requirement_names)
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for case in result.cases[:_MAX_TABLE_ROWS]:
        cells = [str(case.index), case.label] + [_fmt(case.scalars.get(k), d) for _, k, d in present]
        cells += [("pass" if v.passed else "**FAIL**") + f" ({_fmt(v.value, 3)} {v.unit})" for v in case.state.verdicts]
        lines.append("| " + " | ".join(cells) + " |")
    if len(result.cases) > _MAX_TABLE_ROWS:
        lines.append(f"\n{len(result.cases) - _MAX_TABLE_ROWS} more cases in summary.json and results.h5.")
    lines += ["", "σ and bias in m²/m² (linear), SD of the σ_hv error in m²/m²; AGB errors are relative, in percent, "
              "at the given one-sided quantile."]
    return lines


def _comparison_table(result) -> list:
    rows = [c for c in result.cases if "comparison.bias_rel_diff" in c.scalars][:_MAX_TABLE_ROWS]
    if not rows:
        return []
    lines = ["| case | inputs | bias rel. diff. | z | variance rel. diff. | z |", "|---|---|---|---|---|---|"]
    for c in rows:
        s = c.scalars
        zb = s["comparison.bias_rel_diff"] / s["comparison.bias_rel_se"]
        zv = s["comparison.var_rel_diff"] / s["comparison.var_rel_se"]
        lines.append(
            f"| {c.index} | {c.label} | {100 * s['comparison.bias_rel_diff']:.2f} % ± {100 * s['comparison.bias_rel_se']:.2f} % "
            f"| {zb:.2f} | {100 * s['comparison.var_rel_diff']:.2f} % ± {100 * s['comparison.var_rel_se']:.2f} % | {zv:.2f} |"
        )
    return lines


def _margin_table(result) -> list:
    lines = []
    for c in result.cases[:_MAX_TABLE_ROWS]:
        for v in c.state.verdicts:
            if "crosstalk.limit_db" not in v.details:
                continue
            if not lines:
                lines = ["| case | requirement | crosstalk limit (dB) | margin | channel imbalance limit (dB) | margin "
                         "| NESZ limit (dB) | margin |", "|---|---|---|---|---|---|---|---|"]
            d = v.details
            lines.append(
                f"| {c.index} | {v.name} | {_fmt(d['crosstalk.limit_db'], 4)} | {_fmt(d['crosstalk.margin_db'], 3)} "
                f"| {_fmt(d['channel_imbalance.limit_db'], 4)} | {_fmt(d['channel_imbalance.margin_db'], 3)} "
                f"| {_fmt(d['nesz.limit_db'], 4)} | {_fmt(d['nesz.margin_db'], 3)} |"
            )
    return lines


def write_report(result, path, plots: list) -> None:
    write_text_atomic(path, render_report(result, plots))
