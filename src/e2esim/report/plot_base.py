"""What every report plot shares: saving a figure atomically, and saying why a requested plot is not drawn.

A plot type is a function ``(result, folder, options) -> [(file name, caption)]`` registered in
``e2esim.report.plots.PLOTTERS``. One that cannot draw anything for a run raises ``PlotSkipped`` with the
reason; the report and standard error show it (``make_plots``).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from e2esim.io.atomic import atomic_path

DPI = 110


class PlotSkipped(Exception):
    """A requested plot that cannot be drawn for this run; the message says why."""


def save(fig, folder: Path, name: str, tight: bool = True) -> str:
    """Write ``fig`` as ``folder/name.png`` (atomically); return the file name."""
    path = Path(folder) / f"{name}.png"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=DPI, format="png", bbox_inches="tight" if tight else None)
    plt.close(fig)
    return path.name
