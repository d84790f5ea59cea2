"""Every case of a run as columns in case order: what the writers (results.h5, summary.json, results.nc) and
the large-run report read, instead of one ``CaseResult`` per case.

The blocks of a run (``e2esim.runner.run.BlockResult``) hold their cases' scalars and verdicts as columns
(``e2esim.runner.columns``); this joins them and puts them in case order. Nothing here is per case in Python:
a million cases join in about the time numpy copies their numbers. The output scalars are joined one at a
time, when asked for, and not kept: the blocks already hold them, and a million cases' hundred scalars
joined at once would double the run's memory.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from e2esim.block import Values
from e2esim.runner.columns import Column, RequirementColumns


@dataclass
class ResultTable:
    """The columns of every case, in case order.

    n : number of cases. scalars : {name: ``Column``} in the order of first appearance (a ``JoinedColumns``:
    each column joined from the blocks when read). requirements :
    ``RequirementColumns`` per requirement. notes : the error model's notes per case (``Values`` of tuples).
    groups : {source: group} of each case's AGB-error contributions (``Values``).
    """

    n: int
    scalars: Mapping
    requirements: list
    notes: Values
    groups: Values

    @classmethod
    def of(cls, blocks: list, n: int) -> ResultTable:
        """Join ``blocks`` (``BlockResult``s covering cases 0..n-1 once each)."""
        if not blocks:
            return cls(n, {}, [], Values.repeated((), n), Values.repeated({}, n))
        indices = np.concatenate([b.indices for b in blocks])
        order = None if np.array_equal(indices, np.arange(n)) else np.argsort(indices, kind="stable")
        sizes = [len(b) for b in blocks]
        scalars = JoinedColumns([b.scalars for b in blocks], sizes, order)
        count = len(blocks[0].requirements)
        requirements = [_joined_requirement([b.requirements[j] for b in blocks], sizes, order) for j in range(count)]
        notes = Values.concatenate([b.notes for b in blocks])
        groups = Values.concatenate([b.groups for b in blocks])
        if order is not None:
            notes, groups = notes.take(order), groups.take(order)
        return cls(n, scalars, requirements, notes, groups)

    def scalar(self, name: str) -> np.ndarray:
        """The values of output scalar ``name``, NaN in cases that lack it."""
        column = self.scalars[name]
        if column.present is None:
            return column.values
        return np.where(column.present, column.values, np.nan)

    def has(self, name: str) -> np.ndarray:
        """Where output scalar ``name`` exists (bool per case)."""
        column = self.scalars.get(name)
        if column is None:
            return np.zeros(self.n, dtype=bool)
        return np.ones(self.n, dtype=bool) if column.present is None else column.present

    def applies(self, j: int) -> np.ndarray:
        """Cases requirement ``j`` covers (its ``applies`` detail is not 0; bool per case)."""
        detail = self.requirements[j].details.get("applies")
        if detail is None:
            return np.ones(self.n, dtype=bool)
        return ~(detail.values == 0.0) | (~detail.present if detail.present is not None else False)

    def detail(self, j: int, key: str) -> np.ndarray:
        """Detail ``key`` of requirement ``j``, NaN where a case lacks it."""
        column = self.requirements[j].details[key]
        return column.values if column.present is None else np.where(column.present, column.values, np.nan)


def _joined_requirement(parts: list, sizes: list, order: np.ndarray | None) -> RequirementColumns:
    """The verdicts of one requirement over the blocks (``parts``), in case order; details joined when read."""
    joined = RequirementColumns.concatenate([replace(p, details={}) for p in parts])
    if order is not None:
        joined = joined.take(order)
    return replace(joined, details=JoinedColumns([p.details for p in parts], sizes, order))


class JoinedColumns(Mapping):
    """{name: ``Column``} over consecutive blocks, each joined in case order when read (not kept).

    parts : per block, {name: ``Column``} of its cases (a block may lack a name: NaN there). sizes : the blocks'
    numbers of cases. order : the positions that put the joined blocks' cases in case order, None when they
    already are."""

    def __init__(self, parts: list, sizes: list, order: np.ndarray | None):
        self.parts = parts
        self.sizes = sizes
        self.order = order
        self.names = list(dict.fromkeys(k for p in parts for k in p))

    def __getitem__(self, name: str) -> Column:
        if name not in self.names:
            raise KeyError(name)
        column = Column.concatenate([p.get(name) for p in self.parts], self.sizes)
        return column if self.order is None else column.take(self.order)

    def __iter__(self):
        return iter(self.names)

    def __len__(self) -> int:
        return len(self.names)

    def __contains__(self, name) -> bool:
        return name in self.names


def text_column(values: Values) -> np.ndarray:
    """A ``Values`` column as a numpy object array of its values (one Python object per distinct value)."""
    distinct = np.empty(len(values.values), dtype=object)
    for i, value in enumerate(values.values):  # item by item: a tuple must stay one object
        distinct[i] = value
    return distinct[values.index]
