"""The scenario's ``requirements`` list as one stage of the chain: it provides the ``verdicts`` product."""

from __future__ import annotations

import dataclasses

import numpy as np

from e2esim import products as P
from e2esim.errors import ConfigError
from e2esim.kinds import Kind
from e2esim.module import fast_path
from e2esim.requirements.verdict import RequirementVerdicts

_CURVE_CASES = 32
"""Cases whose trade-off curves are traced at once (a few tens of MB of temporaries)."""


def with_coverage(requirement, verdict, case):
    """``verdict`` with the error sources its checked value covers (``e2esim.requirements.coverage``), unless the
    requirement gave its own, and a note where an ``all`` verdict's chain lacks a group or the Monte Carlo
    cross-check leaves out assumed terms."""
    from e2esim.requirements.coverage import assumed_values, setting, verdict_coverage

    if verdict.coverage:
        return verdict
    coverage, text, missing = verdict_coverage(requirement, case)
    notes = list(verdict.notes)
    if missing and setting(requirement) == "all":
        notes.append(f"sources: all, but this case's chain computed no {' and no '.join(missing)} term")
    if assumed_values(requirement) and getattr(case.get("agb.error"), "samples", None) is not None:
        notes.append("no Monte Carlo cross-check: the assumed terms are combined with the analytic AGB error only")
    return dataclasses.replace(verdict, coverage=coverage, coverage_text=text, notes=tuple(notes))


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

    forward_takes_blocks = True

    def forward(self, case) -> dict:
        """The verdicts of a block of cases at once (``RequirementVerdicts`` with the case axis), a case alone being a
        block of one: every requirement evaluates the block (``batched``) and the block's AGB error carries the case
        axis (analytic). Otherwise, or when one of them cannot take the block as a whole, the engine runs the block's
        cases one by one (``per_case`` says why; a case alone is always evaluated)."""
        if "agb.error" not in case or not all(
                fast_path(r, "batched", "evaluate") and r.si.get("basis", "auto") != "montecarlo"
                for r in self.requirements):
            case.per_case("a requirement evaluates cases alone")
        else:
            case.batched("agb.error")  # analytic: made for the block at once
        # a trade-off curve holds (cases x points x root-finding levels x quadrature nodes) numbers: in parts
        size = _CURVE_CASES if any(r.config.get("tradeoff_curve") for r in self.requirements) else len(case)
        parts = []
        for start in range(0, len(case), size):
            part = case if size >= len(case) else case.take(np.arange(start, min(start + size, len(case))))
            try:
                parts.append(RequirementVerdicts(tuple(with_coverage(r, r.evaluate(part), part)
                                                       for r in self.requirements), len(part)))
            except ConfigError:
                case.per_case("a requirement cannot take the block as a whole")
                raise  # a case alone: the requirement's own message
        return {"verdicts": parts[0] if len(parts) == 1 else RequirementVerdicts.concatenate(parts)}


KIND = Kind("requirement", "verdict of a mission requirement on the AGB error", 80, "requirements",
            composite=RequirementSet)
"""The ``requirements`` section: a list of requirements that make one stage (registered in pyproject.toml,
``e2esim.kinds``)."""
