"""The report's table of how the joint multi-channel AGB error depends on the exponents it assumes: per case and
channel, the analytic RMSE (every source) with that channel's exponent at the ends of its stated range, read from
the ``agb.exponent_sensitivity.*`` scalars (``e2esim.retrieval.exponent_sensitivity``). Nothing is computed here."""

from __future__ import annotations

from e2esim.report.blocks import Table, fmt

PREFIX = "agb.exponent_sensitivity."
CHANNELS = ("hh", "hv", "vv")


def exponent_sensitivity_table(result) -> Table | None:
    """Rows (case, channel, exponent low / used / high, RMSE low / headline / high) of the cases that report it."""
    rows = []
    for c in result.cases:
        s = c.scalars
        for channel in CHANNELS:
            key = f"{PREFIX}{channel}."
            if key + "low_rmse_percent" not in s:
                continue
            used = s.get("agb.analytic.rmse_percent")
            rows.append((f"{c.index}: {c.label}", channel.upper(),
                         f"{fmt(s[key + 'low_exponent'], 3)} / {fmt(s[key + 'high_exponent'], 3)}",
                         fmt(s[key + "low_rmse_percent"], 3), fmt(used, 3), fmt(s[key + "high_rmse_percent"], 3)))
    if not rows:
        return None
    return Table(("case", "channel", "exponent α, low / high end of its range", "RMSE at the low end (%)",
                  "RMSE as computed (%)", "RMSE at the high end (%)"), tuple(rows))


SENSITIVITY_NOTE = (
    "How the AGB RMSE of the joint HH+HV+VV estimate (every source, analytic) depends on the exponents α_pq it "
    "assumes: each row moves one channel's exponent to an end of its stated range (α ± its SD; "
    "docs/theory/retrieval.md, Section 7), the others kept. The exponents set the estimate's weights, so they decide "
    "how much of each channel's speckle reaches the AGB. This is an uncertainty of the answer, not an error of the "
    "estimate (that is the `model` term of the error budget). The ground-cancelled HH exponent is not published: it "
    "is the volume's (that of ground-cancelled HV) and its range reaches the biome's HH exponent at the high end "
    "(docs/theory/ground-cancellation.md, Section 3.2).")
