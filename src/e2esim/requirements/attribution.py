"""Which error source adds how much to a requirement's checked value, from the propagation's error model."""

from __future__ import annotations

import dataclasses

import numpy as np

from e2esim.requirements.base import error_model_of
from e2esim.retrieval.agb_error import AGBError


def attribution(case, value_of, agb: AGBError, unit: str = "percent") -> tuple[dict, tuple]:
    """How much each error source adds to a requirement's checked value, and why not, if it cannot be said.

    For each source of the error model (``backscatter.error``) the value is recomputed with that source
    removed (``ErrorModel.without``), everything else kept; the random-error budget's terms (speckle and
    noise, temporal, calibration, area projection) and the regression uncertainty by taking their variance
    out of the total (every contribution whose group is not "systematic": the model term of the retrieval's
    exponents, an assumed term). A source's contribution is the checked value minus the value without it, in the
    requirement's unit. The parts need not add up (the sources interact, and quantiles are not additive),
    but the largest is the one whose improvement helps most. ``value_of`` maps an analytic ``AGBError`` to
    the checked value; ``agb`` is the error the requirement checks; ``unit`` ends the keys,
    ``contribution.<source>_<unit>``. Returns (contributions, notes).
    """
    model = error_model_of(case)
    if model.unavailable is not None or agb.error_mean is None:
        return {}, (f"no attribution to error sources: {model.unavailable or 'no analytic AGB error'}",)
    # what the budget and regression add to the systematic variance (m^2/m^2)^2
    extra = np.maximum(np.asarray(agb.error_sd) ** 2 - np.asarray(model.current().variance, dtype=float), 0.0)
    base = value_of(agb)

    def with_systematic(mean, sd):
        return dataclasses.replace(agb, error_mean=_plain(mean), error_sd=_plain(np.sqrt(np.square(sd) + extra)))

    out = {}
    for name in model.sources:
        variant = model.without(name)
        if variant is model:  # the source is not active: nothing to take away
            out[f"contribution.{name}_{unit}"] = 0.0
            continue
        m = variant.current()
        value = base - value_of(with_systematic(m.mean, m.sd))
        inactive = getattr(variant, "inactive", None)  # a block's cases where the source is not active
        out[f"contribution.{name}_{unit}"] = value if inactive is None else np.where(inactive, 0.0, value)
    for c in agb.contributions:
        if c.group != "systematic":  # the budget's terms, regression, a retrieval-model or an assumed term
            var = np.maximum(np.asarray(agb.error_sd) ** 2 - np.asarray(model.value) ** 2
                             * np.maximum(c.relative_variance, 0.0), 0.0)
            without = dataclasses.replace(agb, error_sd=_plain(np.sqrt(var)))
            out[f"contribution.{c.name}_{unit}"] = base - value_of(without)
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


def _plain(x):
    return float(x) if np.ndim(x) == 0 else np.asarray(x, dtype=float)
