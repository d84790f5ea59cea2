"""Published values e2esim is checked against: one table for ``e2esim reproduce`` and the tests.

The table is the concatenation of one list per seed paper (``e2esim.verification.<source>_values``). Each
entry names the function that recomputes the value from the paper's equations and inputs
(``module:function``), the tolerance and why it is that, and, where a correct computation cannot
reproduce the printed number, the explanation (also in docs/errata.md). Never bend a computation to
hit a published value.

A check can fail only where its tolerance is smaller than the effect it measures: the distance between the
published value and ``null_value``, what a computation without the effect would give (zero, unless the record
says otherwise). Where it is not, or where the published value is a bound that the null value also meets, a
value within tolerance is ``low_power`` (consistent, but not discriminating), never ``reproduced``.
"""

from __future__ import annotations

from e2esim.verification import (
    ahmed2014_values,
    men2021_sec6_values,
    men2021_values,
    quegan2018_calibration_values,
    quegan2018_values,
)
from e2esim.verification.records import KINDS, PIN_TOLERANCE_NOTE, Computed, Published

__all__ = ["KINDS", "PIN_TOLERANCE_NOTE", "Computed", "Published", "all_published"]


def all_published() -> list:
    """Every published check, all sources."""
    return [
        *men2021_values.PUBLISHED,
        *men2021_sec6_values.PUBLISHED,
        *quegan2018_values.PUBLISHED,
        *quegan2018_calibration_values.PUBLISHED,
        *ahmed2014_values.PUBLISHED,
    ]
