"""Allocation tables: what a requirement allots to each error source, against the source's current best estimate.

A requirement may carry ``allocation_percent: {source: value}`` (absolute, in the requirement's unit) or
``allocation_share: {source: fraction}`` (fractions of its limit, summing to at most 1). Per source, the verdict's
details then hold the allocation, ``allocation.<source>_<unit>``, and its margin, ``allocation_margin.<source>_<unit>``
= allocation − current best estimate, where the estimate is the source's share of the checked value
(``share.<source>_<unit>``, ``e2esim.requirements.shares``: the shares add up to the value, so the allocations can
be compared with them line by line). ``allocation.total_<unit>`` is the requirement's limit and
``allocation.unallocated_<unit>`` what the listed sources leave of it.
"""

from __future__ import annotations

import numpy as np

from e2esim.case_values import plain
from e2esim.module import fail
from e2esim.params import AtMostOneOf, Param

ALLOCATION_PARAMS = (
    Param("allocation_percent", "mapping", "what the requirement allots to each error source, {source: value} "
          "in the requirement's own unit (% or t/ha); the report, summary.json and results.h5 compare each with the "
          "source's share of the checked value", default=None, unit="%", nullable=True, minimum=0.0, convert=False),
    Param("allocation_share", "mapping", "the same as fractions of the requirement's limit, {source: fraction}; "
          "they must sum to at most 1", default=None, nullable=True, minimum=0.0, maximum=1.0),
    AtMostOneOf("allocation_percent", "allocation_share"),
)
"""The allocation keys every requirement takes (``e2esim allocate`` writes them)."""


def check_allocation(requirement) -> None:
    """What can be checked before anything runs: shares that sum to more than 1."""
    shares = requirement.config.get("allocation_share") or {}
    total = sum(shares.values())
    if total > 1.0 + 1e-12:
        raise fail(requirement, f"the allocation shares sum to {total:g} (" + ", ".join(
            f"{k}: {v:g}" for k, v in shares.items()) + ")", "shares of the requirement's limit that sum to at most 1",
            key="allocation_share")


def allocations(requirement, limit) -> tuple:
    """(key, {source: allocation in the requirement's unit}) of ``requirement``, or (None, {})."""
    c = requirement.config
    if c.get("allocation_percent"):
        return "allocation_percent", dict(c["allocation_percent"])
    if c.get("allocation_share"):
        return "allocation_share", {k: v * limit for k, v in c["allocation_share"].items()}
    return None, {}


def allocation_details(requirement, details: dict, sources: tuple, limit, value, unit: str) -> dict:
    """The allocation table's numbers of one verdict (or a block): per allocated source its allocation and margin
    (to its share of ``value``), the total (the limit) and the part left unallocated. An allocated source the chain
    does not have is a clear error naming the sources it has."""
    key, alloc = allocations(requirement, limit)
    if key is None:
        return {}
    unknown = [s for s in alloc if s not in sources]
    if unknown:
        raise fail(requirement, f"no error source {', '.join(repr(s) for s in unknown)} in this chain",
                   f"sources of this requirement's checked value: {', '.join(sources)}", key=key)
    out = {}
    for source, amount in alloc.items():
        estimate = details.get(f"share.{source}_{unit}")
        out[f"allocation.{source}_{unit}"] = amount
        if estimate is not None:
            out[f"allocation_margin.{source}_{unit}"] = plain(amount - np.asarray(estimate, dtype=float))
    out[f"allocation.total_{unit}"] = float(limit)
    out[f"allocation.unallocated_{unit}"] = float(limit) - sum(alloc.values())
    return out

