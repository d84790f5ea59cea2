"""The first screen's word on how sure the verdicts are: per requirement, the cases whose analytic and Monte Carlo
values disagree beyond their uncertainty (and which one the verdict used, and why), and the cases whose margin
lies inside the uncertainty of their value. Read from the verdicts' details (``e2esim.requirements.uncertainty``),
so that a run read back from results.h5 says the same; printed by ``e2esim run`` under each verdict line and at
the top of the report."""

from __future__ import annotations

import numpy as np

from e2esim.report.blocks import fmt
from e2esim.requirements.uncertainty import DISAGREEMENT_CAUSES, Z_DISAGREE, basis_reason
from e2esim.retrieval.sampling_error import Z95


def uncertainty_flags(result, j: int) -> list:
    """Sentences on requirement ``j``: analytic/Monte Carlo disagreement, margins inside the uncertainty."""
    table = result.table
    details = table.requirements[j].details
    out = []
    if "basis_disagreement" in details:
        codes = np.nan_to_num(table.detail(j, "basis_disagreement"))
        flagged = np.flatnonzero(codes > 0)
        if flagged.size:
            out.append(_disagreement(result, j, flagged, codes))
    if "margin_within_uncertainty" in details:
        inside = np.flatnonzero(np.nan_to_num(table.detail(j, "margin_within_uncertainty")) > 0)
        if inside.size:
            out.append(_inside(result, j, inside))
    return out


def _disagreement(result, j, flagged, codes) -> str:
    table = result.table
    r = table.requirements[j]
    a, m = table.detail(j, "analytic.value"), table.detail(j, "montecarlo.value")
    se = table.detail(j, "montecarlo.value_standard_error")
    k = int(flagged[np.argmax(np.abs(a[flagged] - m[flagged]) / np.maximum(se[flagged], 1e-300))])
    unit, basis = r.unit[k], r.basis[k]
    bases = sorted({r.basis[int(i)] for i in flagged})
    used = basis if len(bases) == 1 else " or ".join(bases)
    return (f"analytic and Monte Carlo values disagree by more than {Z_DISAGREE:g} standard errors in {flagged.size} "
            f"of {table.n} cases (most in case {k}, {result.labels[k]}: analytic {fmt(float(a[k]), 4)} {unit}, Monte "
            f"Carlo {fmt(float(m[k]), 4)} +- {fmt(float(se[k]), 2)} {unit}); the verdicts use the {used} value "
            f"({basis_reason(basis)}). {DISAGREEMENT_CAUSES[float(codes[k])]}")


def _inside(result, j, inside) -> str:
    table = result.table
    r = table.requirements[j]
    se = table.detail(j, "value_standard_error")
    margin = r.margin
    k = int(inside[np.argmin(np.abs(margin[inside]))])
    return (f"the margin lies inside the value's 95 % uncertainty in {inside.size} of {table.n} cases (closest: case "
            f"{k}, {result.labels[k]}: margin {fmt(float(margin[k]), 3)} +- {fmt(Z95 * float(se[k]), 2)} "
            f"{r.unit[k]}): another seed or more samples could flip those verdicts")


def with_standard_error(value, se, digits: int = 3) -> str:
    """``value +- se`` (the standard error), or the value alone without a positive standard error."""
    text = fmt(value, digits)
    if se is None or not np.isfinite(se) or se <= 0:
        return text
    return f"{text} ± {fmt(float(se), 2)}"
