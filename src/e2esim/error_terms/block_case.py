"""One case of a block as a case alone, for an error term's one-case ``effect`` inside the batched engine.

An error term makes its ``Effect`` for a case (``ErrorTerm.effect(case, model)``). In a block of cases
(``e2esim.block.Block``) the stage asks each term for the effect of every case from that case's view: its index,
sweep inputs, settings and products (each product's one-case value, ``item``, made when read), exactly what the
per-case engine hands the term. A term that draws random numbers cannot be served from a block (each case has its
own generator, shared with the other stages of the case): the view's ``rng`` hands the block back (``NotBatched``),
and its cases run one by one.
"""

from __future__ import annotations

from collections.abc import Mapping

from e2esim.block import NotBatched
from e2esim.case import Case, LazyMapping, Products


class _ItemProducts(LazyMapping, Products):
    """Case ``position``'s products of a block, each made from the block's product when read."""

    __slots__ = ("_block", "_made", "_position")

    def __init__(self, block_products: Mapping, position: int):
        super().__init__({})
        self._block, self._position, self._made = block_products, position, {}

    def __getitem__(self, name):
        if name not in self._made:
            if name not in self._block:
                raise KeyError(f"product {name!r} is not in the case (products so far: {', '.join(self._block)})")
            self._made[name] = self._block[name].item(self._position)
        return self._made[name]

    def _names(self):
        return self._block

    def get(self, name, default=None):
        return self[name] if name in self._block else default


class _SweepInputs(Mapping):
    """A case's sweep inputs, read from the block's sweep table when asked (terms seldom ask)."""

    def __init__(self, table, index: int):
        self._table, self._index, self._inputs = table, index, None

    def _all(self) -> dict:
        if self._inputs is None:
            self._inputs = {} if self._table is None else self._table.inputs(self._index)
        return self._inputs

    def __getitem__(self, key):
        return self._all()[key]

    def __iter__(self):
        return iter(self._all())

    def __len__(self) -> int:
        return len(self._all())


class _NoDraws:
    """The generator of a case seen from a block: any use hands the block back (module docstring)."""

    def __getattr__(self, name):
        raise NotBatched("an error term draws random numbers: each case has its own generator")


def case_of(block, position: int) -> Case:
    """Case ``position`` of ``block`` as the per-case engine hands it to a stage (module docstring)."""
    index = int(block.indices[position])
    return Case(index=index, inputs=_SweepInputs(block.sweep, index), settings=block.settings, rng=_NoDraws(),
                products=_ItemProducts(block.products, position), services=block.services)


__all__ = ["case_of"]
