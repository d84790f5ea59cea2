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

    def forward(self, case) -> dict:
        system, faraday = case["system"], case["faraday.geophysical"]
        record = CalibrationRecord(system, faraday, case.get("scene.covariance"), declared=bool(self.modules))
        for module in self.modules:
            for name, step in module.steps(case):
                record = record.extended(name, step)
        # The whole strategy is simulated once: steps depend on each other (a Faraday-rotation estimate on data
        # a transponder calibration has corrected), and the record keeps a summary of every step.
        record, residual_system, residual_faraday = record.simulate(case.rng, case.settings.realisations)
        return {"calibration": record, "system.residual": residual_system, "faraday.residual": residual_faraday}

    def forward_block(self, block):
        """``forward`` for a block of cases when there is no calibration section: the residual products are the
        raw ones themselves (``UncalibratedBlock``); None (case by case) when there are steps to simulate."""
        if self.modules:
            return None
        from e2esim.calibration.record_block import UncalibratedBlock

        system, faraday = block["system"], block["faraday.geophysical"]
        record = UncalibratedBlock(system, faraday, block.get("scene.covariance"))
        return {"calibration": record, "system.residual": system, "faraday.residual": faraday}


KIND = Kind("calibration", "a calibration strategy (list of steps) and the residual errors it leaves", 50,
            "calibration", composite=CalibrationStrategy, always=True)
"""The ``calibration`` section: a list of steps that make one stage, in every chain (registered in pyproject.toml,
``e2esim.kinds``)."""
