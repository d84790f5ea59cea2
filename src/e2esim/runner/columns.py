"""The results of a block of cases as columns: the output scalars, the requirement verdicts, the notes.

What a run writes (summary.json, results.h5, the report) is read from these columns, one array per quantity
over the block's cases, whatever form the products had (``e2esim.block``): one-case products give their
``scalars()`` once per distinct value, batched products their ``scalar_columns()``. The names are those of the
per-case runner (``e2esim.runner.records``): a case's scalars and verdicts are the same either way. A column
may be missing in some cases (a Monte Carlo scalar of a case that ran none): ``present`` says where it is.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field

import numpy as np

from e2esim.block import Batched, Catalog, Factor, Values
from e2esim.requirements.verdict import RequirementVerdict, curves_at, status_of
from e2esim.runner.records import DECLARATIONS


@dataclass
class Column:
    """Values of one output scalar over cases; ``present`` (bool) where they exist, None: everywhere."""

    values: np.ndarray
    present: np.ndarray | None = None

    def take(self, positions) -> Column:
        return Column(self.values[positions], None if self.present is None else self.present[positions])

    def has(self, k: int) -> bool:
        return self.present is None or bool(self.present[k])

    @staticmethod
    def concatenate(columns: list, sizes: list) -> Column:
        """Columns of consecutive blocks (None where a block lacks the scalar)."""
        values = np.concatenate([c.values if c is not None else np.full(n, np.nan) for c, n in zip(columns, sizes)])
        if all(c is not None and c.present is None for c in columns):
            return Column(values)
        present = np.concatenate([np.zeros(n, bool) if c is None else (np.ones(n, bool) if c.present is None
                                                                        else c.present)
                                  for c, n in zip(columns, sizes)])
        return Column(values, present)


def merged_order(sequences) -> list:
    """The keys of ``sequences`` (each an ordered collection of keys) in one order that keeps each sequence's
    order where they agree: a key first met in a later sequence goes right after the key before it there, not at
    the end. So a case's scalars keep their product's place (the contribution ``nonlinearity`` that only some cases
    have stays among the other contributions), whatever case of the block has them first."""
    order: list = []
    seen: set = set()
    for sequence in sequences:
        previous = None
        for key in sequence:
            if key not in seen:
                order.insert(0 if previous is None else order.index(previous) + 1, key)
                seen.add(key)
            previous = key
    return order


def dict_columns(rows: list) -> dict:
    """{key: Column} of one-case {key: number} mappings, keys in their merged order (``merged_order``), NaN and
    not present where a mapping lacks the key."""
    columns = {}
    for key in merged_order(rows):
        values = np.array([row.get(key, np.nan) for row in rows], dtype=float)
        present = np.array([key in row for row in rows], dtype=bool)
        columns[key] = Column(values, None if present.all() else present)
    return columns


@dataclass
class RequirementColumns:
    """The verdicts of one requirement over cases: text fields as ``Values``, numbers as float arrays,
    ``applicable`` as a bool array, ``coverage`` as ``Values`` of tuples of source names, ``details`` as
    ``Column``s, ``curves`` as ``Values`` of {name: array} per case (None: no curves)."""

    name: Values
    passed: np.ndarray
    value: np.ndarray
    limit: np.ndarray
    margin: np.ndarray
    unit: Values
    basis: Values
    dominant: Values
    notes: Values
    applicable: np.ndarray
    reason: Values
    coverage: Values
    coverage_text: Values
    details: dict = field(default_factory=dict)
    curves: Values | None = None

    def verdict(self, k: int) -> RequirementVerdict:
        return RequirementVerdict(
            name=self.name[k], passed=bool(self.passed[k]), value=float(self.value[k]), limit=float(self.limit[k]),
            margin=float(self.margin[k]), unit=self.unit[k], basis=self.basis[k],
            details={key: float(c.values[k]) for key, c in self.details.items() if c.has(k)},
            curves=dict(self.curves[k]) if self.curves is not None else {}, dominant=self.dominant[k],
            notes=tuple(self.notes[k]), applicable=bool(self.applicable[k]), reason=self.reason[k],
            coverage=tuple(self.coverage[k]), coverage_text=self.coverage_text[k])

    @property
    def status(self) -> np.ndarray:
        """"pass", "fail" or "not_applicable" per case."""
        return status_of(self.passed, self.applicable)

    def take(self, positions) -> RequirementColumns:
        return RequirementColumns(
            *(take_field(getattr(self, f), positions) for f in _ARRAYS),
            details={k: c.take(positions) for k, c in self.details.items()},
            curves=None if self.curves is None else self.curves.take(positions))

    @classmethod
    def from_verdicts(cls, verdicts: list) -> RequirementColumns:
        """From one-case ``RequirementVerdict``s."""
        details = dict_columns([v.details for v in verdicts])
        curves = None
        if any(v.curves for v in verdicts):
            curves = Values([v.curves for v in verdicts], np.arange(len(verdicts)))
        return cls(
            name=Values.of([v.name for v in verdicts]), passed=np.array([v.passed for v in verdicts], dtype=bool),
            value=np.array([v.value for v in verdicts], dtype=float),
            limit=np.array([v.limit for v in verdicts], dtype=float),
            margin=np.array([v.margin for v in verdicts], dtype=float),
            unit=Values.of([v.unit for v in verdicts]), basis=Values.of([v.basis for v in verdicts]),
            dominant=Values.of([v.dominant for v in verdicts]), notes=Values.of([tuple(v.notes) for v in verdicts]),
            applicable=np.array([v.applicable for v in verdicts], dtype=bool),
            reason=Values.of([v.reason for v in verdicts]), coverage=Values.of([tuple(v.coverage) for v in verdicts]),
            coverage_text=Values.of([v.coverage_text for v in verdicts]), details=details, curves=curves)

    @staticmethod
    def concatenate(parts: list) -> RequirementColumns:
        sizes = [len(p.passed) for p in parts]
        keys = list(dict.fromkeys(k for p in parts for k in p.details))
        curves = None
        if any(p.curves is not None for p in parts):
            curves = Values.concatenate([p.curves if p.curves is not None else Values.repeated({}, n)
                                         for p, n in zip(parts, sizes)])
        return RequirementColumns(
            *(join_field([getattr(p, f) for p in parts]) for f in _ARRAYS),
            details={k: Column.concatenate([p.details.get(k) for p in parts], sizes) for k in keys}, curves=curves)


_ARRAYS = ("name", "passed", "value", "limit", "margin", "unit", "basis", "dominant", "notes", "applicable", "reason",
           "coverage", "coverage_text")


def take_field(column, positions):
    """A field of ``RequirementColumns`` (``Values`` or array) at ``positions``."""
    return column.take(positions) if isinstance(column, Values) else column[positions]


def join_field(parts: list):
    """A field of ``RequirementColumns`` over consecutive blocks (``Values`` or arrays) as one."""
    return Values.concatenate(parts) if isinstance(parts[0], Values) else np.concatenate(parts)


def scalar_columns(products: dict, n: int, declarations: dict | None = None) -> dict:
    """{name: Column} of every product with outputs, in chain order (``e2esim.runner.records.case_scalars``,
    case by case: a product that is the very object of an earlier one in a case is not written there)."""
    declared = dict(DECLARATIONS, **(declarations or {}))
    out: dict = {}
    written: list = []  # per earlier one-case product: the id of every case's object
    batched: list = []  # earlier batched products
    for name, value in products.items():
        product = declared.get(name)
        if product is None or product.scalars is None:
            continue
        prefix = f"{product.scalars}." if product.scalars else ""
        if isinstance(value, Batched):
            if any(value is earlier for earlier in batched):
                continue  # the residual Faraday rotation when nothing corrected it: the same product
            batched.append(value)
            columns = {k: Column(np.real(np.asarray(v)).astype(float)) for k, v in value.scalar_columns().items()}
        else:
            ids = _object_ids(value.values)[value.index]
            repeated = np.zeros(n, dtype=bool)
            for earlier in written:
                repeated |= earlier == ids
            written.append(ids)
            columns = _factor_columns(value, None if not repeated.any() else ~repeated)
        for key, column in columns.items():
            out[sys.intern(prefix + key)] = column  # one text per name, not one per block: a large run keeps them
    return out


def _factor_columns(factor: Factor, keep: np.ndarray | None) -> dict:
    values = factor.values
    _, table = (values.extended("scalar columns", _scalar_table) if isinstance(values, Catalog)
                else _scalar_table(None, values))
    columns = {}
    for key, (per_value, has) in table.items():
        present = has[factor.index]
        if keep is not None:
            present &= keep
        if not present.any():
            continue  # no case writes it (the product is an earlier one's in every case)
        columns[key] = Column(per_value[factor.index], None if present.all() else present)
    return columns


def _object_ids(values) -> np.ndarray:
    """id of every distinct value (kept in a catalog, extended as values are added)."""
    if isinstance(values, Catalog):
        return values.table("object ids", id)
    return np.array([id(v) for v in values], dtype=np.int64)


def _scalar_table(state: tuple | None, values) -> tuple:
    """(count, {scalar name: (value of every distinct product, whether it has it)}) of ``count`` values: ``state``
    (of the values before these, None for none) extended by ``values``."""
    before, table = state or (0, {})
    per_value = [{k: float(np.real(v)) for k, v in value.scalars().items()} for value in values]
    table = dict(table)
    for key in merged_order([list(table), *per_value]):
        old_values, old_has = table.get(key, (np.full(before, np.nan), np.zeros(before, dtype=bool)))
        table[key] = (np.concatenate([old_values, np.array([s.get(key, np.nan) for s in per_value], dtype=float)]),
                      np.concatenate([old_has, np.array([key in s for s in per_value], dtype=bool)]))
    return before + len(per_value), table


def requirement_columns(verdicts, n: int) -> list:
    """``RequirementColumns`` per requirement from the block's ``verdicts`` product."""
    if verdicts is None:
        return []
    if isinstance(verdicts, Batched):
        return batched_requirement_columns(verdicts)
    count = len(verdicts.values[0].verdicts) if verdicts.values else 0
    return [RequirementColumns.from_verdicts([v[j] for v in verdicts.values]).take(verdicts.index)
            for j in range(count)]


def batched_requirement_columns(verdicts) -> list:
    """``RequirementColumns`` per requirement of a ``RequirementVerdicts`` with a case axis (its fields arrays of
    the block's cases, or one value shared by all of them)."""
    n, out = verdicts.n, []
    for v in verdicts.verdicts:
        curves = Values([curves_at(v.curves, i) for i in range(n)], np.arange(n)) if v.curves else None
        applicable = np.broadcast_to(np.asarray(v.applicable, dtype=bool), (n,))
        out.append(RequirementColumns(
            name=Values.repeated(v.name, n), passed=np.broadcast_to(np.asarray(v.passed, dtype=bool), (n,)),
            value=_floats(v.value, n), limit=_floats(v.limit, n), margin=_floats(v.margin, n),
            unit=Values.repeated(v.unit, n), basis=Values.repeated(v.basis, n),
            dominant=_names(v.dominant, n), notes=Values.repeated(tuple(v.notes), n),
            details={k: Column(_floats(x, n)) for k, x in v.details.items()}, curves=curves,
            applicable=applicable, reason=Values(["", v.reason], (~applicable).astype(np.int64)),
            coverage=Values.repeated(tuple(v.coverage), n), coverage_text=Values.repeated(v.coverage_text, n)))
    return out


def _names(dominant, n: int) -> Values:
    """The dominant source of every case: one name, or an array of names (``attribution.dominant``)."""
    if isinstance(dominant, np.ndarray):
        names, index = np.unique(dominant.astype(str), return_inverse=True)
        return Values(names.tolist(), np.ravel(index))
    return Values.repeated(dominant, n)


def _floats(x, n: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(x, dtype=float), (n,))


def case_notes(model, n: int) -> Values:
    """The notes of the propagation's error model per case (``Values`` of tuples)."""
    if model is None:
        return Values.repeated((), n)
    if isinstance(model, Batched):
        return model.note_column()
    return Values([tuple(getattr(v, "notes", ())) for v in model.values], model.index)


def source_group_column(agb, n: int) -> Values:
    """{source: group} of the AGB error's contributions per case (``Values`` of dicts)."""
    if agb is None:
        return Values.repeated({}, n)
    if isinstance(agb, Batched):
        return Values.repeated(agb.source_groups(), n)
    return Values([{c.name: c.group for c in getattr(v, "contributions", ())} for v in agb.values], agb.index)


__all__ = ["Column", "RequirementColumns", "case_notes", "requirement_columns", "scalar_columns",
           "source_group_column"]
