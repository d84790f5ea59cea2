"""``e2esim reproduce``: run the published-value checks and report them."""

from __future__ import annotations

import importlib
import math
from dataclasses import asdict, dataclass
from statistics import NormalDist

from e2esim.errors import UserError
from e2esim.verification.published import PIN_TOLERANCE_NOTE, Computed, Published, all_published

STATUSES = ("reproduced", "low_power", "discrepancy", "failed")


@dataclass(frozen=True)
class CheckRecord:
    """One line of ``e2esim reproduce --json``.

    effect : |published - null_value|, what the record measures. power : probability that the check fails
    for a computation that gives the null value (sampling included); a ``reproduced`` record has
    tolerance < effect.
    """

    id: str
    quantity: str
    published: float
    computed: float
    tolerance: float
    status: str
    citation: str
    note: str
    expected_computed: float | None = None
    computed_tolerance: float | None = None
    null_value: float = 0.0
    effect: float = float("nan")
    power: float = float("nan")

    def as_dict(self) -> dict:
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in asdict(self).items()}


def check(entry: Published) -> CheckRecord:
    """Recompute one published value and classify it."""
    module, _, func = entry.compute.partition(":")
    try:
        result = getattr(importlib.import_module(module), func)(entry)
    except Exception as exc:  # a crash is a failed check, reported, not a traceback
        return CheckRecord(entry.id, entry.quantity, entry.published, float("nan"), entry.tolerance, "failed",
                           entry.citation, f"computation raised {type(exc).__name__}: {exc}",
                           null_value=entry.null_value, effect=_effect(entry))
    return classify(entry, result if isinstance(result, Computed) else Computed(*result))


def classify(entry: Published, result: Computed) -> CheckRecord:
    """Status of one computed value against its published record.

    Within tolerance (or under the bound) the record is ``reproduced`` only where the value a computation
    without the effect would give (``entry.null_value``) lies outside the tolerance, i.e. tolerance < effect;
    otherwise it is ``low_power``: consistent, but the check cannot tell the published value from the null.
    """
    computed = float(result.value)
    tol = float(entry.tolerance if result.tolerance is None else result.tolerance)
    note, effect = result.note, _effect(entry)
    power = _power_against_null(entry, tol, result.sampling_se)
    accepted = _accepts(entry, computed, tol)
    if result.failure:
        status, note = "failed", f"{note}. FAILED: {result.failure}"
    elif accepted and _accepts(entry, entry.null_value, tol):
        status = "low_power"
        note = f"{note}. {_low_power_note(entry, tol, effect, power)}"
    elif accepted:
        status = "reproduced"
    elif entry.known_discrepancy:
        status, pin = _pinned_status(entry, computed)
        note = f"{note}. {entry.known_discrepancy} {pin}"
    else:
        status = "failed"
    return CheckRecord(entry.id, entry.quantity, entry.published, computed, tol, status, entry.citation, note,
                       entry.expected_computed, entry.computed_tolerance, entry.null_value, effect, power)


def _effect(entry: Published) -> float:
    """What the record measures: the distance of the published value from the null value."""
    return abs(entry.published - entry.null_value)


def _accepts(entry: Published, value: float, tol: float) -> bool:
    if entry.kind == "upper_bound":
        return value <= entry.published + tol
    return abs(value - entry.published) <= tol


def _power_against_null(entry: Published, tol: float, se: float) -> float:
    """Probability that the check fails for a computation whose true value is the null value, given the
    sampling SE of the computed value (a step, 0 or 1, for a deterministic one)."""
    if not (math.isfinite(tol) and math.isfinite(se)):
        return float("nan")
    if se <= 0:
        return 0.0 if _accepts(entry, entry.null_value, tol) else 1.0
    phi = NormalDist().cdf
    if entry.kind == "upper_bound":
        return 1.0 - phi((entry.published + tol - entry.null_value) / se)
    d = entry.null_value - entry.published
    return phi((d - tol) / se) + 1.0 - phi((d + tol) / se)


def _low_power_note(entry: Published, tol: float, effect: float, power: float) -> str:
    if entry.kind == "upper_bound":
        why = (f"the published value is an upper bound, which a computation giving {entry.null_value:g} meets as "
               f"well; this check can fail (a computed value above the bound) but cannot confirm the value")
    else:
        why = (f"the tolerance {tol:.3g} is not smaller than the effect {effect:.3g} (|published - "
               f"{entry.null_value:g}|), so a computation giving {entry.null_value:g} would pass too")
    return f"LOW POWER, not counted as reproduced: {why}; power against {entry.null_value:g}: {power:.2f}"


def _pinned_status(entry: Published, computed: float) -> tuple[str, str]:
    """A known discrepancy stays a ``discrepancy`` only while e2esim computes the pinned value; anything else
    (a regression, NaN, a missing pin) is ``failed``."""
    expected, tol = entry.expected_computed, entry.computed_tolerance
    if expected is None or tol is None:
        return "failed", "No computed value is pinned for this discrepancy, so it cannot be checked."
    if abs(computed - expected) <= tol:
        return "discrepancy", f"Pinned: e2esim computes {expected:.10g} (within {tol:.3g})."
    return "failed", (f"REGRESSION: e2esim now computes {computed:.10g}, not the pinned {expected:.10g} "
                      f"(within {tol:.3g}).")


def select(sources=()) -> list:
    published = all_published()
    if not sources:
        return published
    chosen = [p for p in published if any(p.id == s or p.id.startswith(s.rstrip(".") + ".") for s in sources)]
    if not chosen:
        known = sorted({p.id.split(".")[0] for p in published})
        raise UserError(f"no published checks match {', '.join(sources)}; sources: {', '.join(known)}")
    return chosen


def run_checks(sources=()) -> list:
    return [check(p) for p in select(sources)]


STATUS_MEANINGS = {
    "reproduced": "within tolerance, and the tolerance is smaller than the effect the record measures, so a "
                  "computation without the effect would fail",
    "low_power": "consistent, within tolerance or under a published bound, but not discriminating: the tolerance is "
                 "not smaller than the effect, or the null value meets the bound too, so the check cannot tell the "
                 "published value from the null; its power against the null is stated; not counted as reproduced",
    "discrepancy": "a correct computation cannot reproduce the printed value; explained in the note and in errata.md",
    "failed": "unexpected: outside tolerance, a pinned value that moved, or a computation that raised",
}


def status_counts(records) -> str:
    counts = {s: sum(r.status == s for r in records) for s in STATUSES}
    return ", ".join(f"{n} {s}" for s, n in counts.items())


def render_report(records) -> str:
    lines = [
        "# Verification against published results",
        "",
        "<!-- Generated by `e2esim reproduce --report docs/verification.md`. -->",
        "",
        "Status: " + "; ".join(f"`{s}` ({m})" for s, m in STATUS_MEANINGS.items()) + ". The effect is "
        "|published - null|, where the null is what a computation without the effect would give (zero unless the "
        "note says otherwise); the power is the probability that the check fails for a computation giving the "
        "null, with the sampling error of the computed value. A discrepancy also pins "
        f"the value e2esim computes (`expected_computed`, `computed_tolerance` in `--json`); {PIN_TOLERANCE_NOTE}, "
        "so a regression, or NaN, turns it into `failed`.",
        "",
        f"{len(records)} checks: {status_counts(records)}.",
        "",
        "| id | published | computed | tolerance | status | effect | power | citation | note |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in records:
        lines.append(f"| `{r.id}` | {r.published:g} | {r.computed:.5g} | {r.tolerance:.3g} | {r.status} | "
                     f"{r.effect:.3g} | {r.power:.2f} | {_cell(r.citation)} | {_cell(r.note)} |")
    return "\n".join(lines) + "\n"


def _cell(text: str) -> str:
    """Text for a Markdown table cell: a bare '|' (as in |x|) would end the cell."""
    return text.replace("|", "\\|")
