"""The effects of many cases evaluated together: one ``Effect`` whose numbers are arrays over a case axis.

A block of cases (``e2esim.error_terms.block_wrapped``) holds one effect per case, and on a map every case's effect
is distinct (each cell has its own screens). An effect class that lists its per-case numbers in ``stacked_fields``
lets them be stacked: ``stacked(first, columns, ndim)`` is an effect of that class whose listed fields are arrays
with the case axis first, then ndim - 1 axes of length 1 (those of the levels asked), then the field's own axis for
a tuple (the acquisitions, the channels) or, for a number, the axes of length 1 that ``stacked_fields`` gives it (1
where the one-case equations combine it with a tuple's axis, 0 where they combine it with the level). Its ``joint``
then runs the one-case equations once for all those cases, with the same operations in the same order on every
element as each case alone, so every number is bit for bit the case's own (tests/test_error_terms_stacked.py).
Effects stack together only when they are of the same class, agree on every other field (a flag used in a branch,
say) and have tuples of the same lengths (``stack_key``): a sum over the acquisitions then runs over rows of the same
length. A class that does not list its fields itself (a plug-in's, a subclass's) is evaluated effect by effect.
"""

from __future__ import annotations

import functools
from dataclasses import fields, replace

import numpy as np

NOT_NUMBERS = ("source", "level", "description", "draws", "outputs")
"""Fields of ``Effect`` that ``joint`` does not read (the level comes as its argument)."""


@functools.cache  # a constant of the class: its fields do not change
def _shared_fields(cls) -> tuple:
    """The fields that effects of ``cls`` stacked together must have equal (module docstring)."""
    return tuple(f.name for f in fields(cls) if f.name not in cls.stacked_fields and f.name not in NOT_NUMBERS)


def stack_key(effect):
    """What effects stacked with ``effect`` must share (module docstring); None when it is evaluated alone."""
    cls = type(effect)
    names = cls.__dict__.get("stacked_fields")  # the class's own: a subclass may read its fields otherwise
    if names is None:
        return None
    key = (cls, tuple(getattr(effect, n) for n in _shared_fields(cls)),
           tuple(len(v) if isinstance(v, tuple) else None for v in (getattr(effect, n) for n in names)))
    try:
        hash(key)
    except TypeError:  # a field holding a mapping: compared by nobody, evaluated alone
        return None
    return key


def stack_groups(effects: list) -> list:
    """The positions in ``effects`` that stack together (same ``stack_key``), in order of first appearance; an
    effect with no key is a group of its own."""
    groups: dict = {}
    for k, effect in enumerate(effects):
        key = stack_key(effect)
        groups.setdefault(("alone", k) if key is None else key, []).append(k)
    return list(groups.values())


def stacked_columns(effects: list) -> dict:
    """{field: array (len(effects),) or (len(effects), n)} of the stacked fields of ``effects`` (one ``stack_key``)."""
    return {name: np.array([getattr(e, name) for e in effects], dtype=float)
            for name in type(effects[0]).stacked_fields}


def stacked(first, columns: dict, ndim: int):
    """``first`` with the fields ``columns`` (rows, case axis first) shaped for levels of ``ndim`` axes (module
    docstring)."""
    axes = type(first).stacked_fields
    shaped = {name: c.reshape(c.shape[:1] + (1,) * (ndim - 1) + (c.shape[1:] if c.ndim > 1 else (1,) * axes[name]))
              for name, c in columns.items()}
    return replace(first, **shaped)


__all__ = ["stack_groups", "stack_key", "stacked", "stacked_columns"]
