"""The allocation table of a requirement, as a review board reads it: per error source its allocation, its current
best estimate (its share of the checked value) and the margin between them, and the total (the limit, the checked
value, the verdict's margin). Read from the verdicts' details (``e2esim.requirements.allocation``); nothing physical
is computed here. Over a sweep the table is that of the requirement's worst case (smallest margin), so that the
estimates add up to the checked value there; each row also gives the smallest margin of its source over the cases the
requirement applies to, and where."""

from __future__ import annotations

import numpy as np

from e2esim.io.error_budget import unit_key
from e2esim.requirements.shares import INTERACTIONS


def allocation_overview(result, j: int) -> dict | None:
    """{"unit", "case", "rows": [{source, allocation, estimate, margin, worst_margin, worst_case}], "unallocated",
    "total": {allocation, estimate, margin}} of requirement ``j`` at its worst case ``case``, or None when it states no
    allocation."""
    table = result.table
    r = table.requirements[j]
    applies = table.applies(j)
    if not applies.any():
        return None
    unit = str(r.unit[int(np.argmax(applies))])  # a Values column: one look-up, not one per case
    suffix = "_" + unit_key(unit)
    keys = set(r.details)
    allocated = [k[len("allocation."):-len(suffix)] for k in keys if k.startswith("allocation.") and k.endswith(suffix)]
    allocated = [s for s in allocated if s not in ("total", "unallocated")]
    if not allocated:
        return None
    shared = sorted((k[len("share."):-len(suffix)] for k in keys if k.startswith("share.") and k.endswith(suffix)
                     and k != f"share.{INTERACTIONS}{suffix}"), key=lambda s: (s not in allocated, s))
    cases = np.nonzero(applies)[0]
    worst = _smallest(np.asarray(r.margin, dtype=float), cases)
    rows = []
    for source in dict.fromkeys([*sorted(allocated), *shared, INTERACTIONS]):
        estimate = _column(table, j, f"share.{source}{suffix}", keys)
        if estimate is None:
            continue
        allocation = _column(table, j, f"allocation.{source}{suffix}", keys)
        margin = _column(table, j, f"allocation_margin.{source}{suffix}", keys)
        tightest = None if margin is None else _smallest(margin, cases)
        rows.append({"source": source, "allocation": _at(allocation, worst), "estimate": _at(estimate, worst),
                     "margin": _at(margin, worst), "worst_margin": _at(margin, tightest), "worst_case": tightest})
    return {"unit": unit, "case": worst, "rows": rows,
            "unallocated": _at(table.detail(j, f"allocation.unallocated{suffix}"), worst),
            "total": {"allocation": float(r.limit[worst]), "estimate": float(r.value[worst]),
                      "margin": float(r.margin[worst])}}


def _smallest(values, cases) -> int:
    """The case of ``cases`` with the smallest finite value (the first of equals; the first case if none is)."""
    picked = values[cases]
    return int(cases[np.argmin(np.where(np.isfinite(picked), picked, np.inf))])


def _column(table, j: int, key: str, keys: set):
    return table.detail(j, key) if key in keys else None


def _at(column, i):
    if column is None or i is None:
        return None
    x = float(column[i])
    return x if np.isfinite(x) else None
