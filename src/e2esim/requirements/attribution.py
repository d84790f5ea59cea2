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
    out of the total. A source's contribution is the checked value minus the value without it, in the
    requirement's unit. The parts need not add up (the sources interact, and quantiles are not additive),
    but the largest is the one whose improvement helps most. ``value_of`` maps an analytic ``AGBError`` to
    the checked value; ``agb`` is the error the requirement checks; ``unit`` ends the keys,
    ``contribution.<source>_<unit>``. Returns (contributions, notes).
    """
    model = error_model_of(case)
    if model.unavailable is not None or agb.error_mean is None:
        return {}, (f"no attribution to error sources: {model.unavailable or 'no analytic AGB error'}",)
    # what the budget and regression add to the systematic variance (m^2/m^2)^2
    extra = max(agb.error_sd**2 - float(model.current().variance), 0.0)
    base = value_of(agb)

    def with_systematic(mean, sd):
        return dataclasses.replace(agb, error_mean=float(mean), error_sd=float(np.sqrt(sd**2 + extra)))

    out = {}
    for name in model.sources:
        variant = model.without(name)
        if variant is model:  # the source is not active: nothing to take away
            out[f"contribution.{name}_{unit}"] = 0.0
        else:
            m = variant.current()
            out[f"contribution.{name}_{unit}"] = base - value_of(with_systematic(m.mean, m.sd))
    for c in agb.contributions:
        if c.group in ("random", "regression"):
            var = max(agb.error_sd**2 - model.value**2 * max(c.relative_variance, 0.0), 0.0)
            out[f"contribution.{c.name}_{unit}"] = base - value_of(
                dataclasses.replace(agb, error_sd=float(np.sqrt(var)))
            )
    return out, ()


def dominant(details: dict, unit: str = "percent") -> str:
    """The source with the largest contribution in ``details`` ("" if none is attributed)."""
    suffix = f"_{unit}"
    parts = {k[len("contribution."):-len(suffix)]: v for k, v in details.items()
             if k.startswith("contribution.") and k.endswith(suffix)}
    return max(parts, key=parts.get) if parts else ""
