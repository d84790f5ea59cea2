"""What every report plot shares: saving a figure atomically, and saying why a requested plot is not drawn.

A plot type is a function ``(result, folder, options) -> [(file name, caption)]`` registered in the entry-point
group ``e2esim.plots`` (``e2esim.registry.plot``). One that cannot draw anything for a run raises ``PlotSkipped``
with the reason; the report and standard error show it (``make_plots``).

Drawing speed: matplotlib lays out text (tick labels above all) on every pass over a figure. Report figures
are made at the resolution they are saved at (``figure_settings``), so the layout pass (``tight_layout``) and
the drawing share one renderer and its cache of text sizes; and a figure is cropped to its artists
(``bbox_inches="tight"``, a further layout pass) only when it has artists that ``tight_layout`` does not
place (see ``save_png``): a figure with a legend below its panels leaves room for it in its layout instead. Text is
most of a figure's drawing time, so it is drawn unhinted (``TEXT_HINTING``) and panels that say the same thing say it
once (a shared legend, shared axis and case labels).
"""

from __future__ import annotations

import contextlib
import functools
import gc
import math
from pathlib import Path

import matplotlib
import matplotlib.image

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.layout_engine import PlaceHolderLayoutEngine

from e2esim.atomic import atomic_path

DPI = 110
PNG = {"compress_level": 3}
"""Pillow's PNG settings: zlib level 3 writes the report's figures in 70 % of the time of the default level 6, 1 %
larger (the same pixels)."""


class PlotSkipped(Exception):
    """A requested plot that cannot be drawn for this run; the message says why."""


TEXT_HINTING = "no_hinting"
"""FreeType's hinting of the report's text. Its default (auto-hinting every glyph it renders) is about a third of
the drawing time of a figure with many tick labels (biomass_ground_cancelled's verdicts: 1.35 s CPU, 0.9 s
unhinted); at the report's resolution unhinted glyphs differ from hinted ones by a fraction of a pixel."""


def figure_settings():
    """Context for drawing report figures: new figures are made at the resolution they are saved at, their text
    unhinted (``TEXT_HINTING``)."""
    return matplotlib.rc_context({"figure.dpi": DPI, "text.hinting": TEXT_HINTING})


@contextlib.contextmanager
def older_objects_left_to_rest():
    """Keep the cyclic garbage collector off the objects that exist on entry (the run's results, modules) until
    the body ends (``gc.freeze``; ``gc.unfreeze`` gives them back to it). Drawing makes and drops many objects with
    reference cycles (every figure), so the collector runs often, and each full pass went over every object the
    process holds: 4.8 s of the 35 s CPU of drawing every shipped scenario's quick-run plots in one process. The
    body's own objects are collected as usual; nothing else changes. Where objects are frozen already (by the
    caller) nothing is done: unfreezing would hand back theirs too."""
    if gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def colors(n: int) -> list:
    """``n`` colours of the report's plots (matplotlib's tab10, repeated after ten)."""
    cmap = plt.get_cmap("tab10")
    return [cmap(i % 10) for i in range(max(n, 1))]


def panel_grid(n: int, max_columns: int, panel_size: tuple) -> tuple:
    """A figure of ``n`` panels of ``panel_size`` (inches), at most ``max_columns`` a row: (figure, its ``n`` axes
    in reading order); the spare axes of the last row are switched off."""
    ncol = min(max_columns, n)
    nrow = math.ceil(n / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(panel_size[0] * ncol, panel_size[1] * nrow), squeeze=False)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    return fig, axes.ravel()[:n]


def tight_layout_in(fig, rect: tuple) -> None:
    """``fig.tight_layout(rect=rect)`` (the panels and their labels fitted into ``rect``, figure fractions: room
    left for a legend below them), each panel measured once instead of twice.

    Matplotlib fits panels into a ``rect`` in two passes (``matplotlib._tight_layout.get_tight_layout_figure``),
    each measuring every panel with its tick labels (most of a layout's time) at the same, unmoved positions; the
    second pass here reads the first's measurements, so the layout is the same at half the cost."""
    measured: dict = {}

    def measured_once(ax, *args, **kwargs):
        key = (id(ax), args, tuple(sorted(kwargs.items())))
        if key not in measured:
            measured[key] = type(ax).get_tightbbox(ax, *args, **kwargs)
        return measured[key]

    for ax in fig.axes:
        ax.get_tightbbox = functools.partial(measured_once, ax)
    try:
        fig.tight_layout(rect=rect)
    finally:
        for ax in fig.axes:
            del ax.get_tightbbox


def save(fig, folder: Path, name: str, tight: bool | None = None) -> str:
    """Write ``fig`` as ``folder/name.png`` (atomically); return the file name (``save_png``)."""
    return save_png(fig, Path(folder) / f"{name}.png", tight)


def save_drawn(fig, folder: Path, name: str) -> str:
    """Write the canvas of ``fig`` as it was last drawn, with no new drawing pass (a figure redrawn in parts,
    ``e2esim.maps.plots.MonthPanels``), as ``folder/name.png`` (atomically); return the file name."""
    path = Path(folder) / f"{name}.png"
    with atomic_path(path) as tmp:
        matplotlib.image.imsave(tmp, fig.canvas.buffer_rgba(), format="png", origin="upper", dpi=fig.dpi,
                                pil_kwargs=dict(PNG))
    return path.name


def save_png(fig, path: Path, tight: bool | None = None) -> str:
    """Write ``fig`` as the PNG ``path`` (atomically), close it and return the file name.

    tight : crop to the drawn artists (``bbox_inches="tight"``: a second drawing of the whole figure); None: only
    when the figure has a legend or text of its own, which ``tight_layout`` does not place (a figure legend below
    the axes), or a suptitle and no ``tight_layout`` (which places it): the axes of a figure laid out by
    ``tight_layout`` already fit. A figure whose layout leaves room for its legend (``tight_layout(rect=...)``)
    is saved with ``tight=False``.
    """
    laid_out = isinstance(fig.get_layout_engine(), PlaceHolderLayoutEngine)  # tight_layout has run
    if tight is None:
        tight = bool(fig.legends or fig.texts or (getattr(fig, "_suptitle", None) is not None and not laid_out))
    if not tight and laid_out:
        fig.set_layout_engine(None)  # tight_layout has run: no layout left for savefig's extra pass
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=DPI, format="png", bbox_inches="tight" if tight else None, pil_kwargs=dict(PNG))
    plt.close(fig)
    return path.name
