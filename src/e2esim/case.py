"""What flows along the chain: one sweep case and the immutable mapping of the products its stages made.

``Case`` is passed through the stages in chain order, like hcipy's ``Wavefront`` through an
``OpticalSystem``: each stage reads products by name (``case["scene.covariance"]``), draws random numbers
from ``case.rng`` only, and returns its new products, which the runner adds with ``Case.adding``. Nothing
is overwritten: a product name is added once. The products are documented in ``e2esim.products``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

import numpy as np

from e2esim.block import Factor
from e2esim.settings import SimulationSettings


class Products(Mapping):
    """Immutable mapping of product name -> value, in the order the stages added them."""

    __slots__ = ("_values",)

    def __init__(self, values: Mapping | None = None):
        self._values = MappingProxyType(dict(values or {}))

    def __getitem__(self, name: str) -> Any:
        try:
            return self._values[name]
        except KeyError:
            have = ", ".join(self._values) or "none"
            raise KeyError(f"product {name!r} is not in the case (products so far: {have})") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __repr__(self) -> str:
        return f"Products({', '.join(self._values)})"

    def __reduce__(self):
        return (Products, (dict(self._values),))

    def adding(self, new: Mapping) -> Products:
        """A copy with the ``new`` products added; a name already present is an error (never overwritten)."""
        clash = [name for name in new if name in self._values]
        if clash:
            raise ValueError(f"products {', '.join(clash)} are already in the case and cannot be replaced")
        return Products({**self._values, **new})


class LazyMapping(Mapping):
    """A mapping whose values are made when read, over names known beforehand (``_names``): iteration, length and
    membership read the names alone, so that ``name in m`` makes no value."""

    __slots__ = ()

    def _names(self):
        """The collection (list, dict, ...) that holds the names."""
        raise NotImplementedError

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())

    def __len__(self) -> int:
        return len(self._names())

    def __contains__(self, name) -> bool:
        return name in self._names()


class SweepInputs(Mapping):
    """A case's sweep inputs, read from the sweep table (``e2esim.runner.sweep.SweepTable``, or None: no sweep) when
    a stage asks (stages seldom do)."""

    def __init__(self, table, index: int):
        self._table, self._index, self._inputs = table, index, None

    def _all(self) -> dict:
        if self._inputs is None:
            self._inputs = {} if self._table is None else self._table.inputs(self._index)
        return self._inputs

    def __getitem__(self, key):
        return self._all()[key]

    def __iter__(self):
        return iter(self._all())

    def __len__(self) -> int:
        return len(self._all())


class ItemProducts(LazyMapping, Products):
    """One case's products of a block (``e2esim.block``), each made from the block's product (``item``) when a
    stage reads it."""

    __slots__ = ("_block", "_made", "_position")

    def __init__(self, block_products: Mapping, position: int):
        super().__init__({})
        self._block, self._position, self._made = block_products, position, {}

    def __getitem__(self, name):
        if name not in self._made:
            if name not in self._block:
                have = ", ".join(self._block) or "none"
                raise KeyError(f"product {name!r} is not in the case (products so far: {have})")
            self._made[name] = self._block[name].item(self._position)
        return self._made[name]

    def _names(self):
        return self._block

    def get(self, name, default=None):
        return self[name] if name in self._block else default

    def __reduce__(self):
        return (Products, ({name: self[name] for name in self._block},))


class KernelMemo:
    """The process's memory of what kernels computed: the one in-memory cache, handed to stages and kernels through
    ``Services.memo`` (docs/architecture.md, "Caching"). A value is found again by the content it was computed from
    (a key a kernel derives from the values of its inputs, never an id()): cases and runs of one process that share
    a geometry, a polynomial, a month table or a campaign share the work. Bounded by the bytes of the arrays it holds
    and by a number of entries in all and per kind (``recall``'s ``keep``; the kind is a key's first element), the
    least recently used going first; a value is the kernel's own result, so a number never depends on whether it
    was found. It holds computed values only, never a user's file (a value read from one is keyed by the file's
    path, size and modification time and lives in memory only). Sent to another process, it starts empty there
    (the process's own memory, ``process_memo``, is that process's memory there)."""

    def __init__(self, max_bytes: int = 64 * 2**20, max_entries: int = 512, repeated_geometry: bool = False,
                 store=None):
        self.max_bytes, self.max_entries = max_bytes, max_entries
        self.repeated_geometry = repeated_geometry
        """Set by a caller that runs one geometry at many values of other keys (a solve's engine runs): kernels
        may then build what pays off only over many such rows (``e2esim.stack.residual_fourier``)."""
        self.store = store
        """None, or an array cache (``get``/``put``, ``e2esim.io.array_cache.ArrayCache``) where such a kernel keeps
        what it built between runs (a solve's caller sets it: ``e2esim.flowdown.evaluate``)."""
        self._values: dict = {}  # key -> (value, bytes), least recently used first
        self._bytes = 0

    def get(self, key, default=None):
        item = self._values.pop(key, None)
        if item is None:
            return default
        self._values[key] = item  # most recently used last
        return item[0]

    def __setitem__(self, key, value) -> None:
        size = _held_bytes(value)
        if size > self.max_bytes:
            return
        old = self._values.pop(key, None)
        self._bytes += size - (old[1] if old else 0)
        self._values[key] = (value, size)
        while self._bytes > self.max_bytes:  # the least recently used of those that hold arrays
            self._bytes -= self._values.pop(next(k for k, item in self._values.items() if item[1]))[1]
        while len(self._values) > self.max_entries:  # the least recently used
            self._bytes -= self._values.pop(next(iter(self._values)))[1]

    def recall(self, key: tuple, make: Callable, keep: int | None = None):
        """The value of ``key`` (a tuple of plain values, its first the kind), ``make()`` when not kept; at most
        ``keep`` entries of the kind stay (the least recently used leave first)."""
        found = self.get(key)
        if found is None:
            found = make()
            self[key] = found
            if keep is not None:
                same = [k for k in self._values if isinstance(k, tuple) and k and k[0] == key[0]]
                for k in same[:max(0, len(same) - keep)]:
                    self._bytes -= self._values.pop(k)[1]
        return found

    def __len__(self) -> int:
        return len(self._values)

    def keys(self) -> list:
        """The keys kept, the least recently used first."""
        return list(self._values)

    def __reduce__(self):
        if _PROCESS_MEMO and self is _PROCESS_MEMO[0]:
            return (process_memo, ())
        return (KernelMemo, (self.max_bytes, self.max_entries, self.repeated_geometry, self.store))


def _held_bytes(value) -> int:
    """The bytes of the arrays a memo value holds: itself, or those in a tuple, list or dict (nested)."""
    if isinstance(value, dict):
        return sum(_held_bytes(v) for v in value.values())
    if isinstance(value, (tuple, list)):
        return sum(_held_bytes(v) for v in value)
    return getattr(value, "nbytes", 0)


_PROCESS_MEMO: list = []  # the process's KernelMemo, made on first use (``process_memo``)


def process_memo() -> KernelMemo:
    """This process's ``KernelMemo``: what the runner hands every run's stages (``Services.memo``), and what a
    case made outside a run (a test, ``check_module``, a one-case call) gets by default."""
    if not _PROCESS_MEMO:
        _PROCESS_MEMO.append(KernelMemo())
    return _PROCESS_MEMO[0]


@dataclass(frozen=True)
class Services:
    """What the runner hands to stages and, through them, to physics kernels (which import none of it).

    cache : ``cache(setting)`` -> an array cache (``e2esim.io.array_cache.ArrayCache``) for a module's cache
        setting (a folder, "off" or None for the default), or None for no caching.
    progress : ``progress(iterable, total, description)`` -> the iterable, reporting progress (a tqdm bar
        on the command line), or None for silence.
    executor : a ``concurrent.futures.Executor`` for work a kernel can spread over processes, or None to
        run it here.
    """

    cache: Callable | None = None
    progress: Callable | None = None
    executor: Any = None
    memo: Any = field(default_factory=process_memo)
    """A ``KernelMemo`` (or None for none): what the kernels of this process computed, found again by value across
    cases and runs (default: ``process_memo()``)."""

    def cache_for(self, setting):
        return None if self.cache is None else self.cache(setting)

    def progress_over(self, iterable, total: int | None = None, description: str = ""):
        return iterable if self.progress is None else self.progress(iterable, total, description)


@dataclass(frozen=True)
class Case:
    """One sweep case as it passes along the chain.

    index : case number in the sweep. inputs : the sweep values of this case (dotted key -> value).
    settings : the simulation settings. rng : the case's own random generator (None once the chain is done).
    products : the products made so far. services : cache, progress and executor from the runner.
    """

    index: int
    inputs: dict
    settings: SimulationSettings
    rng: np.random.Generator | None
    products: Products = field(default_factory=Products)
    services: Services = field(default_factory=Services, compare=False, repr=False)

    def __getitem__(self, name: str) -> Any:
        return self.products[name]

    def __contains__(self, name: str) -> bool:
        return name in self.products

    def get(self, name: str, default: Any = None) -> Any:
        return self.products.get(name, default)

    def column(self, name: str, label: str, get) -> Any:
        """``get`` of the product ``name``: what a stage reads from it, in the form a block of cases gives with its
        case axis (``e2esim.block.Block.column``); ``label`` names it there."""
        return get(self.products[name])

    def common(self, name: str, label: str, get) -> Any:
        """``get`` of the product ``name``: a value every case of a block must share (text, a flag), as
        ``e2esim.block.Block.common`` gives it."""
        return get(self.products[name])

    def factor(self, name: str) -> Factor:
        """The product ``name`` as a block of one gives it: a ``Factor`` of its one value."""
        return Factor.single(self.products[name], 1)

    def batched(self, name: str) -> Any:
        """The product ``name`` as a block of one gives it with its case axis: the case's product (``Block.batched``
        refuses a block's product made case by case)."""
        return self.products[name]

    def per_case(self, why: str) -> None:
        """Nothing: a case alone is always evaluated (a ``Block`` hands such cases back to run one by one)."""

    def __len__(self) -> int:  # a case is a block of one (``e2esim.block.Block``)
        return 1

    def sweep_values(self, key: str) -> np.ndarray | None:
        """The case's sweep value of ``key`` as a block of one gives it, (1,); None when the sweep does not set it."""
        return np.asarray([self.inputs[key]]) if key in self.inputs else None

    def product_of(self, batched) -> Any:
        """The case's product from the product of a block of one made for it (``batched.item(0)``): a stage that
        builds its product with a case axis gives a case alone its one-case product."""
        return batched.item(0)

    def adding(self, new: Mapping) -> Case:
        """The case with ``new`` products added (``Products.adding``)."""
        return replace(self, products=self.products.adding(new))

    def finished(self) -> Case:
        """The case without its generator and services, to be kept or sent between processes."""
        return replace(self, rng=None, services=Services())
