"""The records of a published value and of its recomputation (``e2esim.verification.published`` lists them)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Published:
    """One published value.

    id : stable identifier, ``<source>.<where>.<what>``. quantity : what it is, with unit.
    published : the printed value. tolerance : allowed |computed - published| (same unit), unless the
    compute function returns its own (statistical) tolerance. citation : paper, table/figure/equation.
    compute : ``module:function`` returning ``(computed, tolerance or None, note)`` or a ``Computed``.
    known_discrepancy : explanation when a correct computation differs (status ``discrepancy``).
    expected_computed, computed_tolerance : for a known discrepancy, the value e2esim computes and how far
        it may move (``PIN_TOLERANCE_NOTE``); a computed value outside that band (or NaN) is ``failed``, so a
        regression cannot hide behind the discrepancy.
    null_value : what a computation without the measured effect would give (default 0); the effect is
        ``|published - null_value|``. kind : ``"value"`` (|computed - published| <= tolerance) or
        ``"upper_bound"`` (the published value is a bound: computed <= published + tolerance).
    """

    id: str
    quantity: str
    published: float
    tolerance: float
    citation: str
    compute: str
    known_discrepancy: str = ""
    expected_computed: float | None = None
    computed_tolerance: float | None = None
    null_value: float = 0.0
    kind: str = "value"


KINDS = ("value", "upper_bound")


@dataclass(frozen=True)
class Computed:
    """What a compute function returns when a 3-tuple ``(value, tolerance or None, note)`` is not enough.

    sampling_se : standard error of ``value`` (a Monte Carlo estimate), 0 for a deterministic value; it gives
        the check's power. failure : a reason the check fails whatever the comparison with the published value
        (e.g. the paper's claim that the computation tests does not hold); empty when none.
    """

    value: float
    tolerance: float | None = None
    note: str = ""
    sampling_se: float = 0.0
    failure: str = ""


PIN_TOLERANCE_NOTE = (
    "the pinned values are deterministic closed-form results; their tolerance, 1e-6 of the value, covers "
    "floating-point differences between platforms and library versions and nothing else"
)
