"""Run a block of sweep cases through their chain of stages at once (``e2esim.block``).

For each stage of the chain template the block's cases are split by the stage object they use and their
settings (usually one of each). A stage whose ``forward`` takes blocks (``Stage.forward_takes_blocks``) gets
the whole part at once and returns ``Batched`` products. Any other stage, or a batched one that hands the block
back (``Block.per_case``), runs through ``forward`` exactly as in the per-case runner, once per distinct
combination of the products it reads: cases that share them share the result, unless the stage drew random
numbers, in which case it runs for every case with the case's own generator (``CaseRandom``), so Monte Carlo
numbers are those of the per-case runner. The distinct values of every product are kept across blocks in
catalogs (``StageMemo``), with what was made from which, for stages that drew nothing: the 10 000 instruments of
a million-case sweep are each made once, and read once (``e2esim.block.Catalog``).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from e2esim.block import Batched, Block, CaseRandom, Catalog, Factor, IdentityKey
from e2esim.case import Case, ItemProducts, SweepInputs
from e2esim.distinct import distinct_rows
from e2esim.module import batched_run
from e2esim.runner.stage_products import checked_products

CATALOG_ENTRIES = 1 << 16
"""Distinct values a product's catalog holds before the run's catalogs start afresh (module docstring)."""


class StageMemo:
    """What the blocks of a run in this process share: per product, the ``Catalog`` of its distinct values, and
    per stage, which values it made from which (stage object, settings, values read) when it drew no random
    numbers. Catalogs that hold a random case's own values, or that grew beyond ``CATALOG_ENTRIES``, are
    dropped, all together, before the next block."""

    def __init__(self, size: int = CATALOG_ENTRIES):
        self.size = size
        self.catalogs: dict = {}
        self.made: dict = {}

    def catalog(self, name: str) -> Catalog:
        if name not in self.catalogs:
            self.catalogs[name] = Catalog()
        return self.catalogs[name]

    def next_block(self) -> None:
        if any(c.volatile or len(c) > self.size for c in self.catalogs.values()):
            self.catalogs, self.made = {}, {}


class BlockRun:
    """One block of cases of a plan, run stage by stage (module docstring).

    plan : the ``SweepPlan``. indices : the cases (all of one chain template). services : cache, progress and
    executor for the stages. memo : a ``StageMemo`` shared by the blocks of a run in this process.
    """

    def __init__(self, plan, indices, services, memo: StageMemo | None = None):
        self.plan = plan
        self.indices = np.asarray(indices, dtype=np.int64)
        self.services = services
        self.memo = memo if memo is not None else StageMemo()
        self.memo.next_block()
        self.objects = plan.object_codes(self.indices)
        self.settings_codes = self.objects[:, -1]
        self.products: dict = {}
        self.randoms: dict = {}  # position -> CaseRandom, for the cases a stage ran for
        template = plan.template[self.indices]
        if np.any(template != template[0]):
            raise ValueError("a block's cases must share their chain template")
        self.template = plan.templates[int(template[0])]

    def run(self) -> dict:
        """Every product of the block, in chain order."""
        for step in self.template.steps:
            self._run_step(step)
        return self.products

    # one stage --------------------------------------------------------------------------------------------------
    def _run_step(self, step) -> None:
        stage_codes, stages = self.plan.stage_codes(step, self.objects)
        results, positions = [], []
        by_case = np.ones(len(self.indices), dtype=bool)  # cases left for forward
        if any(batched_run(stage) is not None for stage in _one_of_each_class(stages.values())):
            parts = distinct_rows(np.stack([stage_codes, self.settings_codes], -1))[2]
            for part in range(parts.max() + 1):
                where = np.flatnonzero(parts == part)
                new = self._run_batched(stages[int(stage_codes[where[0]])], self._settings(where[0]), where)
                if new is not None:
                    results.append(new)
                    positions.append(where)
                    by_case[where] = False
        if by_case.any():
            where = np.flatnonzero(by_case)
            results.append(self._run_cases(step, stages, stage_codes, where))
            positions.append(where)
        new = results[0] if len(results) == 1 else _merge(results, positions)
        first = next(iter(stages.values()))
        declared = {p.name for p in first.provides}
        if set(new) != declared:
            raise TypeError(f"{first.identity} returned {', '.join(new) or 'nothing'}; it declares "
                            f"{', '.join(sorted(declared)) or 'nothing'}")
        self.products.update(new)

    def _settings(self, position: int):
        return self.plan.settings_slot.objects[int(self.settings_codes[position])]

    def _run_batched(self, stage, settings, where: np.ndarray) -> dict | None:
        batched = batched_run(stage)
        if batched is None:
            return None
        products = self.products if len(where) == len(self.indices) else {
            name: value.take(where) for name, value in self.products.items()}
        new = batched(Block(self.indices[where], settings, MappingProxyType(products), self.services, self.plan.table))
        return None if new is None else _checked_block(stage, new, len(where))

    def _run_cases(self, step, stages: dict, stage_codes: np.ndarray, where: np.ndarray) -> dict:
        """``forward`` of the cases ``where``, once per distinct combination of stage object, settings and the
        products read (per case when the stage draws random numbers). Results go into the run's catalogs; a
        combination met in an earlier block is not run again (``StageMemo``)."""
        products = self.products
        names = list(dict.fromkeys(n for stage in stages.values() for n in (*stage.needs, *stage.uses)
                                   if n in products))
        provided = [p.name for p in next(iter(stages.values())).provides]
        catalogs = [self.memo.catalog(name) for name in provided]
        columns = [stage_codes[where], self.settings_codes[where]]
        columns += [products[n].index[where] if _cataloged(products[n]) else where for n in names]
        keys = _packed(columns, all(_cataloged(products[n]) for n in names))
        if keys is None:  # not comparable across blocks: this block's distinct combinations only
            _, first, inverse = distinct_rows(np.stack(columns, -1))
            keys, known_keys, known_codes = None, np.zeros(0, np.int64), np.zeros((0, len(provided)), np.int64)
        else:
            keys, first, inverse = distinct_rows(keys[:, None])
            keys = keys[:, 0]
            known_keys, known_codes = self.memo.made.get(IdentityKey(step), (np.zeros(0, np.int64),
                                                                     np.zeros((0, len(provided)), np.int64)))
        inverse = np.ravel(inverse)
        codes = np.empty((len(first), len(provided)), dtype=np.int64)
        found = np.zeros(len(first), dtype=bool)
        if keys is not None and len(known_keys):
            at = np.minimum(np.searchsorted(known_keys, keys), len(known_keys) - 1)
            found = known_keys[at] == keys
            codes[found] = known_codes[at[found]]
        own: dict = {}  # position in ``where`` -> codes, for cases of stages that drew
        new = []
        for g in np.flatnonzero(~found):
            rep = first[g]
            position = where[rep]
            stage, settings = stages[int(stage_codes[position])], self._settings(position)
            random = self._random(position, settings)
            before = random.uses
            made = self._forward(stage, settings, position, random)
            codes[g] = [c.add(made[name]) for c, name in zip(catalogs, provided)]
            if random.uses == before:
                new.append(g)
                continue
            for c in catalogs:  # it drew: every case of the group runs with its own generator
                c.volatile = True
            for m in np.flatnonzero(inverse == g):
                if m != rep:
                    other = self._forward(stage, settings, where[m], self._random(where[m], settings))
                    own[m] = [c.add(other[name]) for c, name in zip(catalogs, provided)]
        if keys is not None and new:
            all_keys = np.concatenate([known_keys, keys[new]])
            order = np.argsort(all_keys, kind="stable")
            self.memo.made[IdentityKey(step)] = (all_keys[order], np.concatenate([known_codes, codes[new]])[order])
        per_case = codes[inverse]
        for m, row in own.items():
            per_case[m] = row
        return {name: Factor(c, per_case[:, k]) for k, (name, c) in enumerate(zip(provided, catalogs))}

    def _random(self, position: int, settings) -> CaseRandom:
        random = self.randoms.get(position)
        if random is None:
            random = self.randoms[position] = CaseRandom(settings.seed, settings.stream_of(self.indices[position]))
        return random

    def _forward(self, stage, settings, position: int, random) -> dict:
        index = int(self.indices[position])
        case = Case(index=index, inputs=SweepInputs(self.plan.table, index), settings=settings, rng=random,
                    products=ItemProducts(self.products, position), services=self.services)
        return checked_products(stage, stage.forward(case))


_READ_BITS = 17  # a catalog holds at most CATALOG_ENTRIES + a block's cases values while a block runs


def _one_of_each_class(stages) -> list:
    """One stage of each class among ``stages``: whether a stage has a fast path (``batched_run``) is decided by its
    class (``forward_takes_blocks`` and the methods in force), so a step of a million-case sweep with thousands of
    distinct instruments asks once per class, not once per instrument."""
    return list({type(stage): stage for stage in stages}.values())


def _packed(columns: list, comparable: bool) -> np.ndarray | None:
    """Each case's combination (stage object, settings, catalog numbers of what it reads) as one int64, the
    same in every block; None when the numbers are not catalog numbers or do not fit in 63 bits."""
    if not comparable:
        return None
    widths = [max(int(columns[0].max()).bit_length(), 20), max(int(columns[1].max()).bit_length(), 8)]
    widths += [_READ_BITS] * (len(columns) - 2)
    if sum(widths) > 63 or any(int(c.max()) >> w for c, w in zip(columns, widths)):
        return None
    key = np.zeros(len(columns[0]), dtype=np.int64)
    for column, width in zip(columns, widths):
        key = (key << width) | column.astype(np.int64)
    return key


def _cataloged(product) -> bool:
    return isinstance(product, Factor) and isinstance(product.values, Catalog)


def _checked_block(stage, new, n: int) -> dict:
    if not isinstance(new, dict):
        raise TypeError(f"{stage.identity}: forward returned a {type(new).__name__} for a block, not a dict of "
                        "products")
    for name, value in new.items():
        if not isinstance(value, (Factor, Batched)) or len(value) != n:
            raise TypeError(f"{stage.identity}: forward returned for a block {name!r} as a {type(value).__name__} for "
                            f"{len(value) if hasattr(value, '__len__') else '?'} cases; expected a Factor or Batched "
                            f"product for {n}")
    return new


def _merge(results: list, positions: list) -> dict:
    """Products made by parts of a block, back in the block's case order."""
    order = np.argsort(np.concatenate(positions), kind="stable")
    out = {}
    for name in results[0]:
        parts = [r[name] for r in results]
        if all(isinstance(p, Factor) for p in parts):
            merged = Factor.concatenate(parts)
        elif all(isinstance(p, Batched) for p in parts) and len({type(p) for p in parts}) == 1:
            merged = type(parts[0]).concatenate(parts)
        else:  # some parts batched, some not: one-case values
            merged = Factor([p.item(i) for p in parts for i in range(len(p))],
                            np.arange(sum(len(p) for p in parts)))
        out[name] = merged.take(order)
    return out


__all__ = ["BlockRun", "StageMemo"]
