"""The report as a list of blocks (headings, paragraphs, tables, images), rendered to Markdown and to a
self-contained HTML page by ``e2esim.report.render``. Building the content once keeps the two in step."""

from __future__ import annotations

import math
from dataclasses import dataclass

from e2esim.io.summary import requirement_overview

_MAX_TABLE_ROWS = 200  # longer sweeps: tables show the first rows; summary.json and results.h5 have all


@dataclass(frozen=True)
class Heading:
    level: int
    text: str


@dataclass(frozen=True)
class Paragraph:
    text: str  # may contain `code` and **bold**


@dataclass(frozen=True)
class Table:
    header: tuple
    rows: tuple


@dataclass(frozen=True)
class Image:
    file: str  # PNG in the run folder
    caption: str


def fmt(x, digits=4) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if isinstance(x, float) and math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def verdict_lines(result) -> list:
    """Plain-text requirement summary (printed by ``e2esim run``)."""
    lines = []
    for row in requirement_overview(result):
        status = "PASS" if row["all_passed"] else "FAIL"
        lines.append(
            f"{status}  {row['name']}: {row['passed_cases']}/{row['passed_cases'] + row['failed_cases']} cases pass; "
            f"worst margin {fmt(row['worst_margin'], 3)} {row['unit']} (case {row['worst_case']}: "
            f"{row['worst_case_label']})"
        )
    return lines


def build_report(result, plots: list) -> list:
    """The blocks of the report of ``result`` with ``plots`` [(file, caption)]."""
    sc = result.scenario
    blocks = [Heading(1, sc.output.get("title") or sc.name)]
    if sc.description:
        blocks.append(Paragraph(sc.description.strip()))
    blocks.append(Heading(2, "Requirement verdicts"))
    if result.requirement_names:
        rows = []
        for row in requirement_overview(result):
            rows.append((row["name"], "PASS" if row["all_passed"] else "FAIL",
                         f"{row['passed_cases']}/{row['passed_cases'] + row['failed_cases']}",
                         f"{fmt(row['worst_margin'], 3)} {row['unit']}", f"{row['worst_case']}: {row['worst_case_label']}"))
        blocks.append(Table(("requirement", "verdict", "cases passing", "worst margin", "worst case"), tuple(rows)))
    else:
        blocks.append(Paragraph("The scenario states no requirements."))
    blocks += [Heading(2, "Cases"), _case_table(result), Paragraph(
        "σ and bias in m²/m² (linear), SD of the σ_hv error in m²/m²; AGB errors are relative, in percent, at the "
        "given one-sided quantile. Each verdict names its dominant contributor: the error source whose removal "
        "would reduce the checked value most (analytic model)." + _truncation_note(result))]
    notes = [f"Case {c.index} ({c.label}): {n}" for c in result.cases for n in c.notes]
    notes += [f"Case {c.index} ({c.label}), {v.name}: {n}" for c in result.cases for v in c.verdicts for n in v.notes]
    if notes:
        blocks += [Heading(2, "Notes")] + [Paragraph(n) for n in notes[:_MAX_TABLE_ROWS]]
    comparison = _comparison_table(result)
    if comparison is not None:
        blocks += [Heading(2, "Analytic model against Monte Carlo"), Paragraph(
            "Relative differences (Monte Carlo − analytic) / analytic of the mean and variance of the σ_hv error "
            "(Men et al. 2021, eq. 18), with their standard errors; |z| up to about 3 is agreement within sampling "
            "uncertainty."), comparison]
    margins = _margin_table(result)
    if margins is not None:
        blocks += [Heading(2, "Level margins"), Paragraph(
            "How far each error source could change, alone, before the verdict flips (analytic model, by root "
            "finding); limits in the instrument's level convention."), margins]
    if plots:
        blocks.append(Heading(2, "Plots"))
        blocks += [Image(name, caption) for name, caption in plots]
    blocks += [Heading(2, "Provenance"),
               Table(("item", "value"), tuple((k, str(v)) for k, v in result.provenance.items())),
               Paragraph("The resolved scenario is stored in results.h5 (`/provenance/resolved_scenario`).")]
    return blocks


def _truncation_note(result) -> str:
    n = len(result.cases) - _MAX_TABLE_ROWS
    return f" The table shows the first {_MAX_TABLE_ROWS} cases; {n} more are in summary.json and results.h5." if n > 0 else ""


def _case_table(result) -> Table:
    cols = [("σ_hv", "scene.sigma_hv", 4), ("bias (analytic)", "analytic.mean", 4),
            ("SD (analytic)", "analytic.sd", 4), ("bias (MC)", "montecarlo.mean", 4), ("SD (MC)", "montecarlo.sd", 4),
            ("AGB err. 0.135 %", "agb.analytic.q00135_percent", 3),
            ("AGB err. 99.865 %", "agb.analytic.q99865_percent", 3),
            ("AGB err. 99.865 % (MC)", "agb.montecarlo.q99865_percent", 3)]
    present = [c for c in cols if any(c[1] in case.scalars for case in result.cases)]
    header = ("case", "inputs") + tuple(c[0] for c in present) + tuple(result.requirement_names)
    rows = []
    for case in result.cases[:_MAX_TABLE_ROWS]:
        cells = [str(case.index), case.label] + [fmt(case.scalars.get(k), d) for _, k, d in present]
        cells += [_verdict_cell(v) for v in case.verdicts]
        rows.append(tuple(cells))
    return Table(header, tuple(rows))


def _verdict_cell(v) -> str:
    if v.details.get("applies", 1.0) == 0.0:
        return f"n/a ({fmt(v.value, 3)} {v.unit}; outside the requirement's AGB range)"
    dominant = f"; {v.dominant.replace('_', ' ')}" if v.dominant else ""
    return ("pass" if v.passed else "**FAIL**") + f" ({fmt(v.value, 3)} {v.unit}{dominant})"


def _comparison_table(result):
    cases = [c for c in result.cases if "comparison.bias_rel_diff" in c.scalars][:_MAX_TABLE_ROWS]
    if not cases:
        return None
    rows = []
    for c in cases:
        s = c.scalars
        zb = s["comparison.bias_rel_diff"] / s["comparison.bias_rel_se"]
        zv = s["comparison.var_rel_diff"] / s["comparison.var_rel_se"]
        rows.append((str(c.index), c.label,
                     f"{100 * s['comparison.bias_rel_diff']:.2f} % ± {100 * s['comparison.bias_rel_se']:.2f} %",
                     f"{zb:.2f}",
                     f"{100 * s['comparison.var_rel_diff']:.2f} % ± {100 * s['comparison.var_rel_se']:.2f} %",
                     f"{zv:.2f}"))
    return Table(("case", "inputs", "bias rel. diff.", "z", "variance rel. diff.", "z"), tuple(rows))


_LEVEL_NAMES = {"crosstalk": "crosstalk", "channel_imbalance": "channel imbalance", "nesz": "NESZ"}


def _margin_table(result):
    """Level margins of every verdict that has them: one column pair per level of the error model."""
    levels: list = []
    for c in result.cases[:_MAX_TABLE_ROWS]:
        for v in c.verdicts:
            levels += [k[: -len(".limit_db")] for k in v.details if k.endswith(".limit_db")]
    levels = list(dict.fromkeys(levels))
    if not levels:
        return None
    rows = []
    for c in result.cases[:_MAX_TABLE_ROWS]:
        for v in c.verdicts:
            if not any(f"{level}.limit_db" in v.details for level in levels):
                continue
            cells = [str(c.index), v.name]
            for level in levels:
                cells += [fmt(v.details.get(f"{level}.limit_db"), 4), fmt(v.details.get(f"{level}.margin_db"), 3)]
            rows.append(tuple(cells))
    header = ["case", "requirement"]
    for level in levels:
        header += [f"{_LEVEL_NAMES.get(level, level.replace('_', ' '))} limit (dB)", "margin"]
    return Table(tuple(header), tuple(rows))
