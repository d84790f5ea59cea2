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
from e2esim.errors import PhysicsInputError

BUDGET_CATALOG_ENTRIES = 1 << 14
"""Budgets a stage keeps for later blocks (in each process) before it starts afresh: 16,384. A budget of three
channels holds some thirty small arrays, about 6.6 kB, nearly forty times a scene (benchmarks/bench_memory.py),
so these take about 110 MB at most, where the runner's ``CATALOG_ENTRIES`` would allow 0.4 GB. A sweep that meets
more distinct scene-instrument pairs again and again makes a returning pair's budget anew (about 0.4 ms)."""


def block_budgets(block, made: dict, budget_of) -> Factor | None:
    """The budgets of every case of ``block`` as a ``Factor``; None when the scene or the instrument is not a
    ``Factor`` or a budget cannot be made (the per-case run then says which case).

    made : the stage's memory across blocks, {(id(scene), id(instrument)): (number, scene, instrument)} and
    the catalog of its budgets under "catalog" (the products are kept with their numbers, so that their ids
    stay theirs; started afresh beyond ``BUDGET_CATALOG_ENTRIES`` budgets). budget_of : (scene, instrument or
    None) -> budget.
    """
    scene, inst = block["scene.covariance"], block.get("instrument")
    if not isinstance(scene, Factor) or (inst is not None and not isinstance(inst, Factor)):
        return None
    if len(made.get("catalog", ())) > BUDGET_CATALOG_ENTRIES:  # start afresh, as the runner's catalogs do
        made.clear()
    catalog = made.setdefault("catalog", Catalog())
    inst_index = np.zeros(len(scene), dtype=np.int64) if inst is None else inst.index
    pairs, first, inverse = distinct_rows(np.stack([scene.index, inst_index], -1))
    codes = np.empty(len(first), dtype=np.int64)
    for k, (s, i) in enumerate(pairs):
        scene_value = scene.values[int(s)]
        inst_value = None if inst is None else inst.values[int(i)]
        key = (id(scene_value), id(inst_value))
        known = made.get(key)
        if known is None or known[1] is not scene_value or known[2] is not inst_value:  # (ids of another process)
            try:
                budget = budget_of(scene_value, inst_value)
            except PhysicsInputError:
                return None
            known = made[key] = (catalog.add(budget), scene_value, inst_value)
        codes[k] = known[0]
    return Factor(catalog, codes[np.ravel(inverse)])
