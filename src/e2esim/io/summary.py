"""summary.json: the machine-readable result of a run, per case and per requirement.

Non-finite numbers (NaN, +-inf) are written as null, so the file is strict JSON.
Layout in docs/output-format.md.
"""

from __future__ import annotations

import json
import math

from e2esim.io.atomic import write_text_atomic


def requirement_overview(result) -> list:
    """Per requirement: how many cases pass, the worst margin and where it occurs."""
    rows = []
    for j, name in enumerate(result.requirement_names):
        every = [(c.index, c.label, c.verdicts[j]) for c in result.cases]
        verdicts = [t for t in every if t[2].details.get("applies", 1.0) != 0.0]  # cases the requirement covers
        worst = min(verdicts or every, key=lambda t: t[2].margin if math.isfinite(t[2].margin) else math.inf)
        rows.append({
            "name": name,
            "passed_cases": sum(v.passed for _, _, v in verdicts),
            "failed_cases": sum(not v.passed for _, _, v in verdicts),
            "not_applicable_cases": len(every) - len(verdicts),
            "all_passed": all(v.passed for _, _, v in verdicts),
            "worst_margin": worst[2].margin if verdicts else float("nan"),
            "unit": worst[2].unit,
            "worst_case": worst[0],
            "worst_case_label": worst[1],
        })
    return rows


def summary_dict(result) -> dict:
    cases = []
    for c in result.cases:
        cases.append({
            "index": c.index,
            "label": c.label,
            "inputs": c.inputs,
            "notes": list(c.notes),
            "results": _finite(c.scalars),
            "requirements": [
                {"name": v.name, "passed": v.passed, "value": _number(v.value), "limit": _number(v.limit),
                 "margin": _number(v.margin), "unit": v.unit, "basis": v.basis, "dominant": v.dominant,
                 "details": _finite(v.details), "notes": list(v.notes)}
                for v in c.verdicts
            ],
        })
    return _clean({
        "scenario": result.scenario.name,
        **result.provenance,
        "n_cases": len(result.cases),
        "requirements": requirement_overview(result),
        "cases": cases,
    })


_INDENT_UP_TO_CASES = 500  # larger sweeps are written compact: the indenting encoder is ten times slower


def summary_json(result) -> str:
    indent = 2 if len(result.cases) <= _INDENT_UP_TO_CASES else None
    return json.dumps(summary_dict(result), indent=indent, allow_nan=False)


def write_summary(result, path) -> None:
    write_text_atomic(path, summary_json(result) + "\n")


def _number(x):
    x = float(x)
    return x if math.isfinite(x) else None


def _finite(floats: dict) -> dict:
    """A mapping of names to numbers with non-finite ones as None (the fast path of ``_clean``)."""
    return {k: _number(v) for k, v in floats.items()}


def _clean(value):
    if type(value) is float:  # the common case first
        return value if math.isfinite(value) else None
    if type(value) is dict and value and all(type(v) is float or v is None for v in value.values()):
        return value  # already cleaned by _finite
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if hasattr(value, "item"):  # numpy scalar
        return _clean(value.item())
    return value
