"""Every case of a run as columns in case order: what the writers (results.h5, summary.json, results.nc) and
the large-run report read, instead of one ``CaseResult`` per case.

The blocks of a run (``e2esim.runner.run.BlockResult``) hold their cases' scalars and verdicts as columns
(``e2esim.runner.columns``); this joins them and puts them in case order. Nothing here is per case in Python:
a million cases join in about the time numpy copies their numbers. The output scalars are joined one at a
time, when asked for, and not kept: the blocks already hold them, and a million cases' hundred scalars
joined at once would double the run's memory. So are the requirements' verdicts and the notes: each field is
joined when read. With the blocks of a large run on disk (``e2esim.runner.spill``), the table then holds no
per-case numbers at all; reading one column holds that column.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from e2esim.block import Values
from e2esim.case import LazyMapping
from e2esim.runner.columns import Column, join_field, take_field


@dataclass
class ResultTable:
    """The columns of every case, in case order.

    n : number of cases. scalars : {name: ``Column``} in the order of first appearance (a ``JoinedColumns``:
    each column joined from the blocks when read). requirements : per requirement, its verdicts with the fields
    of ``RequirementColumns`` (a ``JoinedRequirement``: each field joined when read). ``notes``: the error
    model's notes per case (``Values`` of tuples); ``groups``: {source: group} of each case's AGB-error
    contributions (``Values``); both joined when read.
    """

    n: int
    scalars: Mapping
    requirements: list
    blocks: list = field(default_factory=list, repr=False)  # what notes and groups are joined from
    order: np.ndarray | None = field(default=None, repr=False)

    @classmethod
    def of(cls, blocks: list, n: int) -> ResultTable:
        """Join ``blocks`` (``BlockResult``s covering cases 0..n-1 once each)."""
        if not blocks:
            return cls(n, {}, [])
        indices = np.concatenate([b.indices for b in blocks])
        order = None if np.array_equal(indices, np.arange(n)) else np.argsort(indices, kind="stable")
        sizes = [len(b) for b in blocks]
        scalars = JoinedColumns([b.scalars for b in blocks], sizes, order)
        count = len(blocks[0].requirements)
        requirements = [JoinedRequirement([b.requirements[j] for b in blocks], sizes, order) for j in range(count)]
        return cls(n, scalars, requirements, blocks, order)

    @property
    def notes(self) -> Values:
        return self._texts("notes", ())

    @property
    def groups(self) -> Values:
        return self._texts("groups", {})

    def _texts(self, name: str, empty) -> Values:
        if not self.blocks:
            return Values.repeated(empty, self.n)
        joined = Values.concatenate([getattr(b, name) for b in self.blocks])
        return joined if self.order is None else joined.take(self.order)

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
        """Cases requirement ``j`` applies to (bool per case; the others are not applicable)."""
        return np.asarray(self.requirements[j].applicable, dtype=bool)

    def curves_by_block(self, j: int):
        """Yield (case numbers, ``Values`` of {name: array}) of requirement ``j``'s trade-off curves, block by block
        (blocks without curves left out): each block's read back when reached, so a writer never holds the curves
        of every case at once, as ``requirements[j].curves`` does."""
        for block in self.blocks:
            curves = block.requirements[j].curves
            if curves is not None:
                yield block.indices, curves

    def detail(self, j: int, key: str) -> np.ndarray:
        """Detail ``key`` of requirement ``j``, NaN where a case lacks it."""
        column = self.requirements[j].details[key]
        return column.values if column.present is None else np.where(column.present, column.values, np.nan)


class JoinedRequirement:
    """The verdicts of one requirement over the blocks (``parts``: each a ``RequirementColumns`` or one read back
    from disk), in case order, with the fields of ``RequirementColumns``; each field joined when read, not kept.
    ``details`` is a ``JoinedColumns``."""

    def __init__(self, parts: list, sizes: list, order: np.ndarray | None):
        self.parts, self.order = parts, order
        self.details = JoinedColumns([p.details for p in parts], sizes, order)

    def _joined(self, name: str):
        joined = join_field([getattr(p, name) for p in self.parts])
        return joined if self.order is None else take_field(joined, self.order)

    name = property(lambda self: self._joined("name"))
    passed = property(lambda self: self._joined("passed"))
    value = property(lambda self: self._joined("value"))
    limit = property(lambda self: self._joined("limit"))
    margin = property(lambda self: self._joined("margin"))
    unit = property(lambda self: self._joined("unit"))
    basis = property(lambda self: self._joined("basis"))
    dominant = property(lambda self: self._joined("dominant"))
    notes = property(lambda self: self._joined("notes"))
    applicable = property(lambda self: self._joined("applicable"))
    reason = property(lambda self: self._joined("reason"))
    coverage = property(lambda self: self._joined("coverage"))
    coverage_text = property(lambda self: self._joined("coverage_text"))

    @property
    def status(self) -> np.ndarray:
        """"pass", "fail" or "not_applicable" per case."""
        from e2esim.requirements.verdict import status_of

        return status_of(self.passed, self.applicable)

    @property
    def curves(self) -> Values | None:
        """The trade-off curves per case, None when no block has any: one dict of arrays per case, every case's in
        memory at once (the writers read them block by block: ``ResultTable.curves_by_block``)."""
        if all(p.curves is None for p in self.parts):
            return None
        joined = Values.concatenate([p.curves if p.curves is not None else Values.repeated({}, len(p.passed))
                                     for p in self.parts])
        return joined if self.order is None else joined.take(self.order)


class JoinedColumns(LazyMapping):
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

    def _names(self):
        return self.names


def text_column(values: Values) -> np.ndarray:
    """A ``Values`` column as a numpy object array of its values (one Python object per distinct value)."""
    distinct = np.empty(len(values.values), dtype=object)
    for i, value in enumerate(values.values):  # item by item: a tuple must stay one object
        distinct[i] = value
    return distinct[values.index]
