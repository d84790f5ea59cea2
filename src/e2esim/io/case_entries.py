"""summary.json's per-case entries, made from the run's columns a block at a time.

The entry of a case is what ``e2esim.io.summary`` would write from its ``CaseResult`` (``ScenarioResult.cases``),
key for key and float for float, but read from the block's arrays (``e2esim.runner.columns``): each column turned
into Python floats once (``tolist``, the same floats as ``float`` of each element, non-finite ones as None) rather
than one ``CaseResult`` and ``RequirementVerdict`` per case and a walk over every value afterwards.
tests/test_summary_entries.py pins the bytes against that per-case construction.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from e2esim.allocator import collector_paused
from e2esim.io.error_budget import agb_budget, source_groups, verdict_budget, verdict_budgets


class _Verdict(NamedTuple):
    """What ``verdict_budget`` reads of a verdict: its unit, its checked value and its details (raw floats)."""

    unit: str
    value: float
    details: dict


def case_entries(result) -> list:
    """The per-case entries of summary.json (docs/output-format.md), in case order, JSON-safe (``json_safe``):
    the columns' floats cleaned once as lists, the small values (inputs, notes, budget rows) one by one. The
    cyclic garbage collector is paused meanwhile: the entries hold no cycles, and its passes over the hundreds
    of thousands of new dicts and lists would otherwise cost a third of the time."""
    with collector_paused():
        return _entries(result)


def _entries(result) -> list:
    scenario = result.scenario
    entries: list = [None] * len(scenario.cases)
    plan = scenario.plan
    labels = scenario.cases.labels if plan is not None else None
    for block in result.blocks:
        if hasattr(block, "load"):  # a spilled block (e2esim.runner.spill): its arrays read back once
            block = block.load()
        for k, index in enumerate(block.indices.tolist()):
            if plan is not None:
                label, inputs = labels[index], plan.table.inputs(index)
            else:
                label, inputs = scenario.cases[index].label, scenario.cases[index].inputs
            entries[index] = {"index": index, "label": label, "inputs": json_safe(inputs),
                              "notes": json_safe(list(block.notes[k]))}
        _fill_block(block, entries)
    return entries


def _fill_block(block, entries: list) -> None:
    """The results, AGB budgets and verdicts of one block's cases into their ``entries``."""
    indices = block.indices.tolist()
    n = len(indices)
    scalars, raw_scalars = _rows(block.scalars, n)
    products = block.products
    groups = [source_groups(p) for p in products] if products is not None else [{}] * n
    verdicts = [_verdict_rows(r, n, groups) for r in block.requirements]
    for k, index in enumerate(indices):
        entry = entries[index]
        entry["results"] = scalars[k]
        entry["agb_budget"] = _safe_rows(agb_budget(raw_scalars(k), groups[k])) if groups[k] else []
        entry["requirements"] = [_requirement(rows, k, groups[k]) for rows in verdicts]


def _requirement(rows: dict, k: int, groups: dict) -> dict:
    details = rows["details"][k]
    verdict = _Verdict(rows["unit"][k], rows["raw_value"][k], None)
    if rows["budgets"] is not None:
        budget = rows["budgets"][k]
    else:  # a case's own details (some missing in other cases, or units that differ)
        budget = _safe_rows(verdict_budget(verdict._replace(details=rows["raw_details"](k)), groups))
    return {"name": rows["name"][k], "status": rows["status"][k], "reason": rows["reason"][k],
            "passed": rows["passed"][k], "value": rows["value"][k], "limit": rows["limit"][k],
            "margin": rows["margin"][k], "unit": verdict.unit, "basis": rows["basis"][k],
            "dominant": rows["dominant"][k], "coverage": list(rows["coverage"][k]),
            "coverage_text": rows["coverage_text"][k], "details": details,
            "budget": budget, "notes": json_safe(list(rows["notes"][k]))}


def _verdict_rows(r, n: int, groups: list) -> dict:
    """One requirement's fields over the block's cases as lists of Python values, normalised as a
    ``RequirementVerdict`` is on construction (where it does not apply: not passed, no margin, its reason)."""
    applicable = np.broadcast_to(np.asarray(r.applicable, dtype=bool), (n,))
    passed = (np.broadcast_to(np.asarray(r.passed, dtype=bool), (n,)) & applicable).tolist()
    applies = applicable.tolist()
    value = _floats(r.value, n)
    margin = np.where(applicable, _floats(r.margin, n), np.nan)
    reasons = r.reason.tolist()
    details, _ = _rows(r.details, n)
    # verdict_budget reads only the shares, Shapley parts and contributions: the other details are not handed to it
    budget_columns = {k: c for k, c in r.details.items() if k.startswith(_BUDGET_KEYS)}
    _, raw_details = _rows(budget_columns, n)
    units = r.unit.tolist()
    budgets = None
    if len(set(units)) <= 1 and all(c.present is None for c in budget_columns.values()):
        arrays = {k: np.broadcast_to(np.asarray(c.values, dtype=float), (n,)) for k, c in budget_columns.items()}
        budgets = verdict_budgets(units[0] if units else "", value.tolist(),
                                  {k: a.tolist() for k, a in arrays.items()},
                                  {k: _finite_list(a) for k, a in arrays.items()}, groups)
    return {
        "name": r.name.tolist(), "passed": passed,
        "status": ["pass" if p else "fail" if a else "not_applicable" for p, a in zip(passed, applies)],
        "reason": [reason if not a else "" for reason, a in zip(reasons, applies)],
        "raw_value": value.tolist(), "value": _finite_list(value), "limit": _finite_list(_floats(r.limit, n)),
        "margin": _finite_list(margin), "unit": r.unit.tolist(), "basis": r.basis.tolist(),
        "dominant": r.dominant.tolist(), "coverage": r.coverage.tolist(), "coverage_text": r.coverage_text.tolist(),
        "notes": r.notes.tolist(), "details": details, "raw_details": raw_details, "budgets": budgets}


_BUDGET_KEYS = ("contribution.", "share.", "shapley.")


def _safe_rows(rows: list) -> list:
    """Budget rows (text, floats and None) with their non-finite floats as None, as ``json_safe`` makes them."""
    return [{k: None if type(v) is float and not math.isfinite(v) else v for k, v in row.items()} for row in rows]


def _floats(x, n: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(x, dtype=float), (n,))


def _finite_list(values: np.ndarray) -> list:
    """``values`` as Python floats, None where not finite (as summary.json writes them)."""
    out = values.tolist()
    for i in np.flatnonzero(~np.isfinite(values)).tolist():
        out[i] = None
    return out


def _rows(columns: dict, n: int) -> tuple:
    """({name: value} per case with non-finite values as None, and a function of k giving case k's raw
    {name: value}) of ``{name: Column}``: the names a case has, in column order."""
    names = list(columns)
    arrays = [np.broadcast_to(np.asarray(c.values, dtype=float), (n,)) for c in columns.values()]
    raw = [a.tolist() for a in arrays]
    clean = [_finite_list(a) for a in arrays]
    present = [c.present for c in columns.values()]
    if all(p is None for p in present):
        rows = [dict(zip(names, row)) for row in zip(*clean)] if names else [{} for _ in range(n)]
        return rows, lambda k: {name: values[k] for name, values in zip(names, raw)}
    has = [np.ones(n, bool).tolist() if p is None else np.asarray(p, dtype=bool).tolist() for p in present]
    rows = [{name: values[k] for name, values, h in zip(names, clean, has) if h[k]} for k in range(n)]
    return rows, lambda k: {name: values[k] for name, values, h in zip(names, raw, has) if h[k]}


def json_safe(value):
    """``value`` as strict JSON can hold it: non-finite floats as None, tuples as lists, numpy scalars as Python
    numbers, keys as text. A mapping of floats and None only is already safe and kept as it is."""
    if type(value) is float:  # the common case first
        return value if math.isfinite(value) else None
    if type(value) is dict and value and all(type(v) is float or v is None for v in value.values()):
        return value
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if hasattr(value, "item"):  # numpy scalar
        return json_safe(value.item())
    return value
