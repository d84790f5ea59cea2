"""The scenario's ``error_terms`` list as one stage with the propagation module it refines.

``backscatter.error`` is made once and never replaced: when a scenario has error terms, the stage that provides
``backscatter.error`` (any propagation module, built-in or a plug-in's) and the terms become one composite stage.
Its ``forward`` runs that stage's ``forward`` and hands the error model through the terms in order, each wrapping
the previous model with its source (``ErrorTerm.wrap``); the chain sees only the wrapped model. So every later
stage (the budget, the retrieval, the requirements) asks the model with every term in it, and the propagation's
own model is never a product of the case (``e2esim.error_terms.wrapped.innermost`` finds it under the wrappers).
Without error terms the chain has no such stage.

The composite's ``forward`` takes blocks (``e2esim.module.batched_run``) when the propagation's does: the
propagation's ``forward`` over the block, then each term wraps the block's batched model with every case's effects
(``ErrorTerm.wrap_block``, ``e2esim.error_terms.block_wrapped``), each number bit for bit the one the case gets
alone; a case alone is wrapped the same way, as a block of one. It hands the block back, so that its cases run one
by one, where the propagation does (a Monte Carlo, a multi-channel model), where a term draws random numbers, and
where a term does not declare that its effects may be made from a block's cases (``ErrorTerm.effects_take_blocks``:
a plug-in's term that does not say so): the error model's notes then say which term ran case by case. A case alone
is wrapped case by case there too (``ErrorTermStack.one_case_only``): a Monte Carlo draw stays per case, because
each case draws from its own generator.
"""

from __future__ import annotations

from e2esim.block import Batched
from e2esim.error_model import MultiChannelErrorModel
from e2esim.error_terms.wrapped import base_samples_shape, with_notes
from e2esim.errors import ConfigError
from e2esim.kinds import Kind
from e2esim.module import fast_path

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

    forward_takes_blocks = True

    @property
    def case_by_case(self) -> tuple:
        """The terms whose effects are not made from a block's cases (``ErrorTerm.takes_blocks``)."""
        return tuple(t for t in self.terms if not t.takes_blocks)

    def forward(self, case) -> dict:
        """The propagation's products, its error model wrapped by every term (module docstring). A case alone is
        wrapped as a block of one (``ErrorTerm.wrap_block``), except where ``one_case_only`` says why it cannot be;
        a block then hands its cases back to run one by one (``per_case``), and a case alone is wrapped with its
        one-case model and its own generator (``ErrorTerm.wrap``)."""
        if self.case_by_case:
            case.per_case(f"error terms whose effects do not take blocks: {self.case_by_case[0].identity}")
        if fast_path(self.propagation) is None:
            case.per_case(f"{self.propagation.identity} runs case by case")
        out = dict(self.propagation.forward(case))
        model = out[PRODUCT]
        why = self.one_case_only(model)
        if why is None:
            for term in self.terms:
                model = term.wrap_block(model, case)
            out[PRODUCT] = case.product_of(model)
            return out
        case.per_case(why)
        for term in self.terms:
            model = term.wrap(model, case)
        slow = self.case_by_case
        if slow:
            model = with_notes(model, (f"error terms run case by case (their effects do not declare "
                                       f"effects_take_blocks): {', '.join(t.identity for t in slow)}",))
        out[PRODUCT] = model
        return out

    def one_case_only(self, model) -> str | None:
        """Why the terms must wrap ``model`` case by case, or None. A Monte Carlo model (the simulation mode draws:
        it has samples) is one: each term's effect draws its random numbers from the case's own generator, in the
        order of the case's stages, which a block of cases does not have (``e2esim.block.CaseRandom``). So is a
        model that is not batched (a multi-channel model, a plug-in's one-case model) and a term that does not
        declare that its effects may be made from a block's cases."""
        if self.case_by_case:
            return f"error terms whose effects do not take blocks: {self.case_by_case[0].identity}"
        if not isinstance(model, Batched) or isinstance(model, MultiChannelErrorModel):
            return "the propagation's error model was made case by case"
        if base_samples_shape(model) is not None:
            return "the error model has Monte Carlo samples: each term's effect draws from the case's own generator"
        return None

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
