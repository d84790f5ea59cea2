"""Report plots of map sweeps (``e2esim.maps.grid``): ``global_maps``, filled latitude-longitude maps of
the Faraday rotation, the sigma_hv error, the AGB error and the verdict (the cell's state: passes, fails, not
applicable, not acquired) for every month (panels), pass and solar level (one figure each), and where each source
of the chain's error terms changes a verdict; ``map_fraction``, the share of the forest area that meets each
requirement, by month (each cell weighted by its forest area, ``forest_area_weight`` of the map dataset).

Both draw the map dataset of the run (``e2esim.maps.netcdf.map_dataset_of``, the content of results.nc): the
report computes nothing physical (an area weight is bookkeeping; the sigma_hv error is shown relative to sigma_hv).
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.cm import ScalarMappable
from matplotlib.colors import ListedColormap, Normalize
from matplotlib.ticker import MultipleLocator

from e2esim.maps.grid import is_map_sweep
from e2esim.maps.netcdf import map_dataset_of
from e2esim.report.plot_base import PlotSkipped, save, save_drawn

MONTH_NAMES = ("Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec")
PASS_FAIL = ListedColormap(["#d7301f", "#1a9850"])
CELL_STATES = ListedColormap(["#d7301f", "#1a9850", "0.45", "#6a51a3"])
"""Colours of a cell's state (``requirement<j>_state`` of results.nc): fails, passes, not applicable, not acquired."""
STATE_NAMES = ("fails", "passes", "not applicable", "not acquired")
CHANGES = ListedColormap(["#2b8cbe", "#ffffbf", "#e66101"])
"""Colours of ``requirement<j>_changed_by_<source>``: the source rescues the verdict, leaves it, breaks it."""
LAND_GREY = "0.86"


def _dataset(result):
    """The map dataset of the run; ``PlotSkipped`` unless it is a map sweep."""
    if not is_map_sweep(result.scenario):
        raise PlotSkipped("the sweep is not a map sweep (sweep: {map: ...})")
    return map_dataset_of(result)


def _quantities(ds, result) -> list:
    """(file stem, title, values (solar, pass, month, lat, lon), colour map, vmin, vmax, limit) to draw."""
    out = []
    if "faraday_omega_mean_abs_deg" in ds:
        v = ds["faraday_omega_mean_abs_deg"].values
        out.append(("map_faraday", "one-way Faraday rotation before correction: mean |Ω| (deg)", v, "viridis",
                    *_range(v), None))
    mean = next((k for k in ("analytic_mean", "montecarlo_mean") if k in ds), None)
    if mean is not None and "scene_sigma_hv" in ds:
        v = 100.0 * ds[mean].values / ds["scene_sigma_hv"].values
        low, high = _range(v)
        cmap = "RdBu_r" if low < 0 < high else "magma"
        if low < 0 < high:
            low, high = -max(-low, high), max(-low, high)
        out.append(("map_sigma_hv_error", f"bias of σ_hv, systematic ({mean.split('_')[0]}), % of σ_hv", v, cmap,
                    low, high, None))
    for j, name in enumerate(result.requirement_names):
        verdict = result.cases[0].verdicts[j]
        if f"requirement{j}_value" in ds:
            v = ds[f"requirement{j}_value"].values
            limit = float(verdict.limit)
            low, high = _range(v, limit)
            shown = bool(low <= limit <= high)
            out.append((f"map_agb_error{j if j else ''}", f"AGB error checked by '{name}' ({verdict.unit}; limit "
                        f"{limit:g}{', the black line' if shown else ''})", v, "YlOrRd", low, high,
                        limit if shown else None))
        if f"requirement{j}_state" in ds:
            out.append((f"map_verdict{j if j else ''}", f"verdict of '{name}': green passes, red fails, dark grey "
                        "not applicable, purple not acquired", _states(ds[f"requirement{j}_state"].values),
                        CELL_STATES, -0.5, 3.5, None))
        elif f"requirement{j}_passed" in ds:
            out.append((f"map_verdict{j if j else ''}", f"verdict of '{name}': green passes, red fails",
                        ds[f"requirement{j}_passed"].values, PASS_FAIL, -0.5, 1.5, None))
        for key in [k for k in ds.data_vars if str(k).startswith(f"requirement{j}_changed_by_")]:
            source = str(key)[len(f"requirement{j}_changed_by_"):]
            v = ds[key].values.astype(float)
            if not np.any(np.abs(v[v >= -1]) > 0):
                continue  # the source changes no verdict anywhere: results.nc says so, no figure
            out.append((f"map_change{j if j else ''}_{source}", f"where the error source {source} changes the verdict "
                        f"of '{name}': orange it fails only with it, blue it passes only with it",
                        np.where(v >= -1, v, np.nan), CHANGES, -1.5, 1.5, None))
    return out


def _states(values) -> np.ndarray:
    """Cell states as floats, NaN where there is no case (the fill value -1 in memory, NaN once read back)."""
    v = np.asarray(values, float)
    return np.where(v >= 0, v, np.nan)


def _range(values, limit=None) -> tuple:
    """Colour range of ``values``: their finite extremes, stretched to show ``limit`` when it is near them."""
    finite = np.asarray(values)[np.isfinite(values)]
    if not finite.size:
        return 0.0, 1.0
    low, high = float(finite.min()), float(finite.max())
    if limit is not None and np.isfinite(limit) and low - 0.25 * abs(low) <= limit <= high + 0.25 * abs(high):
        low, high = min(low, limit), max(high, limit)
    if high - low < 1e-12 * max(abs(high), 1.0):
        low, high = low - 0.5, high + 0.5
    return low, high


def plot_map_sweep(result, folder: Path, options: dict) -> list:
    ds = _dataset(result)
    quantities = _quantities(ds, result)
    if not quantities:
        raise PlotSkipped("the cases have no Faraday rotation, sigma_hv error or verdict to map")
    panels = MonthPanels(ds)
    out = []
    try:
        for stem, title, values, cmap, vmin, vmax, limit in quantities:
            panels.scale(cmap, vmin, vmax, limit)  # one colour bar for the quantity's figures
            for s, solar in enumerate(ds["solar"].values):
                for p, pass_name in enumerate(ds["pass"].values):
                    panels.show(values[s, p], f"{title}\n{pass_name} pass, solar {solar}")
                    name = save_drawn(panels.fig, folder, f"{stem}_{pass_name}_{solar}")
                    out.append((name, f"Map of the {title}, {pass_name} pass, solar {solar}, one panel per month; "
                                "light grey: land left out of the sweep (no forest, or no forest class), white: ocean"
                                f"{_not_acquired_note(ds)}. "
                                f"Cells of {panels.step:g} deg."))
    finally:
        plt.close(panels.fig)
    return out


def _not_acquired_note(ds) -> str:
    """What the map leaves out as not acquired, for a caption ("" without an acquisition mask)."""
    if "not_acquired_mask" not in ds.attrs:
        return ""
    return (f"; not acquired: {ds.attrs['not_acquired_mask']} ({int(ds.attrs['not_acquired_cells'])} forest cells, "
            f"{float(ds.attrs['not_acquired_forest_area_km2']) / 1e6:.2f} million km² of forest, "
            f"{100 * float(ds.attrs['not_acquired_forest_area_fraction']):.1f} % of the map's), purple on the verdict "
            "maps and left out of every share")


class MonthPanels:
    """A figure of one map panel per month of a map dataset, made and drawn once, then shown again for every
    quantity, pass and solar level: the panels (axes, ticks, grid lines, the land underneath) are drawn once into
    a background, and each figure redraws only its values (images over that background, so the grid lines show
    over land and ocean, not over the swept cells), the panels' frames and its title; a quantity's colour bar is
    drawn once into that background for all its figures (``scale``)."""

    def __init__(self, ds):
        lat, lon = ds["lat"].values, ds["lon"].values
        self.step = step = float(ds.attrs.get("grid_step_deg", lat[1] - lat[0] if lat.size > 1 else 1.0))
        lat_edges = np.r_[lat - step / 2, lat[-1] + step / 2]
        lon_edges = np.r_[lon - step / 2, lon[-1] + step / 2]
        land = ds["land_area_fraction"].values >= 0.5
        swept = ds["cell_area_weight"].values > 0
        rows = np.nonzero(np.any(land | swept, axis=1))[0]
        ylim = (lat_edges[rows[0]], lat_edges[rows[-1] + 1]) if rows.size else (lat_edges[0], lat_edges[-1])
        months = [int(m) for m in ds["month"].values]
        ncol = min(4, len(months))
        nrow = math.ceil(len(months) / ncol)
        panel_w = 3.6
        panel_h = panel_w * (ylim[1] - ylim[0]) / max(lon_edges[-1] - lon_edges[0], 1e-9)
        self.size = size = (panel_w * ncol + 1.4, (panel_h + 0.4) * nrow + 1.0)
        self.fig = plt.figure(figsize=size)
        grid = self.fig.add_gridspec(nrow, ncol, left=0.9 / size[0], right=1 - 1.1 / size[0], bottom=0.45 / size[1],
                                     top=1 - 0.75 / size[1], wspace=0.08, hspace=0.4 / panel_h)
        # cells of a regular grid: images, which draw far faster than meshes of 65 000 cells
        cells = {"extent": (lon_edges[0], lon_edges[-1], lat_edges[0], lat_edges[-1]), "origin": "lower",
                 "interpolation": "nearest"}
        self.images = []
        for k, month in enumerate(months):
            ax = self.fig.add_subplot(grid[k // ncol, k % ncol])
            ax.imshow(np.where(land, 1.0, np.nan), cmap=ListedColormap([LAND_GREY]), **cells)
            self.images.append(ax.imshow(np.full(land.shape, np.nan), animated=True, **cells))  # not in the background
            _frame(ax, lon_edges, ylim, first_column=k % ncol == 0, last_row=k // ncol == nrow - 1)
            ax.set_title(MONTH_NAMES[month - 1], fontsize=8, pad=2)
        self.bar = self.scaled = None
        self.title = self.fig.text(0.5, 1 - 0.08 / size[1], "", fontsize=9, ha="center", va="top", animated=True)
        self.fig.canvas.draw()
        self.background = self.fig.canvas.copy_from_bbox(self.fig.bbox)

    def scale(self, cmap, vmin, vmax, limit) -> None:
        """Colour the panels by ``cmap`` from ``vmin`` to ``vmax``, with its colour bar (a black line at ``limit``
        unless None), drawn once over the panels' background for every figure of the quantity (the bar lies
        beside the panels: the figures' pixels are those of drawing it with each)."""
        for image in self.images:
            image.set_cmap(cmap)
            image.set_clim(vmin, vmax)
        if self.bar is not None:
            self.bar.remove()
        size = self.size
        cax = self.fig.add_axes((1 - 0.95 / size[0], 0.45 / size[1], 0.14 / size[0], 1 - 1.2 / size[1]))
        # a mappable of its own: a colour bar of a panel's image would reset that panel's position when removed
        self.bar = bar = self.fig.colorbar(ScalarMappable(Normalize(vmin, vmax), cmap), cax=cax)
        if cmap is PASS_FAIL:
            bar.set_ticks([0, 1], labels=["fails", "passes"])
        elif cmap is CELL_STATES:
            bar.set_ticks([0, 1, 2, 3], labels=list(STATE_NAMES))
        elif cmap is CHANGES:
            bar.set_ticks([-1, 0, 1], labels=["passes only with it", "unchanged", "fails only with it"])
        if limit is not None and np.isfinite(limit):
            bar.ax.axhline(limit, color="k", lw=1.5)
        bar.ax.tick_params(labelsize=7)
        canvas = self.fig.canvas
        canvas.restore_region(self.background)
        self.fig.draw_artist(cax)
        self.scaled = canvas.copy_from_bbox(self.fig.bbox)

    def show(self, values, title: str) -> None:
        """Show ``values`` (month, lat, lon) under ``title``, coloured as ``scale`` last set."""
        for image, month_values in zip(self.images, values):
            image.set_data(month_values)
        self.title.set_text(title)
        canvas = self.fig.canvas
        canvas.restore_region(self.scaled)
        for image in self.images:
            image.axes.draw_artist(image)
            for spine in image.axes.spines.values():
                image.axes.draw_artist(spine)
        self.fig.draw_artist(self.title)


def _frame(ax, lon_edges, ylim, first_column: bool, last_row: bool) -> None:
    """Limits, equal scales, and degree ticks labelled on the outer panels only."""
    ax.set_xlim(lon_edges[0], lon_edges[-1])
    ax.set_ylim(*ylim)
    ax.set_aspect("equal", adjustable="box")
    ax.xaxis.set_major_locator(MultipleLocator(60 if lon_edges[-1] - lon_edges[0] > 120 else 20))
    ax.yaxis.set_major_locator(MultipleLocator(30 if ylim[1] - ylim[0] > 60 else 10))
    ax.tick_params(labelsize=6, labelleft=first_column, labelbottom=last_row, length=2)
    ax.grid(alpha=0.3, lw=0.4)


def plot_map_fraction(result, folder: Path, options: dict) -> list:
    ds = _dataset(result)
    names = result.requirement_names
    keys = [(j, f"requirement{j}_area_fraction") for j in range(len(names))]
    keys = [(j, k) for j, k in keys if k in ds]
    if not keys:
        raise PlotSkipped("the scenario states no requirements")
    months = ds["month"].values
    fig, axes = plt.subplots(len(keys), 1, figsize=(7.5, 3.6 * len(keys)), squeeze=False)
    styles = ["-", "--", ":", "-."]
    for ax, (j, key) in zip(axes[:, 0], keys):
        frac = ds[key].values
        for s, solar in enumerate(ds["solar"].values):
            for p, pass_name in enumerate(ds["pass"].values):
                ax.plot(months, 100.0 * frac[s, p], styles[s % 4], marker="o", color=plt.get_cmap("tab10")(p),
                        label=f"{pass_name}, solar {solar}")
        ax.set_ylim(-3, 103)
        ax.set_xticks(range(1, 13), MONTH_NAMES, fontsize=8)
        ax.set_xlim(0.5, 12.5)
        ax.set_ylabel("forest area meeting it (%)")
        ax.set_title(names[j], fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return [(save(fig, folder, "map_fraction"),
             "Share of the forest area of the map that meets each requirement, by month: the forest areas (cell "
             "area, cos latitude, times forest fraction) of the passing cells over those of every swept cell, for "
             f"each pass and solar level{_not_acquired_note(ds)}.")]
