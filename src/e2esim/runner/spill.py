"""Finished blocks of a large run kept on disk, so that a run's memory is bounded by its blocks, not its size.

A block's results (``e2esim.runner.run.BlockResult``) take 0.6 to 1.5 kB per case, nearly all of it numbers: the
output scalars, the requirement verdicts and their details (level margins the most), and 2 kB more per case with
trade-off curves. A sweep of a million cases that kept them would hold gigabytes until its outputs are written.
Runs of more than ``SPILL_ABOVE_CASES`` cases therefore write every finished block's arrays to one temporary file
(``SpillFile``) and keep only a ``SpilledBlock``: the block's case indices and where its arrays lie in the file
(the columns present in every case as rows of one array, each trade-off curve as one array). The writers read
the run column by column (``e2esim.runner.result_table``; the curves block by block), so reading back one column
of every block at a time keeps the memory of the outputs at one column of the sweep (8 bytes per case) beside the
blocks in flight.

The file holds plain arrays only, is read only by the process that wrote it, and is removed when the run's
result is (on POSIX it has no name at all: a killed run leaves nothing behind). It is created in the output
folder when there is one, not in the system's temporary folder, which is memory on some systems (tmpfs).
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from e2esim.block import Values
from e2esim.case import LazyMapping
from e2esim.errors import OutputFolderError
from e2esim.runner.case_results import BlockResult
from e2esim.runner.columns import Column, RequirementColumns

SPILL_ABOVE_CASES = 10_000
"""Runs with more cases keep their finished blocks on disk. Smaller ones keep them in memory (at most about
6 MB): their report reads every case some twenty times (``e2esim.runner.run.REMEMBER_CASES_UP_TO``)."""


@dataclass(frozen=True, slots=True)
class Spilled:
    """Where one array lies in a ``SpillFile``: byte offset, dtype (numpy's text form) and shape. Small (slots, the
    dtype's text shared): a block keeps one per array, a few hundred."""

    offset: int
    dtype: str
    shape: tuple


class SpillFile:
    """An append-only temporary file of plain numeric arrays, read back one array at a time.

    folder : where to create it (None: the system's temporary folder)."""

    def __init__(self, folder=None):
        if folder is not None:
            os.makedirs(folder, exist_ok=True)
        self._folder = folder if folder is not None else tempfile.gettempdir()
        self._file = tempfile.TemporaryFile(prefix="e2esim-spill-", dir=folder)
        self._end = 0

    def put(self, array: np.ndarray) -> Spilled:
        array = np.ascontiguousarray(array)
        if array.dtype.kind not in "biuf":
            raise TypeError(f"only numeric arrays are spilled, not {array.dtype}")
        return self._write([array], array.dtype, array.shape)

    def put_rows(self, rows: list) -> Spilled:
        """Arrays of one numeric dtype and shape as the rows of one array, written one after the other (the
        layout of ``put(np.stack(rows))``, without making that copy: a block's columns are megabytes)."""
        rows = [np.ascontiguousarray(row) for row in rows]
        first = rows[0]
        if first.dtype.kind not in "biuf" or any(r.dtype != first.dtype or r.shape != first.shape for r in rows):
            raise TypeError("only numeric arrays of one dtype and shape are spilled as rows")
        return self._write(rows, first.dtype, (len(rows),) + first.shape)

    def _write(self, arrays: list, dtype: np.dtype, shape: tuple) -> Spilled:
        try:
            self._file.seek(self._end)
            for array in arrays:
                self._file.write(array.data)
            self._file.flush()  # a full disk shows here, not later in a buffer
        except OSError as exc:
            raise OutputFolderError(f"{self._folder}: cannot keep the finished blocks in a temporary file: "
                                    f"{exc.strerror or exc}") from exc
        ref = Spilled(self._end, sys.intern(dtype.str), shape)
        self._end += sum(a.nbytes for a in arrays)
        return ref

    def get(self, ref: Spilled) -> np.ndarray:
        dtype = np.dtype(ref.dtype)
        out = np.empty(ref.shape, dtype=dtype)
        if _read_at(self._file, memoryview(out).cast("B"), ref.offset) != out.nbytes:
            raise OSError(f"the spill file {self._file.name} is shorter than expected")
        return out

    def close(self) -> None:
        self._file.close()


def _read_at(file, view: memoryview, offset: int) -> int:
    """Read ``view``'s bytes from ``offset`` of ``file`` without its file offset: the report's plots are drawn by
    this process and a forked helper at once (``e2esim.report.plot_processes``), and a forked process shares the
    open file, so a seek then a read could read where the other process has just sought. The bytes read."""
    if not hasattr(os, "preadv"):  # no positional read (Windows), and no forked helper either
        file.seek(offset)
        return file.readinto(view)
    got = 0
    while got < len(view):
        n = os.preadv(file.fileno(), [view[got:]], offset + got)
        if n == 0:
            break
        got += n
    return got


def spill_block(block, spill: SpillFile) -> SpilledBlock:
    """The ``SpilledBlock`` of ``block`` (a ``BlockResult`` without products): its arrays written to ``spill``."""
    if block.products is not None:
        raise ValueError("a block that keeps its cases' products is not spilled")
    # the indices copied: those of a block read back from the journal are a view of the whole record's bytes
    return SpilledBlock(spill, np.array(block.indices), SpilledColumns.of(block.scalars, spill),
                        [SpilledRequirement.of(r, spill) for r in block.requirements],
                        SpilledValues.of(block.notes, spill), SpilledValues.of(block.groups, spill))


class SpilledBlock:
    """A ``BlockResult`` whose arrays are in a ``SpillFile``, with the same attributes (each read back when asked
    for, not kept): ``indices`` (in memory), ``scalars``, ``requirements``, ``notes``, ``groups``; ``products``
    is None (only blocks that keep no products are spilled)."""

    products = None

    def __init__(self, spill: SpillFile, indices: np.ndarray, scalars: SpilledColumns, requirements: list,
                 notes: SpilledValues, groups: SpilledValues):
        self._spill = spill
        self.indices = indices
        self.scalars = scalars
        self.requirements = requirements
        self._notes, self._groups = notes, groups

    def __len__(self) -> int:
        return len(self.indices)

    @property
    def notes(self) -> Values:
        return self._notes.load()

    @property
    def groups(self) -> Values:
        return self._groups.load()

    def load(self):
        """The whole block in memory, a ``BlockResult``."""
        return BlockResult(self.indices, dict(self.scalars.items()), [r.load() for r in self.requirements],
                           self.notes, self.groups)


class SpilledColumns(LazyMapping):
    """{name: ``Column``} of a spilled block, each read back when asked for. The columns present in every case
    (nearly all) are rows of one array on disk, so that the block keeps a row number per name, not a reference
    per column."""

    def __init__(self, spill: SpillFile, table: Spilled | None, refs: dict):
        self._spill, self._table = spill, table  # the (columns, cases) float array of the full columns
        self._refs = refs  # name -> its row in the table, or (values, present) of a column of its own

    @classmethod
    def of(cls, columns: Mapping, spill: SpillFile) -> SpilledColumns:
        full = [name for name, c in columns.items() if c.present is None and c.values.dtype == np.float64
                and c.values.ndim == 1]
        if len({len(columns[name].values) for name in full}) > 1:
            full = []
        table = spill.put_rows([columns[name].values for name in full]) if full else None
        rows = {name: k for k, name in enumerate(full)}
        return cls(spill, table, {name: rows[name] if name in rows else
                                  (spill.put(c.values), None if c.present is None else spill.put(c.present))
                                  for name, c in columns.items()})

    def __getitem__(self, name: str) -> Column:
        ref = self._refs[name]
        if isinstance(ref, int):
            cases = self._table.shape[1]
            row = Spilled(self._table.offset + ref * cases * 8, self._table.dtype, (cases,))
            return Column(self._spill.get(row))
        values, present = ref
        return Column(self._spill.get(values), None if present is None else self._spill.get(present))

    def _names(self):
        return self._refs


class SpilledValues:
    """A ``Values`` column of a spilled block: its distinct values in memory, the index on disk."""

    def __init__(self, spill: SpillFile, values: list, index: Spilled):
        self._spill, self.values, self._index = spill, values, index

    @classmethod
    def of(cls, values: Values, spill: SpillFile) -> SpilledValues:
        return cls(spill, values.values, spill.put(values.index))

    def load(self) -> Values:
        return Values(self.values, self._spill.get(self._index))


_NUMBERS = ("passed", "value", "limit", "margin", "applicable")
_TEXTS = ("name", "unit", "basis", "dominant", "notes", "reason", "coverage", "coverage_text")


class SpilledRequirement:
    """The ``RequirementColumns`` of one requirement in a spilled block: every field read back when asked for,
    the trade-off curves included (``SpilledCurves``)."""

    def __init__(self, spill: SpillFile, numbers: dict, texts: dict, details: SpilledColumns, curves):
        self._spill, self._numbers, self._texts = spill, numbers, texts
        self.details, self._curves = details, curves

    @classmethod
    def of(cls, r: RequirementColumns, spill: SpillFile) -> SpilledRequirement:
        return cls(spill, {f: spill.put(getattr(r, f)) for f in _NUMBERS},
                   {f: SpilledValues.of(getattr(r, f), spill) for f in _TEXTS},
                   SpilledColumns.of(r.details, spill), SpilledCurves.of(r.curves, spill))

    @property
    def curves(self) -> Values | None:
        """The block's trade-off curves per case (``Values`` of {name: array}), read back when asked for."""
        return self._curves.load() if isinstance(self._curves, SpilledCurves) else self._curves

    def _number(self, field: str) -> np.ndarray:
        return self._spill.get(self._numbers[field])

    def _text(self, field: str) -> Values:
        return self._texts[field].load()

    passed = property(lambda self: self._number("passed"))
    value = property(lambda self: self._number("value"))
    limit = property(lambda self: self._number("limit"))
    margin = property(lambda self: self._number("margin"))
    name = property(lambda self: self._text("name"))
    unit = property(lambda self: self._text("unit"))
    basis = property(lambda self: self._text("basis"))
    dominant = property(lambda self: self._text("dominant"))
    notes = property(lambda self: self._text("notes"))
    applicable = property(lambda self: self._number("applicable"))
    reason = property(lambda self: self._text("reason"))
    coverage = property(lambda self: self._text("coverage"))
    coverage_text = property(lambda self: self._text("coverage_text"))

    def load(self) -> RequirementColumns:
        return RequirementColumns(self.name, self.passed, self.value, self.limit, self.margin, self.unit, self.basis,
                                  self.dominant, self.notes, self.applicable, self.reason, self.coverage,
                                  self.coverage_text, details=dict(self.details.items()), curves=self.curves)


class SpilledCurves:
    """The trade-off curves of a spilled block, ``Values`` of {name: array} per case (``{}``: none): each name's
    curves stacked into one array on disk (one row per case that has curves; once, where every case has the same
    array object, as the crosstalk axis of a batched block), read back as the block's ``Values`` when asked for.

    ``of`` keeps in memory, as they are, curves it cannot stack: names, shapes or dtypes that differ between the
    block's cases, or values that are not numeric arrays (a plug-in's)."""

    def __init__(self, spill: SpillFile, index: Spilled, present: Spilled, arrays: dict, shared: frozenset):
        self._spill, self._index, self._present = spill, index, present
        self._arrays = arrays  # name -> Spilled, in the curves' order: rows of the cases that have curves, or one
        self._shared = shared  # the names stored once

    @classmethod
    def of(cls, curves: Values | None, spill: SpillFile):
        """The ``SpilledCurves`` of ``curves``, or ``curves`` itself where they cannot be stacked (or are None)."""
        if curves is None:
            return None
        rows = curves.values
        drawn = [row for row in rows if row]
        if not drawn or not all(isinstance(row, dict) for row in rows) or not _stackable(drawn):
            return curves
        arrays, shared = {}, set()
        for name, first in drawn[0].items():
            if all(row[name] is first for row in drawn):
                arrays[name] = spill.put(first)
                shared.add(name)
            else:
                arrays[name] = spill.put(np.stack([row[name] for row in drawn]))
        present = np.array([bool(row) for row in rows], dtype=bool)
        return cls(spill, spill.put(curves.index), spill.put(present), arrays, frozenset(shared))

    def load(self) -> Values:
        arrays = {name: self._spill.get(ref) for name, ref in self._arrays.items()}
        rows, k = [], 0
        for has in self._spill.get(self._present):
            if has:
                rows.append({name: a if name in self._shared else a[k] for name, a in arrays.items()})
                k += 1
            else:
                rows.append({})
        return Values(rows, self._spill.get(self._index))


def _stackable(rows: list) -> bool:
    """Whether every row (a dict of arrays) has the same names, in the same order, each a numeric array of the
    same shape and dtype as in the first row."""
    first = rows[0]
    names = list(first)
    for row in rows:
        if list(row) != names:
            return False
        for name in names:
            a, b = row[name], first[name]
            if not (isinstance(a, np.ndarray) and a.dtype.kind in "biuf" and a.shape == b.shape
                    and a.dtype == b.dtype):
                return False
    return True
