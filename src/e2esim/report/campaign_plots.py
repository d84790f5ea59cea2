"""Report plot of a calibration campaign (issue 25, item 5): the residual crosstalk, channel imbalance and gain
against mission time with every visit used marked per site, the AGB error of the swept epochs and the worst epoch,
and the schedule search's trade-off between transponder passes per year and the smallest margin."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from e2esim.report.plot_base import PlotSkipped, save_png
from e2esim.units import level_db_from_variance

YEAR_DAYS = 365.25


def _campaign(case):
    record = case.get("calibration")
    for result in getattr(record, "results", ()) or ():
        if getattr(result, "outcome", None) is not None:
            return result.outcome
    return None


def plot_campaign(result, folder: Path, options: dict) -> list:
    found = [(c, _campaign(c)) for c in result.cases]
    found = [(c, o) for c, o in found if o is not None]
    if not found:
        raise PlotSkipped("no case has a calibration campaign (calibration type campaign)")
    out = found[0][1]
    folder = Path(folder)
    s = out.search
    worst = int(np.argmin(out.margin))
    if s.best is None:
        answer = (f"no schedule of up to {int(s.per_year.max())} transponder passes per year and any set of targets "
                  f"of opportunity keeps the limits (best margin {np.max(s.margin_db):.2f} dB)")
    else:
        sites = ", ".join(s.opportunity[s.best]) or "no target of opportunity"
        answer = (f"the cheapest schedule that keeps the limits: {int(s.per_year[s.best])} transponder passes per "
                  f"year after commissioning with {sites} (smallest margin {s.margin_db[s.best]:.2f} dB)")
    return [(_timeline(out, found, folder / "campaign_timeline.png"),
             f"Residual crosstalk, channel imbalance and gain left by the campaign against mission time (Kalman filter "
             f"of the visits and the drift model; the gain SD of a pixel anywhere in the swath, with its parts: gain "
             f"offset, pointing and elevation pattern, dB at the far edge), the flowed-down limits (dashed), every "
             f"visit used (ticks, one row "
             f"per site), the AGB error of the swept epochs and the worst epoch (red line: day "
             f"{out.result.days[worst]:.0f}, margin {out.margin[worst]:.2f} dB)."),
            (_tradeoff(out, folder / "campaign_schedules.png"),
             f"Schedule search: the smallest margin of the residuals against their limits after commissioning, per "
             f"transponder passes per year, one line per set of targets of opportunity. Answer: {answer} (circled).")]


def _timeline(out, found, path) -> str:
    r = out.result
    years = r.days / YEAR_DAYS
    fig, axes = plt.subplots(5, 1, figsize=(8.5, 10.5), sharex=True, constrained_layout=True,
                             gridspec_kw={"height_ratios": [2, 2, 2, 1.2, 2]})
    rows = [("crosstalk", "residual crosstalk (dB)"), ("imbalance", "residual imbalance (dB)"),
            ("gain", "residual gain SD (dB)")]
    for ax, (p, label) in zip(axes, rows):
        v = r.variance[p]
        y = np.sqrt(v) if p == "gain" else level_db_from_variance(v, out.convention)
        lim = np.sqrt(out.limits[p]) if p == "gain" else level_db_from_variance(out.limits[p], out.convention)
        ax.plot(years, y, lw=1, label="swath" if p == "gain" else None)
        ax.axhline(lim, color="k", ls="--", lw=0.8)
        ax.set_ylabel(label, fontsize=8)
    for part in ("gain_offset", "pointing", "pattern"):  # the gain's parts (campaign.antenna), when estimated
        if part in r.variance:
            axes[2].plot(years, np.sqrt(r.variance[part]), lw=0.7, ls=":", label=part.replace("_", " "))
    if "pointing" in r.variance:
        axes[2].legend(fontsize=6, ncol=4)
    acq = r.acquisitions
    for i in range(len(out.site_names)):
        days = acq.day[r.used & (acq.site == i)]
        axes[3].plot(days / YEAR_DAYS, np.full(days.size, i), "|", ms=8)
    axes[3].set_yticks(range(len(out.site_names)), out.site_names, fontsize=7)
    axes[3].set_ylabel("visits", fontsize=8)
    x, value = [], []
    for case, _ in found:
        values = next(res.values for res in case.get("calibration").results if getattr(res, "outcome", None))
        x.append(values["epoch_day"] / YEAR_DAYS)
        value.append(case.verdicts[0].value if case.verdicts else np.nan)
    order = np.argsort(x)
    axes[4].plot(np.array(x)[order], np.array(value)[order], "o-", ms=3)
    if found[0][0].verdicts:
        axes[4].set_ylabel(f"{found[0][0].verdicts[0].name}\n({found[0][0].verdicts[0].unit})", fontsize=7)
    worst = r.days[int(np.argmin(out.margin))] / YEAR_DAYS
    for ax in axes:
        ax.axvline(worst, color="tab:red", lw=0.8)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
    axes[-1].set_xlabel("mission time (years)", fontsize=8)
    fig.suptitle(f"Calibration campaign: worst epoch day {worst * YEAR_DAYS:.0f} "
                 f"(margin {np.min(out.margin):.2f} dB)", fontsize=10)
    return save_png(fig, path)


def _tradeoff(out, path) -> str:
    s = out.search
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    for sites in dict.fromkeys(s.opportunity):
        pick = np.array([o == sites for o in s.opportunity])
        ax.plot(s.per_year[pick], s.margin_db[pick], "o-", ms=3, lw=1, label=", ".join(sites) or "transponder only")
    if s.best is not None:
        ax.plot(s.per_year[s.best], s.margin_db[s.best], "o", ms=12, mfc="none", color="tab:red")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xlabel("transponder passes per year after commissioning", fontsize=8)
    ax.set_ylabel("smallest margin (dB)", fontsize=8)
    ax.legend(fontsize=6)
    ax.grid(alpha=0.3)
    return save_png(fig, path)
