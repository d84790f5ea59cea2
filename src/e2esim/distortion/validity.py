"""Where the analytic error models hold, in the level convention of the scenario (docs/theory/validity.md).

Two limits on the crosstalk and channel-imbalance variances V_delta, V_eps of a case's residual system errors:

* ``HARD_LIMIT_VARIANCE``: beyond it the errors are not small, and no analytic model is used at all;
* each model's ``ValidityRange``: the largest level at which its mean and variance agree with the exact Monte
  Carlo within 5 % for every representative case (measured by benchmarks/validity_ranges.py). Past it the
  propagation modules say so: a note on the case and a warning in mode ``analytic``, the Monte Carlo alone in
  mode ``both``; margins and trade-off curves stop there.

Levels are variances inside; every message gives them in the scenario's convention and as 3-sigma amplitude
labels, the convention of the scenarios and of Men et al. (2021) (docs/conventions.md).
"""

from __future__ import annotations

from dataclasses import dataclass

from e2esim.units import THREE_SIGMA_AMPLITUDE, VARIANCE, level_db_from_variance, variance_from_level_db

HARD_LIMIT_VARIANCE = 0.1
"""Largest crosstalk or channel-imbalance variance V = E|delta|^2 for which an analytic model is evaluated at all:
-10 dB as a variance, -3.47 dB as a 3-sigma amplitude label (10 log10(4.5 V)). Beyond it the error terms are not
small (the amplitude exceeds 0.67 with probability 1.1 %) and only the Monte Carlo applies."""


def describe_level(variance: float, convention: str = THREE_SIGMA_AMPLITUDE) -> str:
    """A level as the scenario states it and as the other conventions read it, e.g. "-8.0 dB (3-sigma amplitude
    label; variance 3.5e-03, -24.5 dB as a variance)"."""
    three_sigma = float(level_db_from_variance(variance, THREE_SIGMA_AMPLITUDE))
    as_variance = float(level_db_from_variance(variance, VARIANCE))
    if convention == VARIANCE:
        return (f"{as_variance:.1f} dB (variance convention: V = {variance:.2g}; {three_sigma:.1f} dB as a 3-sigma "
                "label)")
    return f"{three_sigma:.1f} dB (3-sigma amplitude label; variance V = {variance:.2g}, {as_variance:.1f} dB)"


@dataclass(frozen=True)
class ValidityRange:
    """The measured validity range of an analytic model.

    model : what it describes. edge_db : the largest crosstalk or channel-imbalance level (3-sigma amplitude
    label, dB) up to which its mean and variance agree with the exact Monte Carlo within 5 % in every
    representative case and direction (docs/theory/validity.md). limited_by : what departs first beyond it.
    """

    model: str
    edge_db: float
    limited_by: str

    @property
    def edge_variance(self) -> float:
        return float(variance_from_level_db(self.edge_db, THREE_SIGMA_AMPLITUDE))

    @property
    def search_limit(self) -> float:
        """The largest variance margins and trade-off curves may search: the edge, or the hard limit."""
        return min(self.edge_variance, HARD_LIMIT_VARIANCE)


def hard_limit_problem(system, convention: str = THREE_SIGMA_AMPLITUDE) -> str | None:
    """Why no analytic model describes ``system`` (a level above ``HARD_LIMIT_VARIANCE``), or None."""
    for name, level in (("crosstalk", system.crosstalk_level), ("channel imbalance", system.imbalance_level)):
        if level > HARD_LIMIT_VARIANCE:
            return (f"the {name} level {describe_level(level, convention)} is above the hard limit of the analytic "
                    f"models, {describe_level(HARD_LIMIT_VARIANCE, convention)}: the errors are not small")
    return None


def beyond_range(system, validity: ValidityRange, convention: str = THREE_SIGMA_AMPLITUDE) -> str | None:
    """Why ``system`` is outside the measured validity range of a model (within the hard limit), or None."""
    for name, level in (("crosstalk", system.crosstalk_level), ("channel imbalance", system.imbalance_level)):
        if level > validity.edge_variance:
            return (f"the {name} level {describe_level(level, convention)} is beyond the edge of the validity "
                    f"range of the {validity.model}, {describe_level(validity.edge_variance, convention)} (beyond "
                    f"it its {validity.limited_by} departs from the exact Monte Carlo by more than 5 %; "
                    "docs/theory/validity.md)")
    return None


def scenario_convention(case) -> str:
    """The dB convention in which the case's scenario states its crosstalk and channel-imbalance levels (the
    instrument's; 3-sigma amplitude labels when the chain has no instrument stage)."""
    inst = case.get("instrument")
    return inst.level_convention if inst is not None else THREE_SIGMA_AMPLITUDE


HARD_LIMIT_DB = float(level_db_from_variance(HARD_LIMIT_VARIANCE, THREE_SIGMA_AMPLITUDE))
"""``HARD_LIMIT_VARIANCE`` as a 3-sigma amplitude label: -3.47 dB."""

VALIDITY = {
    "hv_complete": ValidityRange("HV model of Men et al. (2021), complete form", -12.0, "variance"),
    "hv_paper": ValidityRange("HV model of Men et al. (2021), eqs. (11)-(12) as published", -20.0, "variance"),
    "polarimetric": ValidityRange("HH, HV and VV model (co-pol theory, exact covariance)", HARD_LIMIT_DB,
                                  "nothing: mean and covariance are exact"),
    "stack_hv": ValidityRange("multi-pass HV model", -10.0, "variance"),
    "stack_joint": ValidityRange("multi-pass HH, HV and VV model", -16.0, "HH variance"),
}
"""The validity range of each analytic model, measured by benchmarks/validity_ranges.py (docs/theory/validity.md):
the lowest level over the Table I forests (Men et al. 2021, Table II rotations, SD 5 deg; corrected and not) or
the multi-pass sites and the directions equal, specification (imbalance 4 dB below), crosstalk alone and channel
imbalance alone, up to which no departure of mean or variance from the exact Monte Carlo exceeds 5 % by more
than one standard error (``verification.validity.EDGE_Z``); for the published form
except under crosstalk alone, where eq. (12) misses terms of the order it keeps at every level (errata E3). The
co-polarised model is exact up to the hard limit. The Gaussian quantiles of eq. (19) hold in a narrower range, and
not at all where crosstalk dominates: validity.md."""
