"""Values derived once from an object that does not change: ``functools.cached_property``s, and what the error models
share of them (docs/architecture.md, "Caching").

A cached value lives in the object's own ``__dict__`` under the property's name. It is never data of the object:
``dataclasses.replace`` makes a copy without it, and the plain-data encoding (``e2esim.runner.plaindata``) leaves it
out; a maker that already holds the value (the row of a block's evaluation for one of its cases) hands it over with
``knowing``.
"""

from __future__ import annotations

from functools import cached_property


def knowing(obj, **derived):
    """``obj`` with values of its ``cached_property``s its maker has (each what the property would derive: a row of a
    block's evaluation, a polynomial the levels do not change), set before anything reads them."""
    if any(not isinstance(getattr(type(obj), name, None), cached_property) for name in derived):
        raise AttributeError(f"{type(obj).__name__} derives no {', '.join(derived)} once")
    obj.__dict__.update(derived)  # where cached_property keeps them
    return obj


def derived_values(obj) -> dict:
    """{name: value} of the ``cached_property``s ``obj`` has derived so far."""
    cls = type(obj)
    return {name: value for name, value in vars(obj).items() if isinstance(getattr(cls, name, None), cached_property)}


class EvaluatedOnce:
    """``current()`` of a single-channel error model: ``moments()`` at its own levels, derived once (``evaluated``;
    the retrieval and every requirement of a case ask for it)."""

    def current(self):
        return self.evaluated

    @cached_property
    def evaluated(self):
        """``current()``, derived once (or known from the model's maker)."""
        return self.moments()


class JointEvaluatedOnce:
    """``current_joint()`` of a multi-channel error model: its ``evaluated``, which the model derives once."""

    def current_joint(self):
        return self.evaluated


class RemovedOnce:
    """``without(source)`` of an error model, made once per source (the attribution and the Shapley split of every
    requirement ask the same variants); the model says how in ``_without``."""

    def without(self, source: str):
        if source not in self.sources:
            raise KeyError(f"unknown error source {source!r}; sources: {', '.join(self.sources)}")
        made = self.removals
        if source not in made:
            made[source] = self._without(source)
        return made[source]

    @cached_property
    def removals(self) -> dict:
        """{source: the model without it}, each made when first asked: a Shapley split asks each variant for one
        source only, and a variant of an HV model without a level source costs an evaluation."""
        return {}
