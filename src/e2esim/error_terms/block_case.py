"""One case of a block as a case alone, for an error term's one-case ``effect`` inside the batched engine.

An error term makes its ``Effect`` for a case (``ErrorTerm.effect(case, model)``). In a block of cases
(``e2esim.block.Block``) the stage asks each term for the effect of every case from that case's view: its index,
sweep inputs, settings and products (each product's one-case value, ``item``, made when read), exactly what the
per-case engine hands the term. A term that draws random numbers cannot be served from a block (each case has its
own generator, shared with the other stages of the case): the view's ``rng`` hands the block back (``NotBatched``),
and its cases run one by one. A term whose effects do not read the model they wrap (``ErrorTerm.effects_ignore_model``)
gets ``UNREAD_MODEL`` instead of the case's one-case model, which costs a map cell its Faraday climatology and the
rest of the propagation's one-case model; reading it anyway hands the block back too.
"""

from __future__ import annotations

from e2esim.block import NotBatched
from e2esim.case import Case, ItemProducts, SweepInputs


class _NoDraws:
    """The generator of a case seen from a block: any use hands the block back (module docstring)."""

    def __getattr__(self, name):
        raise NotBatched("an error term draws random numbers: each case has its own generator")


class _UnreadModel:
    """The error model handed to a term that declares it does not read it (module docstring)."""

    def __getattr__(self, name):
        raise NotBatched(f"an error term that declares effects_ignore_model reads its model ({name})")


UNREAD_MODEL = _UnreadModel()


def case_of(block, position: int) -> Case:
    """Case ``position`` of ``block`` as the per-case engine hands it to a stage (module docstring); a case alone (a
    block of one) is its own, with its own generator."""
    if isinstance(block, Case):
        return block
    index = int(block.indices[position])
    return Case(index=index, inputs=SweepInputs(block.sweep, index), settings=block.settings, rng=_NoDraws(),
                products=ItemProducts(block.products, position), services=block.services)


__all__ = ["UNREAD_MODEL", "case_of"]
