"""Module kinds: what a scenario section of a kind holds, where it stands, and what it becomes in the chain.

A kind is declared once (``Kind``) and registered through the entry-point group ``e2esim.kinds`` (name: the
kind), exactly as modules are (``e2esim.registry``): e2esim's own kinds in its pyproject.toml, a plug-in's in
its own. A plug-in may also register modules of a kind nobody declares: their kind is then a scenario section
of that name that holds one module or a list, after every declared kind (``undeclared``).

A **composite** kind's section is a list of modules that together make one stage (``Kind.composite``): the
calibration steps make one ``CalibrationStrategy``, the requirements one ``RequirementSet``. Its members are
plain ``Module`` subclasses; the chain builds the stage once per distinct list of members
(``e2esim.runner.plan``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

RESERVED_SECTIONS = ("name", "description", "plugins", "simulation", "sweep", "output")
"""Top-level scenario keys that are no module section."""


@dataclass(frozen=True)
class Kind:
    """Declaration of a module kind.

    name : the registry kind (``Module.kind``), "propagation". doc : one line for the scenario reference.
    order : rank of its section among the sections (e2esim's own: 10, 20, ... 80, so that a plug-in kind fits in
        between); the chain follows the products and falls back on this order.
    section : its key in a scenario (None: no section; its modules are parts of another module, like the
        Faraday-rotation estimators). many : the section may hold a list of modules, applied in order.
    required : a scenario without the section is refused. default : the section used when it is absent
        (``{"type": ...}``), or None.
    composite : ``composite(members, where) -> Stage``: the section's list makes one stage of its members (None:
        each module is a stage). always : the composite stage is in every chain, with no members when the
        section is absent (the calibration strategy provides the residual products, raw when nothing corrects).
    absorbs : a product name, or None: the composite also takes the stage of the chain that provides this product,
        as the first of its members, and stands in its place (a list that refines a product, which a case never
        replaces: the stage makes it and the members change it before any other stage sees it).
    """

    name: str
    doc: str
    order: float
    section: str | None = None
    many: bool = True
    required: bool = False
    default: dict | None = None
    composite: Callable | None = None
    always: bool = False
    absorbs: str | None = None

    def problem(self, entry_point: str | None = None) -> str | None:
        """What is wrong with this declaration (for a plug-in's entry point), or None."""
        if not (isinstance(self.name, str) and self.name.isidentifier()):
            return f"kind name {self.name!r} is not a name (e.g. 'interferometry')"
        if entry_point is not None and entry_point != self.name:
            return f"the entry point is named {entry_point!r} but declares the kind {self.name!r}"
        if isinstance(self.order, bool) or not isinstance(self.order, (int, float)) or self.order != self.order:
            return f"kind {self.name!r}: order {self.order!r} is not a number"
        if self.section is not None and not (isinstance(self.section, str) and self.section.isidentifier()):
            return f"kind {self.name!r}: section {self.section!r} is not a name"
        if self.section in RESERVED_SECTIONS:
            return f"kind {self.name!r}: section {self.section!r} is reserved ({', '.join(RESERVED_SECTIONS)})"
        if self.default is not None and not (isinstance(self.default, dict) and isinstance(
                self.default.get("type"), str)):
            return f"kind {self.name!r}: default {self.default!r} is not a section with a type"
        if self.composite is not None and not callable(self.composite):
            return f"kind {self.name!r}: composite {self.composite!r} is not callable (members, where) -> Stage"
        if self.composite is not None and not self.many:
            return f"kind {self.name!r}: a composite section holds a list (many=True)"
        if self.absorbs is not None and (self.composite is None or not isinstance(self.absorbs, str)):
            return f"kind {self.name!r}: absorbs {self.absorbs!r} needs a composite and a product name"
        return None


def undeclared(name: str) -> Kind:
    """The kind of modules a plug-in registers without declaring their kind: a section of that name holding one
    module or a list, after every declared kind."""
    return Kind(name, f"plug-in stage kind {name!r}", float("inf"), section=name)


ORBIT = Kind("orbit", "acquisition geometry: where and when the mission looks", 10, "orbit", many=False)
SCENE = Kind("scene", "scattering covariance of the target for an AGB level and biome", 20, "scene", many=False,
             required=True)
INSTRUMENT = Kind("instrument", "system-error statistics, noise and gain of the radar, and its specification", 30,
                  "instrument", many=False, required=True)
IONOSPHERE = Kind("ionosphere", "Faraday rotation of the case (its geophysical distribution)", 40, "ionosphere",
                  many=False, default={"type": "constant_faraday"})
PROPAGATION = Kind("propagation", "error of the backscattering coefficient (an error model), and its random-error "
                   "budget", 60, "propagation", default={"type": "hv_backscatter_error"})
RETRIEVAL = Kind("retrieval", "relative AGB error through a backscatter-AGB model", 70, "retrieval", many=False,
                 default={"type": "power_law"})
FARADAY_ESTIMATOR = Kind("faraday_estimator", "a Faraday-rotation estimator used by the faraday_correction "
                         "calibration step", 100)
"""e2esim's own kinds without a composite (calibration: ``e2esim.calibration.stage``; requirement:
``e2esim.requirements.stage``), each registered in pyproject.toml."""
