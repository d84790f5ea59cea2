"""The scenario's ``requirements`` list as one stage of the chain: it provides the ``verdicts`` product."""

from __future__ import annotations

from e2esim import products as P
from e2esim.requirements.verdict import RequirementVerdicts


def _union(groups) -> tuple:
    return tuple(dict.fromkeys(name for group in groups for name in group))


class RequirementSet:
    """Evaluates every requirement of the scenario, in order (stage interface of ``e2esim.module.Stage``).

    requirements : the ``Requirement`` modules. location : the scenario's ``requirements`` section.
    """

    kind = "requirement"
    provides = (P.VERDICTS,)

    def __init__(self, requirements, location):
        self.requirements = tuple(requirements)
        self.location = location
        self.needs = _union(r.needs for r in self.requirements)
        self.uses = _union(r.uses for r in self.requirements)

    @property
    def identity(self) -> str:
        return "the requirements"

    @property
    def modules(self) -> tuple:
        return self.requirements

    def forward(self, case) -> dict:
        return {"verdicts": RequirementVerdicts(tuple(r.evaluate(case) for r in self.requirements))}
