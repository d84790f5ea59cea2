"""Which error source adds how much to a requirement's checked value, from the propagation's error model."""

from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np

from e2esim.retrieval.agb_error import AGBError

VERDICTS_ONLY: ContextVar = ContextVar("verdicts_only", default=False)
"""True while the caller reads the verdicts' margins alone (``verdicts_only``)."""


@contextmanager
def verdicts_only():
    """Within it, requirements give their verdicts without the contributions and shares of the error sources,
    which never change a verdict and take most of its time: for the inverse solve, which asks the chain for
    margins many times over (``e2esim.flowdown.evaluate``). Only for runs in this thread (a serial run)."""
    token = VERDICTS_ONLY.set(True)
    try:
        yield
    finally:
        VERDICTS_ONLY.reset(token)


def can_attribute(agb: AGBError) -> bool:
    """Whether the sources of ``agb`` can be taken away one by one (an analytic AGB error of an available model)
    and are to be (not within ``verdicts_only``)."""
    return not VERDICTS_ONLY.get() and agb.error_model.unavailable is None and agb.error_mean is not None


def attribution(value_of, agb: AGBError, unit: str = "percent") -> tuple[dict, tuple]:
    """How much each error source adds to a requirement's checked value, and why not, if it cannot be said.

    For each source of the AGB error (``AGBError.sources``: those of its error model, then the random-error
    budget's terms, the regression uncertainty, the model term of the retrieval's exponents, an assumed term) the
    value is recomputed with that source removed, everything else kept (``AGBError.without``). A source's
    contribution is the checked value minus the value without it, in the requirement's unit. The parts need not
    add up (the sources interact, and quantiles are not additive), but the largest is the one whose improvement
    helps most. ``value_of`` maps an analytic ``AGBError`` to the checked value; ``agb`` is the error the
    requirement checks; ``unit`` ends the keys, ``contribution.<source>_<unit>``. Returns (contributions, notes).
    """
    model = agb.error_model
    if VERDICTS_ONLY.get():
        return {}, ()
    if not can_attribute(agb):
        return {}, (f"no attribution to error sources: {model.unavailable or 'no analytic AGB error'}",)
    base = value_of(agb)
    out = {}
    for name in agb.sources():
        variant, inactive = agb.without(name)
        if variant is None:  # the source is not active (in any case of a block): nothing to take away
            out[f"contribution.{name}_{unit}"] = 0.0 if inactive is True else np.zeros(np.shape(inactive))
            continue
        value = base - value_of(variant)
        out[f"contribution.{name}_{unit}"] = value if inactive is None else np.where(inactive, 0.0, value)
    return out, ()


def dominant(details: dict, unit: str = "percent"):
    """The source with the largest contribution in ``details`` ("" if none is attributed); for a block, an
    object array of them."""
    suffix = f"_{unit}"
    parts = {k[len("contribution."):-len(suffix)]: v for k, v in details.items()
             if k.startswith("contribution.") and k.endswith(suffix)}
    if not parts:
        return ""
    names = list(parts)
    values = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in parts.values()))
    if values[0].ndim == 0:
        return max(parts, key=parts.get)
    choice = np.argmax(np.stack(values, -1), axis=-1)  # the first of equal largest, as max() takes
    return np.asarray(names, dtype=object)[choice]

