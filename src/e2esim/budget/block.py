"""The random-error budgets of a block of sweep cases: one per distinct scene and instrument, made once per run.

A budget (``BackscatterErrorBudget``) reads nothing but the case's scene and instrument, so the cases of a block
that share both share it: the batched engine gets it as a ``Factor`` whose values are made once per distinct
(scene, instrument) pair met in the run, by the stage's own one-case function, so every case has exactly the
budget ``forward`` makes for it.
"""

from __future__ import annotations

import numpy as np

from e2esim.block import Catalog, Factor
from e2esim.distinct import distinct_rows

BUDGET_CATALOG_ENTRIES = 1 << 14
"""Budgets a stage keeps for later blocks (in each process) before it starts afresh: 16,384. A budget of three
channels holds some thirty small arrays, about 6.6 kB, nearly forty times a scene (benchmarks/bench_memory.py),
so these take about 110 MB at most, where the runner's ``CATALOG_ENTRIES`` would allow 0.4 GB. A sweep that meets
more distinct scene-instrument pairs again and again makes a returning pair's budget anew (about 0.4 ms)."""


def block_budgets(scene: Factor, inst: Factor | None, made: dict, budget_of, reads=None) -> Factor:
    """The budgets of every case of a block (its scenes and instruments, ``Factor``s; ``inst`` None without an
    instrument) as a ``Factor``. Raises ``PhysicsInputError`` where a budget cannot be made.

    made : the stage's memory across blocks: the catalogs of scenes and instruments it was made from ("from"),
    {(scene number, instrument number): budget number} and the catalog of its budgets ("catalog"). Numbers in the
    run's catalogs, which hold their values, name a value for as long as the catalog lives; values that are no
    run's catalog (a case alone) are not remembered. Started afresh beyond ``BUDGET_CATALOG_ENTRIES`` budgets, or
    when the run's catalogs start afresh. budget_of : (scene, instrument or None) -> budget. reads : instrument ->
    what of it the budget reads (hashable; None: all of it). Instruments that differ only where the budget does
    not look (a swept crosstalk, a solve's searched key: e2esim.flowdown) then share their budget: it is the same
    budget, made from the same inputs.
    """
    sources = (scene.values, None if inst is None else inst.values)
    remembered = isinstance(scene.values, Catalog) and (inst is None or isinstance(inst.values, Catalog))
    if not remembered:
        made = {}
    before = made.get("from", (None, None))
    if (len(made.get("catalog", ())) > BUDGET_CATALOG_ENTRIES
            or before[0] is not sources[0] or before[1] is not sources[1]):
        made.clear()  # start afresh, as the runner's catalogs do
        made["from"] = sources
    catalog = made.setdefault("catalog", Catalog())
    codes_of = made.setdefault("codes", {})
    inst_index = np.zeros(len(scene), dtype=np.int64) if inst is None else _read_codes(inst, reads, made)
    pairs, first, inverse = distinct_rows(np.stack([scene.index, inst_index], -1))
    codes = np.empty(len(first), dtype=np.int64)
    for k, (s, i) in enumerate(pairs):
        key = (int(s), int(i), reads is None)  # an instrument number, or a reading's
        code = codes_of.get(key)
        if code is None:
            one = None if inst is None else inst.values[made["read_first"][int(i)] if reads else int(i)]
            budget = budget_of(scene.values[int(s)], one)
            code = codes_of[key] = catalog.add(budget)
        codes[k] = code
    return Factor(catalog, codes[np.ravel(inverse)])


def _read_codes(inst: Factor, reads, made: dict) -> np.ndarray:
    """Per case, a number for what the budget reads of its instrument: the instrument's own number without
    ``reads``; with it, one number per distinct reading (``made["read_first"]`` maps it back to an instrument of
    the catalog that has it), kept with the stage's memory so that numbers mean the same in every block."""
    if reads is None:
        return inst.index
    codes, first = made.setdefault("read_codes", {}), made.setdefault("read_first", [])
    of_inst = made.setdefault("read_of_inst", {})
    used, inverse = np.unique(inst.index, return_inverse=True)
    mapped = np.empty(len(used), dtype=np.int64)
    for k, i in enumerate(used):
        code = of_inst.get(int(i))
        if code is None:
            reading = reads(inst.values[int(i)])
            code = codes.get(reading)
            if code is None:
                code = codes[reading] = len(first)
                first.append(int(i))
            of_inst[int(i)] = code
        mapped[k] = code
    return mapped[np.ravel(inverse)]
