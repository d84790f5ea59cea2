"""A block of sweep cases passing along the chain together, and the two forms its products take.

The runner evaluates sweeps block by block (``e2esim.runner.blocks``). A product of a block is one of:

* ``Factor``: the block's distinct values (ordinary one-case products) and, per case, which one it has. Most
  stages make few distinct values per block (the 100 scenes of a sweep over 100 AGB levels), so a stage without
  a batched implementation runs once per distinct combination of what it reads, not once per case;
* ``Batched``: one object holding arrays with a leading case axis, made by a stage whose ``forward`` takes blocks
  (the error model, the AGB error and the verdicts of the analytic chain), so that the arithmetic of a whole
  block is a few numpy operations.

Either form gives any case's one-case product (``item``), which is what the per-case runner would have made;
a stage whose ``forward`` takes blocks reads either form (``Block.column``, ``common``, ``factor``, ``batched``).
``CaseRandom`` gives a case its own generator, created on first use, so that stages that draw nothing cost
nothing and the runner can tell which stages drew (their results are per case; the others' are shared).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np


class IdentityKey:
    """A dictionary key naming an object by its identity that holds the object: unlike its ``id()``, which another
    object may get once the first is gone, this key cannot come to name another object while it lives. For
    values that compare by content badly or not at all (products holding arrays)."""

    __slots__ = ("value",)

    def __init__(self, value):
        self.value = value

    def __hash__(self) -> int:
        return id(self.value)

    def __eq__(self, other) -> bool:
        return isinstance(other, IdentityKey) and other.value is self.value


class Catalog(list):
    """The distinct values of a product over the blocks of a run (in this process), each once, with what has been
    derived from them (``table``): blocks refer to them by number (``Factor``), so a value made for an earlier
    block and what was read from it are not made again. ``volatile``: it holds values a stage made with random
    draws (one case's own), so it is not kept beyond its block."""

    def __init__(self):
        super().__init__()
        self._codes: dict = {}  # IdentityKey(value) -> number
        self._tables: dict = {}
        self.volatile = False

    def __reduce__(self):
        # a copy numbers the same values afresh, in the same order
        return _catalog_of, (list(self), self.volatile)

    def add(self, value) -> int:
        """The number of ``value`` (this very object) in the catalog, added when new."""
        key = IdentityKey(value)
        code = self._codes.get(key)
        if code is None:
            code = self._codes[key] = len(self)
            self.append(value)
        return code

    def table(self, name: str, get):
        """``get(value)`` of every value, stacked into arrays (a tuple of them when ``get`` returns a tuple),
        computed once per value: new values extend the arrays."""
        done, arrays = self._tables.get(name, (0, None))
        if done < len(self):
            rows = [get(v) for v in self[done:]]
            new = tuple(np.asarray(column) for column in zip(*rows)) if isinstance(rows[0], tuple) else np.asarray(rows)
            if arrays is not None:
                new = (tuple(np.concatenate([a, b]) for a, b in zip(arrays, new)) if isinstance(new, tuple)
                       else np.concatenate([arrays, new]))
            arrays = new
            self._tables[name] = (len(self), arrays)
        return arrays

    def extended(self, name: str, extend):
        """What ``extend(state, new values)`` made of every value, applied only to the values added since its
        last call (``state`` None at the first): work per value, not per value and block."""
        done, state = self._tables.get(("extended", name), (0, None))
        if done < len(self):
            state = extend(state, self[done:])
            self._tables[("extended", name)] = (len(self), state)
        return state


def _catalog_of(values: list, volatile: bool) -> Catalog:
    catalog = Catalog()
    for value in values:
        catalog.add(value)
    catalog.volatile = volatile
    return catalog


@dataclass(frozen=True, eq=False)
class Factor:
    """A product of a block as distinct values and, per case, the number of its value.

    values : the distinct one-case products (a ``Catalog`` of the run, or a list). index : (B,) integer,
    ``values[index[i]]`` is case i's.
    """

    values: list
    index: np.ndarray

    def __len__(self) -> int:
        return len(self.index)

    def item(self, i: int):
        return self.values[self.index[i]]

    def take(self, positions) -> Factor:
        return Factor(self.values, self.index[positions])

    def table(self, name: str, get):
        """``get`` of every distinct value (``Catalog.table``, cached in a catalog), not yet indexed by case."""
        if isinstance(self.values, Catalog):
            return self.values.table(name, get)
        rows = [get(v) for v in self.values]
        return tuple(np.asarray(column) for column in zip(*rows)) if isinstance(rows[0], tuple) else np.asarray(rows)

    def gather(self, get, dtype=float, name: str | None = None) -> np.ndarray:
        """``get(value)`` of every case, computed once per distinct value: (B,) array (or (B, ...) for
        array-valued ``get``); with a ``name``, kept in the catalog for later blocks (``table``)."""
        if name is not None and isinstance(self.values, Catalog):
            return np.asarray(self.values.table(name, get), dtype=dtype)[self.index]
        return np.asarray([get(v) for v in self.values], dtype=dtype)[self.index]

    @classmethod
    def single(cls, value, n: int) -> Factor:
        return cls([value], np.zeros(n, dtype=np.int64))

    @staticmethod
    def concatenate(parts: list) -> Factor:
        if all(p.values is parts[0].values for p in parts):
            return Factor(parts[0].values, np.concatenate([p.index for p in parts]))
        values, indices, offset = [], [], 0
        for part in parts:
            values += list(part.values)
            indices.append(part.index + offset)
            offset += len(part.values)
        return Factor(values, np.concatenate(indices))


class Batched:
    """Base class of products that hold a whole block as arrays with a leading case axis.

    Subclasses are frozen dataclasses; ``take`` and ``concatenate`` work field by field (arrays with the case
    axis are indexed, ``Factor`` and ``Batched`` fields recurse, anything else is shared), and subclasses give
    ``item`` (the one-case product of case i) and ``scalar_columns`` (the output scalars of every case,
    the names of the one-case product's ``scalars``). A product made for one case and for a block alike (the
    error model, the AGB error, the Faraday-rotation climatology) declares its ``case_shape`` instead: () for one
    case, a block of one that is its own item; (B,) for a block, whose ``block_item`` gives case i's.
    """

    @property
    def case_shape(self) -> tuple:  # () for one case (no case axis), (B,) for a block
        raise NotImplementedError

    def __len__(self) -> int:
        return self.case_shape[0] if self.case_shape else 1

    def __bool__(self) -> bool:  # a product, whatever its number of cases (a one-case product may have no length)
        return True

    def item(self, i: int):
        return self if self.case_shape == () else self.block_item(i)

    def block_item(self, i: int):
        raise NotImplementedError

    def scalar_columns(self) -> dict:
        """{name: (B,) float array}; NaN where a case has no such scalar (``present`` masks say which)."""
        return {}

    def take(self, positions):
        n = len(self)
        return dataclasses.replace(self, **{f.name: _take(getattr(self, f.name), positions, n)
                                            for f in dataclasses.fields(self) if f.init})

    @classmethod
    def concatenate(cls, parts: list):
        first = parts[0]
        n = [len(p) for p in parts]
        return dataclasses.replace(first, **{f.name: _concatenate([getattr(p, f.name) for p in parts], n)
                                             for f in dataclasses.fields(first) if f.init})


def _take(value, positions, n: int):
    if isinstance(value, (Factor, Batched)):
        return value.take(positions)
    if isinstance(value, np.ndarray) and value.ndim and value.shape[0] == n:
        return value[positions]
    if isinstance(value, dict):
        return {k: _take(v, positions, n) for k, v in value.items()}
    if isinstance(value, tuple) and value and all(isinstance(v, np.ndarray) for v in value):
        return tuple(_take(v, positions, n) for v in value)
    return value


def _concatenate(values: list, n: list):
    first = values[0]
    if isinstance(first, Factor):
        return Factor.concatenate(values)
    if isinstance(first, Batched):
        return type(first).concatenate(values)
    if isinstance(first, np.ndarray) and first.ndim and first.shape[0] == n[0]:
        return np.concatenate(values)
    if isinstance(first, dict):
        return {k: _concatenate([v[k] for v in values], n) for k in first}
    if isinstance(first, tuple) and first and all(isinstance(v, np.ndarray) for v in first):
        return tuple(_concatenate([v[i] for v in values], n) for i in range(len(first)))
    return first


@dataclass(frozen=True, eq=False)
class Values:
    """A column of Python values over cases (text, tuples, mappings) that repeat: each distinct value stored
    once, ``values[index[k]]`` is case k's. Cheap to keep, to send and to journal for a million cases."""

    values: list
    index: np.ndarray

    def __len__(self) -> int:
        return len(self.index)

    def __getitem__(self, k):
        return self.values[int(self.index[k])]

    def take(self, positions) -> Values:
        return Values(self.values, self.index[positions])

    def tolist(self) -> list:
        return [self.values[i] for i in self.index]

    @classmethod
    def of(cls, values: list) -> Values:
        """From one value per case (equal hashable values stored once)."""
        codes: dict = {}
        distinct, index = [], np.empty(len(values), dtype=np.int64)
        for k, value in enumerate(values):
            try:
                key = ("=", value) if value.__hash__ is not None else IdentityKey(value)
                code = codes.get(key)
            except TypeError:  # a tuple holding a mapping, say
                key = IdentityKey(value)
                code = codes.get(key)
            if code is None:
                code = codes[key] = len(distinct)
                distinct.append(value)
            index[k] = code
        return cls(distinct, index)

    @classmethod
    def repeated(cls, value, n: int) -> Values:
        return cls([value], np.zeros(n, dtype=np.int64))

    @staticmethod
    def concatenate(parts: list) -> Values:
        values, indices, offset = [], [], 0
        for part in parts:
            values += list(part.values)
            indices.append(part.index + offset)
            offset += len(part.values)
        return Values(values, np.concatenate(indices) if indices else np.zeros(0, dtype=np.int64))


def join(parts: list):
    """Block products of consecutive parts (all ``Factor``s or all of one ``Batched`` type) as one."""
    return _concatenate(parts, [len(p) for p in parts])


@dataclass(frozen=True, eq=False)
class Block:
    """Cases that pass a stage together: their indices, the settings they share, their products so far, the
    runner's services and the sweep (``e2esim.runner.sweep.SweepTable``, None outside a run). ``block[name]``
    is a ``Factor`` or a ``Batched`` product."""

    indices: np.ndarray
    settings: object
    products: Mapping
    services: object = None
    sweep: object = None

    def sweep_values(self, key: str) -> np.ndarray | None:
        """The sweep value of ``key`` in every case, (B,) array; None when the sweep does not set it."""
        if self.sweep is None or key not in self.sweep.keys:
            return None
        return self.sweep.column(key, self.indices)

    def __len__(self) -> int:
        return len(self.indices)

    def __getitem__(self, name: str):
        try:
            return self.products[name]
        except KeyError:
            have = ", ".join(self.products) or "none"
            raise KeyError(f"product {name!r} is not in the block (products so far: {have})") from None

    def __contains__(self, name: str) -> bool:
        return name in self.products

    def get(self, name: str, default=None):
        return self.products.get(name, default)

    def column(self, name: str, label: str, get):
        """``get`` of every case's product ``name`` with the case axis first, as ``Case.column`` gives it for one
        case, so that a stage's ``forward`` reads a block as it reads a case: a ``Factor``'s distinct values are
        each read once (once per run in a catalog, under ``label``); a ``Batched`` product, which holds every
        case, answers ``get`` itself. A tuple from ``get`` gives a tuple of columns."""
        product = self[name]
        if not isinstance(product, Factor):
            return get(product)
        table = product.table(label, get)
        return tuple(x[product.index] for x in table) if isinstance(table, tuple) else table[product.index]

    def common(self, name: str, label: str, get):
        """``get`` of the product ``name``, a value every case of the block shares (text, a flag: ``Case.common``
        gives a case's), read once per distinct value; ``NotBatched`` where the cases differ (they then run one by
        one). ``label`` says what it is."""
        product = self[name]
        if not isinstance(product, Factor):
            return get(product)
        values = [get(product.values[int(k)]) for k in np.unique(product.index)]
        first = values[0]
        if any(v != first for v in values[1:]):
            raise NotBatched(f"{label} differs between the block's cases")
        return first

    def factor(self, name: str) -> Factor:
        """The product ``name`` as the ``Factor`` of its distinct values; ``NotBatched`` when it carries a case axis
        instead (``Case.factor`` gives a case alone's as a block of one)."""
        product = self[name]
        if not isinstance(product, Factor):
            raise NotBatched(f"{name} carries a case axis, not distinct values")
        return product

    def batched(self, name: str):
        """The product ``name`` with its case axis (a stage's batched answer); ``NotBatched`` when it was made case by
        case (a ``Factor`` of one-case values)."""
        product = self[name]
        if isinstance(product, Factor):
            raise NotBatched(f"{name} was made case by case")
        return product

    def per_case(self, why: str) -> None:
        """Hand the block back to the engine, which then runs its cases one by one (``why`` says what needs a case
        alone: a Monte Carlo, a case the batched equations do not describe)."""
        raise NotBatched(why)

    @staticmethod
    def product_of(batched):
        """The block's product as made, with its case axis (``Case.product_of`` gives a case alone its item)."""
        return batched

    @property
    def index(self) -> str:
        return f"{int(self.indices[0])} (and others of its block)"

    @property
    def rng(self):
        raise NotBatched("a stage draws random numbers: each case has its own generator")

    def take(self, positions) -> Block:
        """The block of the cases at ``positions``."""
        return Block(self.indices[positions], self.settings,
                     {name: value.take(positions) for name, value in self.products.items()}, self.services,
                     self.sweep)


class NotBatched(Exception):
    """A batched implementation cannot take this block as a whole (it then runs case by case)."""


class CaseRandom:
    """The generator of one case, ``numpy.random.Generator(PCG64(SeedSequence(seed, spawn_key=(index,))))``,
    created when a stage first uses it; ``uses`` counts attribute look-ups, so the runner can tell whether a
    stage drew (``e2esim.runner.run.case_generator`` gives the same generator to the per-case runner)."""

    __slots__ = ("_generator", "index", "seed", "uses")

    def __init__(self, seed: int, index: int):
        self.seed, self.index, self.uses, self._generator = seed, int(index), 0, None

    def __getattr__(self, name):
        self.uses += 1
        if self._generator is None:
            self._generator = np.random.Generator(
                np.random.PCG64(np.random.SeedSequence(self.seed, spawn_key=(self.index,))))
        return getattr(self._generator, name)


__all__ = ["Batched", "Block", "CaseRandom", "Catalog", "Factor", "IdentityKey", "NotBatched", "Values", "join"]
