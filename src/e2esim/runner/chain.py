"""From a scenario's modules to the chain of stages the runner passes each case through.

Sections become stages: a stage module is a stage itself; the ``calibration`` list becomes one
``CalibrationStrategy`` and the ``requirements`` list one ``RequirementSet`` (there is always a calibration
stage, with no steps when the scenario has no calibration section, so the propagation finds the residual
products). The order follows the products: a stage runs after every stage that provides what it needs or
uses, and otherwise in the order of the sections (``e2esim.module.KIND_ORDER``, then plug-in kinds as
listed), so a plug-in kind (an ``interferometry`` stage, say) takes its place by what it needs and provides.
A product that no stage provides is a ``ConfigError`` naming the stage that needs it and the registered
modules that could provide it: ``e2esim validate`` reports it before anything runs. With an ``error_terms`` list,
the stage that provides ``backscatter.error`` and the terms become one ``ErrorTermStack`` (``e2esim.error_terms``).
"""

from __future__ import annotations

from e2esim import registry
from e2esim.calibration.stage import CalibrationStrategy
from e2esim.error_terms.stage import ErrorTermStack, refined
from e2esim.errors import ConfigError, Location
from e2esim.requirements.stage import RequirementSet

CONTEXT = ("settings", "rng", "inputs")
"""What every case has besides products (not products; never needed by name)."""


def assemble(modules: list, root: Location) -> list:
    """The stages of a case in chain order, from its modules (in section order)."""
    stages, calibration, requirements, terms = [], [], [], []
    for module in modules:
        if module.kind == "calibration":
            calibration.append(module)
        elif module.kind == "error_terms":
            terms.append(module)
        elif module.kind == "requirement":
            requirements.append(module)
        else:
            stages.append(module)
    stages = refined(stages, terms)
    stages.append(calibration_stage(calibration, root))
    if requirements:
        stages.append(requirement_stage(requirements, root))
    return order(stages)


def calibration_stage(modules: list, root: Location) -> CalibrationStrategy:
    """The calibration strategy of a case's calibration modules (none: a strategy with no steps)."""
    return CalibrationStrategy(modules, modules[0].location.parent() if modules else root.child("calibration"))


def error_term_stage(modules: list, root: Location) -> ErrorTermStack:
    """The stage providing ``backscatter.error`` (``modules[0]``) with the error terms ``modules[1:]``."""
    return ErrorTermStack(modules[0], modules[1:])


def requirement_stage(modules: list, root: Location) -> RequirementSet:
    """The requirement set of a case's requirement modules."""
    return RequirementSet(modules, modules[0].location.parent() if modules else root.child("requirements"))


def order(stages: list) -> list:
    """Stable topological order by products; raises ``ConfigError`` for a product nobody provides."""
    provided_by: dict = {}
    for stage in stages:
        for product in stage.provides:
            provided_by.setdefault(product.name, stage)
    pending, done, available = list(stages), [], set()
    while pending:
        for i, stage in enumerate(pending):
            wanted = [n for n in stage.needs] + [n for n in stage.uses if n in provided_by]
            if all(n in available or provided_by.get(n) is stage for n in wanted):
                if any(provided_by.get(n) is stage for n in stage.needs):
                    raise ConfigError(stage.location, f"{stage.identity} needs a product it provides itself")
                done.append(pending.pop(i))
                available.update(p.name for p in stage.provides)
                break
        else:
            raise _missing(pending, available, provided_by)
    return done


def _missing(pending: list, available: set, provided_by: dict) -> ConfigError:
    for stage in pending:
        for name in stage.needs:
            if name not in provided_by:
                providers = providers_of(name)
                hint = ("modules that provide it: " + ", ".join(providers)) if providers else (
                    "no registered module provides it")
                return ConfigError(stage.location, f"{stage.identity} needs the product {name!r}, which no stage of "
                                   "this chain provides", f"add a section with one of them; {hint}")
    names = ", ".join(stage.identity for stage in pending)
    return ConfigError(pending[0].location, f"the stages {names} need each other's products (a cycle)",
                       "remove one of the dependencies")


def providers_of(product: str) -> list:
    """``kind.type`` of every registered stage module that can provide ``product``."""
    out = []
    for reg in registry.available():
        provides = getattr(reg.cls, "provides", ())
        if isinstance(provides, tuple) and any(getattr(p, "name", None) == product for p in provides):
            out.append(f"{reg.kind}.{reg.type_name}")
    if product in ("calibration", "system.residual", "faraday.residual"):
        out.append("calibration (any list of calibration steps, or none)")
    if product == "verdicts":
        out.append("requirements (a list of requirement types)")
    return out
