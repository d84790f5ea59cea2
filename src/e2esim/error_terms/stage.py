"""The scenario's ``error_terms`` list as one stage with the propagation module it refines.

``backscatter.error`` is made once and never replaced: when a scenario has error terms, the stage that provides
``backscatter.error`` (any propagation module, built-in or a plug-in's) and the terms become one composite stage.
Its ``forward`` runs that stage's ``forward`` and hands the error model through the terms in order, each wrapping
the previous model with its source (``ErrorTerm.wrap``); the chain sees only the wrapped model. So every later
stage (the budget, the retrieval, the requirements) asks the model with every term in it, and the propagation's
own model is never a product of the case (``e2esim.error_terms.wrapped.innermost`` finds it under the wrappers).
Without error terms the chain has no such stage. The composite's ``forward`` takes no blocks: a case with
error terms runs case by case in both engines (the reference path), so both give the same numbers.
"""

from __future__ import annotations

from e2esim.errors import ConfigError
from e2esim.kinds import Kind

PRODUCT = "backscatter.error"


def _union(groups) -> tuple:
    return tuple(dict.fromkeys(name for group in groups for name in group))


class ErrorTermStack:
    """The stage providing ``backscatter.error`` (``propagation``) with the error terms ``terms`` (stage interface
    of ``e2esim.module.Stage``); ``modules``: all of them, the propagation first."""

    kind = "error_terms"

    def __init__(self, propagation, terms):
        self.propagation = propagation
        self.terms = tuple(terms)
        self.modules = (propagation, *self.terms)
        self.location = propagation.location
        own = {p.name for p in propagation.provides}
        self.provides = propagation.provides
        self.needs = _union([propagation.needs, *(t.needs for t in self.terms)])
        self.uses = tuple(n for n in _union([propagation.uses, *(t.uses for t in self.terms)]) if n not in own)
        sources = [s for t in self.terms for s in t.sources]
        repeated = sorted({s for s in sources if sources.count(s) > 1})
        if repeated:
            term = next(t for t in self.terms if repeated[0] in t.sources)
            raise ConfigError(term.location.child("source"), f"two error terms have the source {repeated[0]!r}",
                              "give each error term its own source name")
        for term in self.terms:
            inside = [n for n in term.needs if n in own]
            if inside:
                raise ConfigError(term.location, f"{term.identity} needs {inside[0]!r}, which the stage it refines "
                                  f"({propagation.identity}) provides itself", "an error term reads products of "
                                  "earlier stages only")

    @property
    def identity(self) -> str:
        return f"{self.propagation.identity} with the error terms {', '.join(t.source for t in self.terms)}"

    def forward(self, case) -> dict:
        out = dict(self.propagation.forward(case))
        model = out[PRODUCT]
        for term in self.terms:
            model = term.wrap(model, case)
        out[PRODUCT] = model
        return out

    def insensitivity(self, owner, key: str):
        """The propagation's reason, when no term reads ``owner``'s products."""
        made = {p.name for p in getattr(owner, "provides", ())}
        if any(made & set((*t.needs, *t.uses)) for t in self.terms):
            return None
        return self.propagation.insensitivity(owner, key)


def error_term_stack(members: list, where) -> ErrorTermStack:
    """The composite of the ``error_terms`` section (``e2esim.kinds.Kind.composite``): ``members[0]`` is the stage
    that provides ``backscatter.error`` (absorbed, ``Kind.absorbs``), the rest the terms in order."""
    return ErrorTermStack(members[0], members[1:])


KIND = Kind("error_terms", "error sources added to the propagation's error model, in order (a list)", 65,
            "error_terms", composite=error_term_stack, absorbs=PRODUCT)
"""The ``error_terms`` kind, registered in pyproject.toml (entry-point group ``e2esim.kinds``)."""

__all__ = ["KIND", "ErrorTermStack", "error_term_stack"]
