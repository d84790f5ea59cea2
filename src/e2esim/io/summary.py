"""summary.json: the machine-readable result of a run, per case and per requirement.

Non-finite numbers (NaN, +-inf) are written as null, so the file is strict JSON.
Layout in docs/output-format.md.
"""

from __future__ import annotations

import json

import numpy as np

from e2esim.atomic import write_text_atomic
from e2esim.io.allocation_table import allocation_overview
from e2esim.io.case_entries import case_entries, json_safe
from e2esim.maps.netcdf import not_acquired_summary
from e2esim.runner.no_effect import no_effect


def requirement_sources(resolved) -> list:
    """Per requirement, its ``sources`` setting ("computed", "all" or "systematic"; "computed" for a requirement
    without one). What each verdict actually covers is its ``coverage`` (``e2esim.requirements.coverage``)."""
    from e2esim.requirements.coverage import setting

    modules = resolved.cases[0].modules if resolved.cases else []
    return [setting(m) for m in modules if m.kind == "requirement"]


def coverage_overview(r) -> list:
    """[{sources, text, cases}] of one requirement's columns: each distinct coverage with its number of cases (in
    the order first met), counted per distinct pair of codes, not per case."""
    coverage, text = r.coverage, r.coverage_text
    # one integer per pair (a sort of a million integers, not of a million rows)
    width = max(len(text.values), 1)
    codes = np.asarray(coverage.index, dtype=np.int64) * width + np.asarray(text.index, dtype=np.int64)
    pairs, first, counts = np.unique(codes, return_index=True, return_counts=True)
    out: dict = {}
    for k in np.argsort(first, kind="stable"):
        a, b = divmod(int(pairs[k]), width)
        key = (tuple(coverage.values[a]), text.values[b])
        out[key] = out.get(key, 0) + int(counts[k])
    return [{"sources": list(sources), "text": words, "cases": count} for (sources, words), count in out.items()]


def requirement_overview(result) -> list:
    """Per requirement: how many cases pass, fail and are not applicable, the worst margin over the cases it
    applies to and where it occurs, and what its verdicts cover (from the run's columns)."""
    rows = []
    sources = requirement_sources(result.scenario)
    table = result.table
    labels = result.labels
    for j, name in enumerate(result.requirement_names):
        r = table.requirements[j]
        applies = table.applies(j)  # the cases the requirement applies to
        passed = np.asarray(r.passed)[applies]
        worst = None
        if applies.any():
            candidates = np.nonzero(applies)[0]
            margins = r.margin[candidates]
            worst = int(candidates[np.argmin(np.where(np.isfinite(margins), margins, np.inf))])  # the first of equals
        status = "not_applicable" if worst is None else "pass" if passed.all() else "fail"
        rows.append({
            "name": name,
            "sources": sources[j] if j < len(sources) else "computed",
            "coverage": coverage_overview(r),
            "status": status,
            "passed_cases": int(passed.sum()),
            "failed_cases": int((~passed).sum()),
            "not_applicable_cases": int(table.n - applies.sum()),
            "all_passed": status == "pass",
            "worst_margin": float(r.margin[worst]) if worst is not None else float("nan"),
            "unit": r.unit[worst if worst is not None else 0],
            "worst_case": worst,
            "worst_case_label": labels[worst] if worst is not None else None,
        })
        allocation = allocation_overview(result, j)
        if allocation is not None:
            rows[-1]["allocation"] = allocation
    return rows


LARGE_RUN_CASES = 10_000
"""Runs with more cases leave the per-case entries out of summary.json and the per-case tables and plots out
of the report: every case is in results.h5 (docs/output-format.md). A per-case JSON entry takes 2 to 20 kB; made
from the columns (``e2esim.io.case_entries``) and encoded it takes about 0.4 ms (the 1 degree scintillation/RFI
map region, 3,024 cases of 21 kB: 0.1 ms to make, 0.3 ms to encode); past ten thousand cases nobody reads them,
and a million would take minutes."""


def summary_dict(result) -> dict:
    n = len(result.scenario.cases)
    head = {"scenario": result.scenario.name, **({"answer": result.answer} if getattr(result, "answer", None)
                                                 else {}), **result.provenance, "n_cases": n,
            "requirements": requirement_overview(result),
            "settings_without_effect": [f.as_dict() for f in no_effect(result)]}
    excluded = not_acquired_summary(result)  # a map sweep's cells the mission does not acquire
    if excluded is not None:
        head["not_acquired"] = excluded
    if getattr(result, "sensitivity", None):
        head["sensitivity"] = result.sensitivity
    if n > LARGE_RUN_CASES:
        return json_safe({**head, "cases_omitted": f"{n} cases, more than {LARGE_RUN_CASES}: every case's inputs, "
                       "results and verdicts are in results.h5", "cases": []})
    return {**json_safe(head), "cases": case_entries(result)}  # the entries made JSON-safe as they are made


_INDENT_UP_TO_CASES = 500  # larger sweeps are written compact: the indenting encoder is ten times slower


def summary_json(result) -> str:
    indent = 2 if len(result.scenario.cases) <= _INDENT_UP_TO_CASES else None
    return json.dumps(summary_dict(result), indent=indent, allow_nan=False)


def write_summary(result, path) -> None:
    write_text_atomic(path, summary_json(result) + "\n")
