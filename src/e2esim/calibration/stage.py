"""The scenario's ``calibration`` section as one stage: a strategy of steps and the residual errors it leaves.

It provides ``calibration`` (the record of what the steps did), ``system.residual`` and ``faraday.residual``
(what the propagation applies), beside the raw ``system`` and ``faraday.geophysical``, which it never
changes. Without a calibration section the chain still has this stage, with no steps: the residual
products are then the raw ones themselves.
"""

from __future__ import annotations

from e2esim import products as P
from e2esim.calibration.record import CalibrationRecord
from e2esim.kinds import Kind


def _union(groups) -> tuple:
    return tuple(dict.fromkeys(name for group in groups for name in group))


class CalibrationStrategy:
    """The calibration modules of a scenario, simulated as one strategy (stage interface of
    ``e2esim.module.Stage``).

    modules : the ``CalibrationModule`` list, in order (empty: no calibration section). location : the
    section, for messages.
    """

    kind = "calibration"
    provides = (P.CALIBRATION, P.SYSTEM_RESIDUAL, P.FARADAY_RESIDUAL)

    def __init__(self, modules, location):
        self.modules = tuple(modules)
        self.location = location
        self.needs = _union(m.needs for m in self.modules) or ("system", "faraday.geophysical")
        self.uses = _union(m.uses for m in self.modules)

    @property
    def identity(self) -> str:
        return "the calibration strategy"

    forward_takes_blocks = True

    def forward(self, case) -> dict:
        """The record and the residual products of a case; of a block of cases at once when there is no
        calibration section (the residual products are then the raw ones themselves, and the record, with the
        case axis of the block's products, makes each case's when asked). Steps are simulated case by case."""
        if self.modules:
            case.per_case("calibration steps are simulated for each case")
        system, faraday = case["system"], case["faraday.geophysical"]
        record = CalibrationRecord(system, faraday, case.get("scene.covariance"), declared=bool(self.modules))
        if not self.modules:  # what ``simulate`` gives without steps, with no generator asked for
            return {"calibration": record, "system.residual": system, "faraday.residual": faraday}
        for module in self.modules:
            for name, step in module.steps(case):
                record = record.extended(name, step)
        # The whole strategy is simulated once: steps depend on each other (a Faraday-rotation estimate on data
        # a transponder calibration has corrected), and the record keeps a summary of every step.
        record, residual_system, residual_faraday = record.simulate(case.rng, case.settings.realisations)
        return {"calibration": record, "system.residual": residual_system, "faraday.residual": residual_faraday}


KIND = Kind("calibration", "a calibration strategy (list of steps) and the residual errors it leaves", 50,
            "calibration", composite=CalibrationStrategy, always=True)
"""The ``calibration`` section: a list of steps that make one stage, in every chain (registered in pyproject.toml,
``e2esim.kinds``)."""
