"""The report as a list of blocks (``e2esim.report.blocks``), rendered to Markdown and to a self-contained
HTML page by ``e2esim.report.render``. Building the content once keeps the two in step.

The first screen answers the question: a conclusion per requirement, the verdict table, the error budget.
Then the margins, the assumptions, the plots; long tables (more than 20 rows) come after the plots,
collapsed. The report draws what the chain computed; it computes nothing physical.
"""

from __future__ import annotations

import inspect

import numpy as np

from e2esim.io.allocation_table import allocation_overview
from e2esim.io.summary import LARGE_RUN_CASES, requirement_overview
from e2esim.maps.grid import is_map_sweep
from e2esim.maps.netcdf import not_acquired_summary
from e2esim.report import tables
from e2esim.report.assumptions import assumption_rows
from e2esim.report.blocks import (
    STATUS_WORDS,
    Badge,
    Details,
    Heading,
    Image,
    Paragraph,
    Table,
    Warning,
    fmt,
    table_blocks,
)
from e2esim.report.conclusions import conclusions, error_term_sentences
from e2esim.report.no_effect_section import no_effect_section
from e2esim.report.outliers import error_meaning
from e2esim.report.sensitivity_blocks import sensitivity_blocks
from e2esim.report.sensitivity_table import SENSITIVITY_NOTE, exponent_sensitivity_table
from e2esim.report.uncertainty import uncertainty_flags

__all__ = [
    "Badge",
    "Details",
    "Heading",
    "Image",
    "Paragraph",
    "Table",
    "Warning",
    "build_report",
    "fmt",
    "verdict_lines",
]


def verdict_lines(result) -> list:
    """Plain-text requirement summary (printed by ``e2esim run``): the verdict, the cases passing (and not
    applicable), the worst margin over the cases the requirement applies to, and what the verdicts cover."""
    lines = []
    for j, row in enumerate(requirement_overview(result)):
        status = STATUS_WORDS[row["status"]]
        if row["worst_case"] is None:
            lines.append(f"{status}  {row['name']}: applies to none of the {row['not_applicable_cases']} cases")
        else:
            total = row["passed_cases"] + row["failed_cases"]
            outside = f", {row['not_applicable_cases']} not applicable" if row["not_applicable_cases"] else ""
            meaning = error_meaning(result.table.requirements[j].value[row["worst_case"]], row["unit"])
            lines.append(f"{status}  {row['name']}: {row['passed_cases']}/{total} cases pass{outside}; worst margin "
                         f"{fmt(row['worst_margin'], 3)} {row['unit']} (case {row['worst_case']}: "
                         f"{row['worst_case_label']}{'; ' + meaning if meaning else ''})")
        lines.append(f"      covers: {tables.coverage_words(row)}")
        lines += [f"      ! {flag}" for flag in uncertainty_flags(result, j)]
    return lines


def build_report(result, plots: list, warnings: list = ()) -> list:
    """The blocks of the report of ``result`` with ``plots`` [(file, caption)] and plot ``warnings``."""
    sc = result.scenario
    blocks = [Heading(1, sc.output.get("title") or sc.name)]
    answer = getattr(result, "answer", None)
    if answer:  # the scenario's own question (solve or allocate section), answered first
        blocks += [Heading(2, "Answer")] + [Paragraph(line.strip()) for line in answer["lines"]]
    if result.requirement_names:
        blocks += [Heading(2, "Conclusions")] + [Paragraph(f"{b} {sentence}") for b, sentence in conclusions(result)]
        blocks += [Paragraph(f"**Error term:** {sentence}") for sentence in error_term_sentences(result)]
        blocks += [Paragraph(f"**How sure:** {name}: {flag}") for j, name in enumerate(result.requirement_names)
                   for flag in uncertainty_flags(result, j)]
        blocks += [Heading(2, "Requirement verdicts"), tables.verdict_table(result), Paragraph(_scope_note(result))]
        blocks += _allocation_blocks(result)
        blocks += _budget_section(result, plots)
    else:
        blocks += [Paragraph("The scenario states no requirements.")]
    blocks += no_effect_section(result)
    if sc.description:
        blocks += [Heading(2, "Scenario"), Paragraph(sc.description.strip())]
    if is_map_sweep(sc):  # thousands of cells: the maps and results.nc instead of per-case tables
        return blocks + _assumptions_section(result) + _plots_section(plots, warnings) + [
            Heading(2, "Cases"), Paragraph(MAP_CASES_NOTE.format(n=len(result.cases)))] + _not_acquired(result) \
            + _note_counts(result) + _provenance_section(result)
    if _large(result):
        return blocks + _assumptions_section(result) + _plots_section(plots, warnings) + [
            Heading(2, "Cases"), Paragraph(LARGE_CASES_NOTE.format(n=len(result.cases), most=LARGE_RUN_CASES))] \
            + _note_counts(result) + _provenance_section(result)
    margins = tables.margin_table(result)
    if margins is not None:
        blocks += [Heading(2, "Level margins")] + table_blocks("Margins of each error level", margins, (
            "How far each error level could change, alone, before the verdict flips (analytic model, by root "
            "finding), in the instrument's level convention; NESZ as 10 log10 of the noise power. Two margins: "
            "to the **specification** the scenario states (before calibration) and to the **residual after "
            "calibration**, the level the propagation applies, whose value is shown."))
    blocks += _assumptions_section(result)
    blocks += _plots_section(plots, warnings)
    blocks += [Heading(2, "Cases")] + table_blocks("Every case", tables.case_table(result), (
        "σ and bias in m²/m² (linear); the σ_hv bias and SD are the systematic error (system distortions, Faraday "
        "rotation and noise); the AGB error quantiles cover every error source the chain models. Each verdict "
        "names its dominant contributor: the error source whose removal would reduce the checked value most."))
    comparison = tables.comparison_table(result)
    if comparison is not None:
        blocks += table_blocks("Analytic model against Monte Carlo", comparison, (
            "Relative differences (Monte Carlo − analytic) / analytic of the mean and variance of the σ_hv error "
            "(Men et al. 2021, eq. 18), with their standard errors; |z| up to about 3 is agreement within sampling "
            "uncertainty."))
    notes = [f"Case {c.index} ({c.label}): {n}" for c in result.cases for n in c.notes]
    notes += [f"Case {c.index} ({c.label}), {v.name}: {n}" for c in result.cases for v in c.verdicts for n in v.notes]
    if notes:
        note_blocks = tuple(Paragraph(n) for n in notes)
        blocks += [Heading(2, "Notes")] + (list(note_blocks) if len(notes) <= 5 else
                                           [Details(f"{len(notes)} notes on the cases", note_blocks)])
    return blocks + _provenance_section(result)


MAP_CASES_NOTE = ("This map sweep has {n} cases (cells x months x passes x solar levels): their numbers are in "
                  "results.nc, one variable per output on the map's grid (docs/output-format.md), and in results.h5; "
                  "the per-case tables are left out of the report.")


LARGE_CASES_NOTE = ("This run has {n} cases, more than {most}: the per-case tables and plots are left out of the "
                    "report and summary.json; every case's inputs, results and verdicts are in results.h5 "
                    "(`e2esim.open_results`, then `to_dataframe()` or `to_xarray()`).")


def _not_acquired(result) -> list:
    """The paragraph on a map sweep's cells the mission does not acquire (none without an acquisition mask)."""
    excluded = not_acquired_summary(result)
    if excluded is None:
        return []
    return [Paragraph(f"Not acquired: {excluded['cells']} forest cells lie where the mission does not acquire "
                      f"({excluded['mask']}): {excluded['forest_area_km2'] / 1e6:.2f} million km² of forest, "
                      f"{100 * excluded['forest_area_fraction']:.1f} % of the forest area of the map. They have no "
                      "cases, show as not acquired on the verdict maps (`requirement<j>_state` = 3 in results.nc) and "
                      "are left out of the share of the forest area meeting each requirement.")]


def _large(result) -> bool:
    return len(result.scenario.cases) > LARGE_RUN_CASES


def _note_counts(result) -> list:
    """The error model's notes of a large run, each with the number of cases it concerns."""
    notes = result.table.notes
    counts = np.bincount(notes.index, minlength=len(notes.values))
    per_note: dict = {}
    for value, count in zip(notes.values, counts):
        for note in value:
            per_note[note] = per_note.get(note, 0) + int(count)
    if not per_note:
        return []
    paragraphs = tuple(Paragraph(f"{count} cases: {note}") for note, count in per_note.items())
    return [Heading(2, "Notes"), Details(f"{len(per_note)} notes on the cases", paragraphs)]


def _provenance_section(result) -> list:
    return [Heading(2, "Provenance"),
            Table(("item", "value"), tuple((k, _provenance_text(v)) for k, v in result.provenance.items())),
            Paragraph("The resolved scenario is stored in results.h5 (`/provenance/resolved_scenario`).")]


def _scope_note(result) -> str:
    return ("Error sources covered: the sources each verdict's checked value contains, as the chain computed them "
            "(the error model's sources, the random-error budget's terms, the regression or retrieval-model "
            "uncertainty), and the terms this chain does not compute. A requirement checks **computed sources** "
            "(all the chain computes), **all sources** (the same, checked at validation to include speckle and a "
            "regression or retrieval-model term, computed or stated as assumed) or the **system errors** only. "
            "N/A: the requirement does not apply to the case (outside its stated range); such cases have no margin "
            "and are not counted as passing.")


def _allocation_blocks(result) -> list:
    out = []
    for j, name in enumerate(result.requirement_names):
        table = tables.allocation_table(result, j)
        if table is not None:
            worst = allocation_overview(result, j)["case"]
            out += table_blocks(f"{name}: allocation", table,
                                ALLOCATION_NOTE.format(case=f"{worst}: {result.labels[worst]}"))
    return out


ALLOCATION_NOTE = (
    "What the requirement allots to each error source (`allocation_percent` or `allocation_share`), its current best "
    "estimate (the source's share of the checked value: the estimates add up to it, see Error budget) and the margin "
    "(allocation − estimate; negative: the source overruns its allocation), at the requirement's worst case ({case}); "
    "the last column is the smallest margin of the source over the cases, and where.")


def _budget_section(result, plots) -> list:
    out = [Heading(2, "Error budget"), Paragraph(
        "The part of each requirement's checked value each error source accounts for: its share of the mean square "
        "of the σ error (RMSE) or of its Gaussian quantile (bounds), by the Euler principle, carried to the checked "
        "value in proportion, so that the parts add up to it (analytic model; docs/theory/error-budget.md). "
        "'not attributed' is the part no single source accounts for, where the error model couples its sources; "
        "it is zero where they add. Where it would exceed 1 % of the checked value, the line (column 'split') uses "
        "the Shapley split instead: each source's average effect over every subset of the other sources switched "
        "on, which adds up with no remainder however the sources couple. The tables also give, in brackets, how "
        "much the value falls when the source "
        "alone is removed. Systematic: system distortions, Faraday rotation, noise; random: the error budget of the "
        "product (speckle and noise, temporal variability, calibration, area projection); regression: the retrieval "
        "model's calibration uncertainty; model: the uncertainty of the retrieval's exponents and coefficients away "
        "from their calibration.")]
    out += [Image(name, caption) for name, caption in plots if name == "error_budget.png"]
    if is_map_sweep(result.scenario) or _large(result):
        return out
    for j, name in enumerate(result.requirement_names):
        table = tables.budget_table(result, j)
        if table is not None:
            out += table_blocks(f"{name}: contribution of each source (share; removal in brackets)", table)
    agb = tables.agb_budget_table(result)
    if agb is not None:
        out += table_blocks("Relative AGB error each source causes on its own", agb, (
            "RMSE of the relative AGB error from the source alone, and its share of the variance of the relative "
            "σ_hv error (scalars `agb.contribution.<source>.*`)."))
    out += [Image(name, caption) for name, caption in plots if name == "sensitivity.png"]
    out += sensitivity_blocks(result)
    sensitivity = exponent_sensitivity_table(result)
    if sensitivity is not None:
        out += table_blocks("Sensitivity of the AGB error to the retrieval's exponents", sensitivity, SENSITIVITY_NOTE)
    return out


def _assumptions_section(result) -> list:
    table = result.table
    key_rows, other_rows = assumption_rows(result.scenario, table.scalar("budget.looks")[table.has("budget.looks")]
                                           if "budget.looks" in table.scalars else ())
    if not key_rows and not other_rows:
        return []
    out = [Heading(2, "Assumptions"), Paragraph(
        "The settings the verdicts rest on, for the first case (swept settings vary: see the cases), and where each "
        "comes from: the scenario, or a module's default or preset (with the source the code gives).")]
    out.append(Table(("setting", "value", "source"), tuple(key_rows)))
    notes = _preset_sources(result)
    if notes:
        out.append(Details("Sources of the module presets", tuple(Paragraph(n) for n in notes)))
    if other_rows:
        out.append(Details(f"Every other setting ({len(other_rows)})", (Table(("setting", "value", "source"),
                                                                               tuple(other_rows)),)))
    return out


def _preset_sources(result) -> list:
    """The documentation of each preset module in the chain (its class docstring cites the sources)."""
    out = []
    for module in result.scenario.cases[0].modules if result.scenario.cases else []:
        doc = inspect.getdoc(type(module)) or ""
        if "preset" in (getattr(module, "summary", "") or "").lower() and doc:
            out.append(f"{module.kind} type `{module.type_name}`: " + " ".join(doc.split()))
    return out


def _plots_section(plots, warnings) -> list:
    shown = [(name, caption) for name, caption in plots if name != "error_budget.png"]
    if not shown and not warnings:
        return []
    out = [Heading(2, "Plots")]
    out += [Warning(f"Plot {w}") for w in warnings]
    out += [Image(name, caption) for name, caption in shown]
    return out


def _provenance_text(value) -> str:
    if isinstance(value, dict):
        return ", ".join(f"{k} {v}" for k, v in value.items())
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):  # input_files
        return "; ".join(_provenance_text(v) for v in value)
    return "–" if value is None else str(value)
