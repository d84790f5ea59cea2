"""An outlier never hides the other cases: values far beyond the rest are cut at the edge of the axis and written
out, so that the axis spans the others.

biomass_multichannel's VV estimate without Faraday correction (boreal 200 t/ha) has an AGB error of 1.8e7 %: its
power law's exponent is 0.0612 (docs/theory/co-pol-error.md), so the AGB estimate is sigma_vv to the power 16.3
and the 99.865 % quantile of a VV error of about a factor 2 becomes a factor of 1.8e5 in AGB. A linear axis that
reaches it shows the other 15 cases as zero. Here a value is an outlier when its magnitude is more than
``OUTLIER_FACTOR`` times that of every value that is not one (and of the reference drawn with them, such as the
limit); the axis then spans the others and each outlier is drawn to its edge with its value written beside it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.report.blocks import fmt

OUTLIER_FACTOR = 10.0
"""A value is an outlier beyond this many times the largest magnitude of the values that are not."""
AXIS_ROOM = 1.15
"""The cut axis reaches this many times the largest magnitude kept."""
LARGE_PERCENT = 1000.0
"""A relative error (%) beyond this is written with what it means: the estimate is many times the true value."""


@dataclass(frozen=True)
class AxisCut:
    """The axis limit ``edge`` (a magnitude: the axis spans [-edge, edge] where the values reach) beyond which
    values are drawn cut."""

    edge: float

    def clip(self, values) -> np.ndarray:
        return np.clip(np.asarray(values, float), -self.edge, self.edge)

    def cut(self, values) -> np.ndarray:
        """Which values lie beyond the edge."""
        return np.abs(np.asarray(values, float)) > self.edge

    def limits(self, values, reference=()) -> tuple:
        """(low, high) of an axis holding ``values`` and ``reference`` up to the edge, with room for the marks."""
        kept = np.concatenate([self.clip(values).ravel(), np.ravel(np.asarray(reference, float)), [0.0]])
        kept = kept[np.isfinite(kept)]
        low, high = float(kept.min()), float(kept.max())
        pad = 0.08 * (high - low or self.edge)
        return low - pad, high + pad

    def note(self, values, unit: str) -> str:
        """The caption's sentence on the cut values."""
        n = int(self.cut(values).sum())
        return (f" {n} value{'s' if n > 1 else ''} far beyond the others (more than {OUTLIER_FACTOR:g} times) "
                f"{'are' if n > 1 else 'is'} cut at the edge of the axis ({self.edge:.3g} {unit} from zero) and "
                "written out there (▶).")


def axis_cut(values, reference=()) -> AxisCut | None:
    """The cut that keeps outliers (module docstring) from hiding the other values, or None when there is none.

    values : what the axis shows (NaN and infinities are ignored); reference : values drawn with them that the
    axis must keep (a limit, zero)."""
    magnitudes = np.sort(np.abs(np.asarray(values, float)[np.isfinite(values)]).ravel())[::-1]
    floor = max([abs(float(r)) for r in np.ravel(reference) if np.isfinite(r)] + [0.0])
    for k in range(1, (len(magnitudes) - 1) // 2 + 1):  # outliers are fewer than half of the values
        rest = max(float(magnitudes[k]) if k < len(magnitudes) else 0.0, floor)
        if rest > 0 and magnitudes[k - 1] > OUTLIER_FACTOR * rest:
            return AxisCut(AXIS_ROOM * rest)
    return None


def mark_cut(ax, positions, values, cut: AxisCut | None, unit: str, horizontal: bool = True) -> None:
    """Write each cut value at the edge it is drawn to (``horizontal``: values along x, positions along y)."""
    if cut is None:
        return
    for pos, value in zip(positions, values):
        if not cut.cut([value])[0]:
            continue
        edge = float(np.sign(value)) * cut.edge
        arrow = ("▶" if value > 0 else "◀") if horizontal else ("▲" if value > 0 else "▼")
        text = f"{arrow} {value:.3g} {unit}" if value > 0 or not horizontal else f"{value:.3g} {unit} {arrow}"
        if horizontal:
            ax.text(edge, pos, text, ha="right" if value > 0 else "left", va="center", fontsize=7,
                    bbox={"facecolor": "white", "edgecolor": "0.5", "pad": 1.5, "alpha": 0.9})
        else:
            ax.text(pos, edge, text, ha="center", va="top" if value > 0 else "bottom", fontsize=7,
                    bbox={"facecolor": "white", "edgecolor": "0.5", "pad": 1.5, "alpha": 0.9})


def error_meaning(error: float, unit: str) -> str:
    """What a relative error beyond ``LARGE_PERCENT`` means, for a headline that prints it: ``an error of
    1.79e+07 %, about 1.8e+05 times the true value``; "" for any other value."""
    if unit != "%" or not np.isfinite(error) or abs(error) < LARGE_PERCENT:
        return ""
    return f"an error of {fmt(float(error), 3)} %, about {abs(error) / 100:.2g} times the true value"


__all__ = ["AXIS_ROOM", "LARGE_PERCENT", "OUTLIER_FACTOR", "AxisCut", "axis_cut", "error_meaning", "mark_cut"]
