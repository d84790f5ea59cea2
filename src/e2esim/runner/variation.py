"""Whether output columns vary among cases that differ in one sweep group only: the vectorised kernel behind
``e2esim.runner.no_effect``.

Cases are grouped into *contexts* (the same position of every other sweep group) and each column is tested once
over all contexts with ``numpy`` reductions over the cases sorted by context: nothing is done per case in Python,
so a million-case sweep costs a few array passes per column. A column *varies* in a context when

* it is present in some of the context's cases and not in others, or
* (a deterministic column) two present values differ by more than 1e-9 of the column's largest magnitude: the
  batched engine evaluates blocks of different sizes, which may change the last bits of a sum, and a setting that
  moves a result by less than that changes nothing a reader could see; NaN and infinities compare as themselves.

A *sampled* column (a Monte Carlo value or its comparison with the analytic one: a ``montecarlo`` or
``comparison`` part in its name) is tested by presence only: every case draws its own random stream
(``e2esim.runner.run.case_generator``), so its values differ between any two cases whether or not the setting acts.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from e2esim.distinct import distinct_rows

SAMPLED_PARTS = frozenset({"montecarlo", "comparison"})
"""Name parts of the output columns drawn from the case's random stream."""
RELATIVE_TOLERANCE = 1e-9
_VERDICT = re.compile(r"^requirement\d+\.")


def is_sampled(name: str) -> bool:
    return not SAMPLED_PARTS.isdisjoint(name.split("."))


@dataclass(frozen=True)
class Contexts:
    """The cases ``cases`` (positions in the run) sorted by context: ``order`` into ``cases``, ``starts`` of every
    context in that order, and the sweep position of the varied group per context (``evidence``: the context
    holds at least two of its values)."""

    cases: np.ndarray
    order: np.ndarray
    starts: np.ndarray
    evidence: np.ndarray

    @classmethod
    def of(cls, codes: np.ndarray, cases: np.ndarray, group: int) -> Contexts:
        """Contexts of the cases ``cases`` (sweep positions ``codes`` (n, G) of every case) for sweep group
        ``group``."""
        own = codes[cases, group]
        other = np.delete(codes[cases], group, axis=1)
        context = distinct_rows(other)[2] if other.shape[1] else np.zeros(len(cases), dtype=np.int64)
        order = np.argsort(context, kind="stable")
        ordered = context[order]
        starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]]) if len(order) else np.zeros(0, np.int64)
        own = own[order]
        evidence = np.minimum.reduceat(own, starts) != np.maximum.reduceat(own, starts) if len(order) else \
            np.zeros(0, dtype=bool)
        return cls(np.asarray(cases), order, starts, evidence)

    @property
    def sizes(self) -> np.ndarray:
        return np.diff(np.r_[self.starts, len(self.order)])

    def first_cases(self) -> np.ndarray:
        """The first case (position in the run) of every context."""
        return self.cases[self.order[self.starts]]

    def varies(self, values: np.ndarray, present: np.ndarray, sampled: bool) -> np.ndarray:
        """(contexts,) bool: where the column (``values`` and ``present`` over every case of the run) varies."""
        take = self.cases[self.order]
        v, p = values[take], present[take]
        have = np.add.reduceat(p.astype(np.int64), self.starts)
        out = (have > 0) & (have < self.sizes)
        if sampled:
            return out
        finite = p & np.isfinite(v)
        if finite.any():
            tolerance = RELATIVE_TOLERANCE * float(np.max(np.abs(v[finite])))
            low = np.minimum.reduceat(np.where(finite, v, np.inf), self.starts)
            high = np.maximum.reduceat(np.where(finite, v, -np.inf), self.starts)
            count = np.add.reduceat(finite.astype(np.int64), self.starts)
            out |= (count >= 2) & (high - low > tolerance)
        if (p & ~finite).any():  # NaN, +inf and -inf: each the same in every case that has the column, or varied
            for kind in (np.isnan(v), v == np.inf, v == -np.inf):
                count = np.add.reduceat((p & kind).astype(np.int64), self.starts)
                out |= (count > 0) & (count < have)
        return out


def column_products(names, stages) -> dict:
    """{column name: the name of the product that writes it}, from the output prefixes the chain's ``stages``
    declare (``Product.scalars``); a column with none of them belongs to the verdicts when it starts with
    ``requirement<j>.``, else to the first product the chain writes without a prefix (the error model)."""
    prefixed, bare = {}, None
    for stage in stages:
        for product in stage.provides:
            if product.scalars:
                prefixed.setdefault(product.scalars + ".", product.name)
            elif product.scalars == "" and product.name != "verdicts" and bare is None:
                bare = product.name
    ordered = sorted(prefixed, key=len, reverse=True)
    out = {}
    for name in names:
        if _VERDICT.match(name):
            out[name] = "verdicts"
            continue
        out[name] = next((prefixed[p] for p in ordered if name.startswith(p)), bare)
    return out


__all__ = ["RELATIVE_TOLERANCE", "SAMPLED_PARTS", "Contexts", "column_products", "is_sampled"]
