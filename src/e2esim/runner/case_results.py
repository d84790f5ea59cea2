"""What a run makes of its cases: one case's results (``CaseResult``) and a block's, as columns (``BlockResult``).

The runner makes them (``e2esim.runner.cases``), the journal stores and checks them (``e2esim.runner.journal``,
``journal_check``), the spill file keeps them on disk (``e2esim.runner.spill``) and ``ScenarioResult`` reads them
(``e2esim.runner.run``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.block import Values
from e2esim.case import Products
from e2esim.runner.columns import RequirementColumns, dict_columns


@dataclass
class CaseResult:
    """Outcome of one case: its inputs, the products its stages made (when kept) and the flattened scalars
    (``e2esim.runner.records``)."""

    index: int
    inputs: dict
    label: str
    products: Products
    scalars: dict
    verdict_list: tuple | None = None
    note_list: tuple | None = None
    groups: dict | None = None

    def get(self, name: str, default=None):
        """The product ``name`` of this case, or ``default``."""
        return self.products.get(name, default)

    @property
    def verdicts(self) -> tuple:
        """The requirement verdicts, in scenario order (empty without requirements)."""
        if self.verdict_list is not None:
            return self.verdict_list
        verdicts = self.products.get("verdicts")
        return tuple(verdicts) if verdicts is not None else ()

    @property
    def notes(self) -> tuple:
        """Remarks of the propagation's error model (e.g. why the analytic model was not used)."""
        if self.note_list is not None:
            return self.note_list
        model = self.products.get("backscatter.error")
        return tuple(getattr(model, "notes", ())) if model is not None else ()


@dataclass
class BlockResult:
    """The results of a block of cases as columns (``e2esim.runner.columns``).

    indices : the cases (B,). scalars : {name: Column}. requirements : ``RequirementColumns`` per requirement.
    notes : the error model's notes per case. groups : {source: group} of the AGB error's contributions per
    case (``Values``). products : every case's ``Products`` when kept, else None.
    """

    indices: np.ndarray
    scalars: dict
    requirements: list
    notes: Values
    groups: Values
    products: list | None = None

    def __len__(self) -> int:
        return len(self.indices)

    def case(self, k: int, inputs: dict, label: str) -> CaseResult:
        """The ``CaseResult`` of the block's k-th case."""
        scalars = {name: float(c.values[k]) for name, c in self.scalars.items() if c.has(k)}
        return CaseResult(int(self.indices[k]), inputs, label,
                          self.products[k] if self.products is not None else Products(), scalars,
                          tuple(r.verdict(k) for r in self.requirements), tuple(self.notes[k]), self.groups[k])

    def without_products(self) -> BlockResult:
        return BlockResult(self.indices, self.scalars, self.requirements, self.notes, self.groups)

    @classmethod
    def from_cases(cls, results: list) -> BlockResult:
        """From one-case results of the per-case runner (``run_case``)."""
        n = len(results)
        scalars = dict_columns([r.scalars for r in results])
        count = len(results[0].verdicts) if results else 0
        requirements = [RequirementColumns.from_verdicts([r.verdicts[j] for r in results]) for j in range(count)]
        groups = [{c.name: c.group for c in getattr(r.products.get("agb.error"), "contributions", ())}
                  for r in results]
        return cls(np.array([r.index for r in results], dtype=np.int64), scalars, requirements,
                   Values.of([tuple(r.notes) for r in results]), Values(groups, np.arange(n)),
                   [r.products for r in results])
