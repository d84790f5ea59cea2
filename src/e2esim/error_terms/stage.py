"""The scenario's ``error_terms`` list as one stage with the propagation module it refines.

``backscatter.error`` is made once and never replaced: when a scenario has error terms, the stage that provides
``backscatter.error`` (any propagation module, built-in or a plug-in's) and the terms become one composite stage.
Its ``forward`` runs that stage's ``forward`` and hands the error model through the terms in order, each wrapping
the previous model with its source (``ErrorTerm.wrap``); the chain sees only the wrapped model. So every later
stage (the budget, the retrieval, the requirements) asks the model with every term in it, and the propagation's
own model is never a product of the case (``e2esim.error_terms.wrapped.innermost`` finds it under the wrappers).
Without error terms the chain has no such stage. The composite has no batched ``forward_block``: a case with
error terms runs case by case in both engines (the reference path), so both give the same numbers.
"""

from __future__ import annotations

from e2esim.errors import ConfigError

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
        sources = [t.source for t in self.terms]
        repeated = sorted({s for s in sources if sources.count(s) > 1})
        if repeated:
            term = next(t for t in self.terms if t.source == repeated[0])
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


def refined(stages: list, terms: list) -> list:
    """``stages`` with the one providing ``backscatter.error`` and ``terms`` made one ``ErrorTermStack`` (no terms:
    ``stages`` itself); a ``ConfigError`` when no stage provides it."""
    if not terms:
        return stages
    at = [i for i, s in enumerate(stages) if PRODUCT in {p.name for p in getattr(s, "provides", ())}]
    if not at:
        raise ConfigError(terms[0].location.parent(),
                          "error terms refine backscatter.error, which no stage of this chain provides",
                          "add a propagation section (hv_backscatter_error, polarimetric_backscatter_error, ...)")
    out = list(stages)
    out[at[0]] = ErrorTermStack(stages[at[0]], terms)
    return out


__all__ = ["ErrorTermStack", "refined"]
