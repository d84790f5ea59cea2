"""From a scenario's modules to the chain of stages the runner passes each case through.

Sections become stages: a stage module is a stage itself; the list of a composite kind (``e2esim.kinds.Kind``)
becomes one stage of its members: the ``calibration`` list one ``CalibrationStrategy``, the ``requirements`` list
one ``RequirementSet`` (there is always a calibration stage, with no steps when the scenario has no calibration
section, so the propagation finds the residual products: ``Kind.always``). The order follows the products: a
stage runs after every stage that provides what it needs or uses, and otherwise in the order of the sections
(the kinds' ``order``, then plug-in kinds nobody declares), so a plug-in kind (an ``interferometry`` stage, say)
takes its place by what it needs and provides.
A product that no stage provides is a ``ConfigError`` naming the stage that needs it and the registered
modules that could provide it: ``e2esim validate`` reports it before anything runs.
"""

from __future__ import annotations

from e2esim import registry
from e2esim.errors import ConfigError, Location
from e2esim.kinds import Kind

CONTEXT = ("settings", "rng", "inputs")
"""What every case has besides products (not products; never needed by name)."""


def assemble(modules: list, root: Location) -> list:
    """The stages of a case in chain order, from its modules (in section order)."""
    stages, members = [], {}
    for module in modules:
        kind = registry.kind(module.kind)
        if kind.composite is None:
            stages.append(module)
        else:
            members.setdefault(kind.name, []).append(module)
    for kind in composite_kinds():
        own = members.get(kind.name, [])
        if not (own or kind.always):
            continue
        if kind.absorbs is None:
            stages.append(composite_stage(kind, own, root))
        else:
            i = absorbed_at(kind, stages, own, root)
            stages[i] = composite_stage(kind, own, root, stages[i])
    return order(stages)


def composite_kinds() -> list:
    """The kinds whose list makes one stage, in section order."""
    return [k for k in registry.section_kinds() if k.composite is not None]


def composite_stage(kind: Kind, modules: list, root: Location, absorbed=None):
    """The one stage of a case's ``modules`` of the composite ``kind`` (none: a stage with no members, when the kind
    is ``always`` there), located at their section; ``absorbed``: the stage it takes in (``Kind.absorbs``), given
    first."""
    where = modules[0].location.parent() if modules else root.child(kind.section)
    return kind.composite(list(modules) if absorbed is None else [absorbed, *modules], where)


def absorbed_at(kind: Kind, stages: list, modules: list, root: Location) -> int:
    """Where in ``stages`` the stage is that provides the product the composite ``kind`` refines."""
    at = [i for i, s in enumerate(stages) if kind.absorbs in {p.name for p in getattr(s, "provides", ())}]
    if not at:
        where = modules[0].location.parent() if modules else root.child(kind.section)
        providers = providers_of(kind.absorbs)
        raise ConfigError(where, f"the {kind.section} list refines {kind.absorbs!r}, which no stage of this chain "
                          "provides", "add a section with one of " + (", ".join(providers) or "none registered"))
    return at[0]


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
    for kind in composite_kinds():
        provides = getattr(kind.composite, "provides", ())
        if isinstance(provides, tuple) and any(getattr(p, "name", None) == product for p in provides):
            out.append(f"{kind.section} (a list of {kind.name} types{', or none' if kind.always else ''})")
    return out
