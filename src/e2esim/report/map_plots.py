"""Report plot ``site_map``: a sweep over site latitude and/or longitude drawn as a map, one panel per
requirement, each site coloured by its worst margin over the other swept variables (a grid of sites
becomes a filled map)."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from e2esim.report.plot_base import PlotSkipped, save

SITE_KEYS = ("orbit.site.lat_deg", "orbit.site.lon_deg")


def site_position(case) -> tuple | None:
    """(lon, lat) in degrees of the case's site: from its acquisition geometry, else its sweep inputs."""
    geom = case.get("geometry")
    if geom is not None:
        return float(np.degrees(geom.site.lon)), float(np.degrees(geom.site.lat))
    lat, lon = (case.inputs.get(k) for k in SITE_KEYS)
    return (float(lon), float(lat)) if lat is not None and lon is not None else None


def site_margins(cases, positions, index: dict, j: int) -> np.ndarray:
    """Per site, the worst margin of requirement j over its cases that the requirement applies to; NaN at a site
    where it applies to none (not applicable cases have no margin)."""
    worst = np.full(len(index), np.inf)
    for c, p in zip(cases, positions):
        v = c.verdicts[j]
        if v.status != "not_applicable":
            worst[index[p]] = min(worst[index[p]], v.margin)
    return np.where(np.isfinite(worst), worst, np.nan)


def plot_site_map(result, folder: Path, options: dict) -> list:
    if not any(k in result.scenario.sweep_keys for k in SITE_KEYS):
        raise PlotSkipped("the sweep varies neither orbit.site.lat_deg nor orbit.site.lon_deg")
    names = result.requirement_names
    if not names:
        raise PlotSkipped("the scenario states no requirements")
    positions = [site_position(c) for c in result.cases]
    if any(p is None for p in positions):
        raise PlotSkipped("the site's latitude and longitude are not known for every case (no orbit stage)")
    sites = sorted(set(positions))
    index = {p: i for i, p in enumerate(sites)}
    lon = np.array([p[0] for p in sites])
    lat = np.array([p[1] for p in sites])
    fig, axes = plt.subplots(1, len(names), figsize=(6.2 * len(names), 4.4), squeeze=False)
    for j, (ax, name) in enumerate(zip(axes[0], names)):
        worst = site_margins(result.cases, positions, index, j)
        finite = worst[np.isfinite(worst)]
        vmax = float(np.max(np.abs(finite))) if finite.size else 1.0
        shown = np.isfinite(worst)
        points = ax.scatter(lon[shown], lat[shown], c=worst[shown], cmap="RdYlGn", vmin=-vmax, vmax=vmax, s=90,
                            edgecolors="k", linewidths=0.5)
        if not shown.all():  # sites where the requirement applies to no case: no margin to colour
            ax.scatter(lon[~shown], lat[~shown], marker="s", s=60, facecolors="none", edgecolors="0.4",
                       linewidths=0.8, label="not applicable (no margin)")
            ax.legend(fontsize=7, loc="lower left")
        fig.colorbar(points, ax=ax, shrink=0.85, label=f"worst margin ({result.cases[0].verdicts[j].unit})")
        pad = 15.0
        ax.set_xlim(max(-180, lon.min() - pad), min(180, lon.max() + pad))
        ax.set_ylim(max(-90, lat.min() - pad), min(90, lat.max() + pad))
        ax.set_xlabel("longitude (deg)")
        ax.set_ylabel("latitude (deg)")
        ax.axhline(0, color="0.5", lw=0.6)
        ax.set_title(name, fontsize=9)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    others = [k for k in result.scenario.sweep_keys if k not in SITE_KEYS]
    return [(save(fig, folder, "site_map"),
             "Worst requirement margin at each site of the sweep (green passes, red fails)"
             + (f", the minimum over {len(result.cases) // len(sites)} cases per site" if others else "")
             + "; cases the requirement does not apply to have no margin and are left out (an open grey square: a "
             "site where it applies to none).")]
