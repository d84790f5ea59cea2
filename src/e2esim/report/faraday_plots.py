"""Plots of Faraday-rotation climatologies: global maps, latitude profiles and per-case distributions.

``plot_global_maps`` and ``plot_latitude_profiles`` draw a ``FaradayMap`` (used by the report and by
docs/theory/ionosphere.md); ``plot_faraday_distributions`` and ``plot_faraday_climatology`` are report
plot types (``output.plots``).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

from e2esim.report.sweep_layout import facet_axes, label_facet, legend, series_offsets, style, sweep_layout

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from e2esim.faraday.distribution import EmpiricalFaraday
from e2esim.report.plot_base import PlotSkipped, panel_grid, save_png


def plot_global_maps(fr_map, path, quantity: str = "mean_abs_deg", title: str | None = None) -> str:
    """Maps of ``quantity`` ("mean_abs_deg", "sd_deg" or "mean_deg") of a ``FaradayMap`` for every pass
    (rows) and solar level (columns), pooled over months, swath positions and day-to-day variability."""
    data = fr_map.statistics[quantity]
    n_pass, n_sol = data.shape[:2]
    fig, axes = plt.subplots(n_pass, n_sol, figsize=(5.2 * n_sol, 3.1 * n_pass), squeeze=False,
                             constrained_layout=True)
    finite = data[np.isfinite(data)]
    signed = quantity == "mean_deg"
    vmax = float(np.nanpercentile(np.abs(finite), 99)) if finite.size else 1.0
    cmap, vmin = ("RdBu_r", -vmax) if signed else ("viridis", 0.0)
    lat, lon = fr_map.lat_deg, fr_map.lon_deg
    lon_edges = np.r_[lon - np.diff(lon)[0] / 2, lon[-1] + np.diff(lon)[0] / 2]
    lat_edges = np.r_[lat - np.diff(lat)[0] / 2, lat[-1] + np.diff(lat)[0] / 2]
    for i in range(n_pass):
        for j in range(n_sol):
            ax = axes[i, j]
            mesh = ax.pcolormesh(lon_edges, lat_edges, data[i, j], cmap=cmap, vmin=vmin, vmax=vmax, shading="flat")
            ax.set_title(f"{fr_map.pass_labels[i]} ({fr_map.passes[i]}), F10.7 = {fr_map.f107[j]:g} sfu", fontsize=9)
            ax.set_xlim(-180, 180)
            ax.set_ylim(-90, 90)
            ax.set_xticks(range(-180, 181, 60))
            ax.set_yticks(range(-90, 91, 30))
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
    label = {"mean_abs_deg": "mean |Ω| (deg)", "sd_deg": "SD of Ω (deg)", "mean_deg": "mean Ω (deg)"}[quantity]
    fig.colorbar(mesh, ax=axes.ravel().tolist(), shrink=0.85, label=label)
    for ax in axes[-1]:
        ax.set_xlabel("longitude (deg)", fontsize=8)
    for ax in axes[:, 0]:
        ax.set_ylabel("latitude (deg)", fontsize=8)
    fig.suptitle(title or f"One-way Faraday rotation at {fr_map.frequency_hz / 1e6:g} MHz: {label}", fontsize=10)
    return save_png(fig, path)


def plot_latitude_profiles(fr_map, path) -> str:
    """Zonal-mean latitude profiles of mean |Omega| and its SD of a ``FaradayMap``, one line per pass and
    solar level."""
    prof = fr_map.profiles
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    styles = ["-", "--", ":", "-."]
    colors = plt.get_cmap("tab10")
    for i, lab in enumerate(fr_map.pass_labels):
        for j, f in enumerate(fr_map.f107):
            kw = dict(color=colors(i), ls=styles[j % 4], label=f"{lab}, F10.7 {f:g}")
            a1.plot(prof["mean_abs_deg"][i, j], fr_map.lat_deg, **kw)
            a2.plot(prof["sd_deg"][i, j], fr_map.lat_deg, **kw)
    a1.set_xlabel("zonal mean of mean |Ω| (deg)")
    a2.set_xlabel("zonal mean of SD of Ω (deg)")
    a1.set_ylabel("latitude (deg)")
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
        ax.set_ylim(-90, 90)
    a1.legend(fontsize=7)
    fig.suptitle(f"Faraday rotation at {fr_map.frequency_hz / 1e6:g} MHz by latitude (months, swath positions and "
                 f"{fr_map.variability:.0%} TEC variability pooled)", fontsize=10)
    fig.tight_layout()
    return save_png(fig, path)


def plot_faraday_distributions(result, folder: Path, options: dict) -> list:
    """Report plot: the one-way Faraday rotation before any correction (``faraday.geophysical``) of each case;
    histograms for up to ``histogram_cases`` cases, for more a summary against the swept variables."""
    cases = [c for c in result.cases if c.get("faraday.geophysical") is not None]
    if not cases:
        raise PlotSkipped("no case has a Faraday-rotation distribution (no ionosphere stage)")
    if len(cases) > options.get("histogram_cases", 12):
        return _faraday_against_sweep(result, folder, options, cases)
    fig, axes = panel_grid(len(cases), 4, (3.6, 2.8))
    for ax, c in zip(axes, cases):
        fr = c.get("faraday.geophysical")
        if isinstance(fr, EmpiricalFaraday):
            ax.hist(np.degrees(fr.samples), bins=40, weights=fr.probabilities, color="0.6", histtype="stepfilled")
        else:  # a parametric distribution: draw it from its quantiles
            ax.hist(np.degrees(fr.sample(np.random.default_rng(0), 20_000)), bins=40, density=True, color="0.6",
                    histtype="stepfilled")
        ax.axvline(np.degrees(fr.mean_rad), color="r", lw=1.2, label="mean")
        lo, hi = _interval_deg(fr)
        ax.axvspan(lo, hi, color="r", alpha=0.1, label="95.45 %")
        ax.set_title(c.label, fontsize=7)
        ax.set_xlabel("Ω (deg)", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0].legend(fontsize=6)
    fig.tight_layout()
    return [(save_png(fig, Path(folder) / "faraday_distributions.png"),
             "Distribution of the one-way Faraday rotation of each case before any correction (all acquisitions, "
             "swath positions and day-to-day TEC variability): mean (red line) and the 2.275-97.725 % interval "
             "(shaded).")]


def _interval_deg(fr) -> tuple:
    if isinstance(fr, EmpiricalFaraday):
        p = fr.percentiles_deg((2.275, 97.725))
        return p[2.275], p[97.725]
    mean, sd = np.degrees(fr.mean_rad), np.degrees(fr.sd_rad)
    return mean - 2 * sd, mean + 2 * sd


def _faraday_against_sweep(result, folder, options, cases) -> list:
    """Mean and 2.275-97.725 % interval of Omega against the sweep (every case, any number of them)."""
    layout = sweep_layout(result, options, cases)
    if layout.x_key is None:
        raise PlotSkipped(f"{len(cases)} cases (more than histogram_cases = {options.get('histogram_cases', 12)}) "
                          "and no numeric sweep variable to draw their Faraday rotation against; set output.plot_x")
    fig, axes = facet_axes(layout, height=3.6)
    for facet, (ax,) in zip(layout.facets, axes):
        for i, (series, dx) in enumerate(zip(facet.series, series_offsets(layout, facet))):
            frs = [c.get("faraday.geophysical") for c in series.cases]
            mean = np.array([np.degrees(fr.mean_rad) for fr in frs])
            lo, hi = np.array([_interval_deg(fr) for fr in frs]).T
            st = style(i)
            ax.errorbar(layout.x_values(series.cases) + dx, mean, yerr=[mean - lo, hi - mean], fmt="-",
                        marker=st["marker"], ms=3.5, capsize=2, lw=1, color=st["color"], label=series.label)
        ax.axhline(0, color="k", lw=0.6)
        label_facet(ax, layout, facet, "one-way Faraday rotation Ω (deg)")
    legend(axes[0][0], len(layout.facets[0].series))
    fig.tight_layout()
    return [(save_png(fig, Path(folder) / "faraday_distributions.png"),
             f"One-way Faraday rotation before any correction against {layout.x_label}, every case: mean (marker) "
             "and the 2.275-97.725 % interval (bar) over all acquisitions, swath positions and day-to-day TEC "
             "variability.")]


def plot_faraday_climatology(result, folder: Path, options: dict) -> list:
    """Report plot: global maps and latitude profiles of the FR climatology, the ``faraday.global_map`` product of
    the ionosphere stage (``global_map_step_deg``)."""
    case = next((c for c in result.cases if c.get("faraday.global_map") is not None), None)
    if case is None:
        raise PlotSkipped("no case has a global Faraday-rotation map: set global_map_step_deg in the ionosphere "
                          "section (iri_climatology)")
    fr_map = case.get("faraday.global_map")
    folder = Path(folder)
    step = float(np.diff(fr_map.lat_deg)[0]) if fr_map.lat_deg.size > 1 else float("nan")
    return [
        (plot_global_maps(fr_map, folder / "faraday_map_mean_abs.png", "mean_abs_deg"),
         f"Global map of mean |Ω| per pass and solar level ({step:g} deg grid; 12 monthly IRI medians, three swath "
         "positions and day-to-day variability pooled; thin shell)."),
        (plot_global_maps(fr_map, folder / "faraday_map_sd.png", "sd_deg"),
         "Global map of the SD of Ω per pass and solar level (same pooling)."),
        (plot_latitude_profiles(fr_map, folder / "faraday_latitude_profiles.png"),
         "Zonal means of mean |Ω| and of its SD against latitude, per pass and solar level."),
    ]
