"""One sentence per requirement that answers the review's question: does it pass, in how many cases, how
far off is the worst case, and which error source contributes most there (from its attribution)."""

from __future__ import annotations

import numpy as np

from e2esim.io.error_budget import agb_budget, source_groups, unit_key
from e2esim.io.summary import requirement_overview
from e2esim.report.blocks import fmt, status_badge
from e2esim.report.outliers import error_meaning
from e2esim.report.tables import coverage_words
from e2esim.report.uncertainty import with_standard_error
from e2esim.requirements.source_names import source_name


def conclusions(result) -> list:
    """[(Badge, sentence)] in requirement order."""
    out = []
    for j, row in enumerate(requirement_overview(result)):
        total = row["passed_cases"] + row["failed_cases"]
        if row["worst_case"] is None:
            out.append((status_badge("not_applicable"),
                        f"{row['name']}: applies to none of the {len(result.cases)} cases."))
            continue
        worst = result.cases[row["worst_case"]]
        v = worst.verdicts[j]
        verb = (
            f"passes in all {total} cases" if row["all_passed"] else f"fails in {row['failed_cases']} of {total} cases"
        )
        outside = (f" ({row['not_applicable_cases']} cases outside its range: not applicable)"
                   if row["not_applicable_cases"] else "")
        value = with_standard_error(v.value, v.details.get("value_standard_error"))
        sentence = (f"{row['name']} {verb}{outside}; worst case {worst.index} "
                    f"({worst.label}): {value} {v.unit}{_meaning(v)} against a limit of {fmt(v.limit, 3)} {v.unit}")
        sentence += _dominant_clause(worst, v) + f". It covers {coverage_words(row)}."
        out.append((status_badge(row["status"]), sentence))
    return out


NEGLIGIBLE_SHARE = 0.1
"""An error term is called negligible in a case where it moves the checked value by less than this share of the
requirement's limit (its attribution: the value with and without it)."""


def error_term_sentences(result) -> list:
    """One sentence per requirement and error term of the ``error_terms`` list: the largest change of the checked
    value it causes, and in how many cases it is negligible (``NEGLIGIBLE_SHARE`` of the limit), naming the cases
    where it is not. Read from the result's columns (``ResultTable``), not case by case: a 1 deg map has 150 000
    cases, and only the cases the sentence names are made."""
    modules = result.scenario.cases[0].modules if result.scenario.cases else ()
    sources = [m.source for m in modules if getattr(m, "kind", None) == "error_terms" and hasattr(m, "source")]
    out = []
    for j, name in enumerate(result.requirement_names):
        verdicts = result.table.requirements[j]
        for source in dict.fromkeys(sources):
            share, present = _contribution_column(verdicts, source, result.table.n)
            rows = np.flatnonzero(present)
            if not len(rows):
                continue
            size = np.abs(share[rows])
            worst_row = int(rows[np.argmax(size)]) if not np.isnan(size).any() else int(rows[_first_max(size)])
            case = result.cases[worst_row]
            v = case.verdicts[j]
            worst = abs(float(share[worst_row]))
            unit = "percentage points" if v.unit == "%" else v.unit
            large = rows[size >= NEGLIGIBLE_SHARE * np.abs(np.asarray(verdicts.limit, dtype=float)[rows])]
            small = int(np.count_nonzero(size < NEGLIGIBLE_SHARE * np.abs(np.asarray(verdicts.limit, dtype=float)[
                rows])))
            sentence = (f"{source_name(source)} changes the checked value of {name} by at most {fmt(worst, 3)} "
                        f"{unit} (case {case.index}: {case.label}); it is negligible (below a tenth of the limit, "
                        f"{fmt(NEGLIGIBLE_SHARE * abs(float(v.limit)), 3)} {unit}) in {small} of {len(rows)} "
                        "cases")
            if len(large):
                labels = [result.cases[int(k)].label for k in large[:4]]
                sentence += f"; not in {', '.join(labels)}" + (f" and {len(large) - 4} more" if len(large) > 4
                                                               else "")
            out.append(sentence + ".")
    return out


def _contribution_column(verdicts, source: str, n: int) -> tuple:
    """(share, present): the detail ``contribution.<source>_<unit key>`` of every case, in the unit of the case's
    verdict, and where a case has it."""
    share, present = np.full(n, np.nan), np.zeros(n, dtype=bool)
    units = verdicts.unit
    position = np.asarray(units.index)
    for u, unit in enumerate(units.values):
        key = f"contribution.{source}_{unit_key(unit)}"
        if key not in verdicts.details:
            continue
        column = verdicts.details[key]
        here = position == u
        if column.present is not None:
            here &= column.present
        share[here], present[here] = column.values[here], True
    return share, present


def _first_max(size: np.ndarray) -> int:
    """The position ``max`` picks in a list of these numbers (the first largest, comparisons with NaN false)."""
    best = 0
    for k in range(1, len(size)):
        if size[k] > size[best]:
            best = k
    return best


def _dominant_clause(case, v) -> str:
    if not v.dominant:
        return ""
    share = v.details.get(f"contribution.{v.dominant}_{unit_key(v.unit)}")
    clause = f"; {source_name(v.dominant)} contributes most"
    if share is not None:
        points = "percentage points" if v.unit == "%" else v.unit
        clause += f" (without it the value would be {fmt(share, 3)} {points} lower"
        alone = {r["source"]: r for r in agb_budget(case.scalars, source_groups(case))}.get(v.dominant)
        if alone is not None and v.unit == "%" and "analytic.rmse_percent" in v.details:
            clause += f"; on its own it gives an RMSE of {fmt(alone['rmse_percent'], 3)} of the {fmt(v.value, 3)} %"
        clause += ")"
    return clause


def _meaning(v) -> str:
    meaning = error_meaning(v.value, v.unit)  # a relative error of 1.8e7 % read as what it is
    return f" ({meaning.partition(', ')[2]})" if meaning else ""
