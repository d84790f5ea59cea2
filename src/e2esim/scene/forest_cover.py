"""Where forest is: the share of each cell of a latitude-longitude grid that a land-cover product calls forest.

The product is the MODIS land cover of 2019 (MCD12C1 Collection 6, IGBP classification; Friedl &
Sulla-Menashe 2015, NASA LP DAAC, doi:10.5067/MODIS/MCD12C1.006), shipped with e2esim as a grid derived by
``tools/forest_cover_grid.py`` (``data/modis_igbp_2019_025deg.npz``, 280 kB, plain arrays with their
provenance; data/README.md). The source holds the majority IGBP class of every 0.05 deg cell of the globe; the
grid holds, for every 0.25 deg cell, how many of its 25 pixels of 0.05 deg belong to each group of classes:

* ``forests``: IGBP classes 1-5 (evergreen and deciduous needleleaf and broadleaf forests, mixed forests:
  tree cover above 60 %, canopy above 2 m; Sulla-Menashe & Friedl 2018, MCD12 Collection 6 user guide,
  Table 3);
* ``woody_savannas``: class 8 (tree cover 30-60 %, canopy above 2 m);
* ``savannas``: class 9 (tree cover 10-30 %);
* ``water`` (0), ``snow_ice`` (15), ``barren`` (16) and ``unclassified`` (255), which are never forest.

**What counts as forest** (``DEFAULT_FOREST_GROUPS``): forests and woody savannas. Both have a closed or
open tree canopy of at least 30 % and so are forest under the FAO definition (canopy cover above 10 %; FAO
2018, *Global Forest Resources Assessment 2020: Terms and Definitions*, Forest Resources Assessment Working
Paper 188). Woody savannas must be counted for the boreal band: MODIS maps much of the open boreal forest as
woody savanna (of the 0.05 deg pixels of the 1 deg cell at 55 deg N, 100 deg W, northern Manitoba, 91 % are
woody savanna and 4 % forest; at 60 deg N, 100 deg E, central Siberia, 52 % and 48 %). Savannas (10-30 %
tree cover) are left out by default: grass-dominated, their AGB is far below that of the Table I forests
that stand for a band (tropical_338: 338 t/ha); a map sweep can add them (``forest_classes``). Water,
permanent snow and ice and barren land (deserts) are never forest.

A cell's forest fraction is the area-weighted share of its 0.25 deg pixels' forest (pixel counts / 25),
sampled at points no more than 0.25 deg apart: exact for cells whose edges lie on the 0.25 deg grid (every
map sweep with a step that is a multiple of 0.25 deg and ranges on that grid), a nearest-pixel estimate
otherwise. Limits: the majority class of a 0.05 deg pixel stands for the whole pixel (the source has no
per-class percentages), so fractions come in steps of 4 % of a 0.25 deg cell; the classification is that of
2019.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

GRID_FILE = Path(__file__).with_name("data") / "modis_igbp_2019_025deg.npz"

PRODUCTS = ("modis_igbp_2019",)
"""Land-cover products a map sweep can take for where forest is (``sweep.map.forest_cover``)."""

FOREST_GROUPS = ("forests", "woody_savannas", "savannas")
"""Class groups that may count as forest."""

DEFAULT_FOREST_GROUPS = ("forests", "woody_savannas")
"""The groups counted as forest unless a scenario says otherwise (module docstring)."""

NEVER_FOREST = ("water", "snow_ice", "barren", "unclassified")
"""Groups that are never forest: open water, permanent snow and ice, barren land (deserts), unclassified."""


@dataclass(frozen=True)
class LandCoverGrid:
    """Pixel counts of each class group on a global grid of ``cell_deg`` cells (rows from -90 deg northwards,
    columns from -180 deg eastwards), out of ``pixels_per_cell``; ``provenance``: where they come from."""

    counts: dict
    cell_deg: float
    pixels_per_cell: int
    provenance: dict

    def share(self, groups) -> np.ndarray:
        """Share (0-1) of every grid cell in the union of ``groups``, (n_lat, n_lon)."""
        unknown = sorted(set(groups) - set(self.counts))
        if unknown:
            raise ValueError(f"unknown land-cover group(s) {unknown}; known: {', '.join(self.counts)}")
        total = sum(self.counts[g].astype(np.int32) for g in groups)
        return total / float(self.pixels_per_cell)


@lru_cache(maxsize=1)
def land_cover_grid() -> LandCoverGrid:
    """The shipped MODIS 2019 grid, read once per process (plain arrays: ``allow_pickle=False``)."""
    with np.load(GRID_FILE, allow_pickle=False) as data:
        counts = {name[len("count_"):]: data[name] for name in data.files if name.startswith("count_")}
        provenance = {name: str(data[name]) for name in data.files if data[name].dtype.kind == "U"
                      and data[name].ndim == 0}
        cell, pixels = float(data["cell_deg"]), int(data["pixels_per_cell"])
    for values in counts.values():
        values.setflags(write=False)
    return LandCoverGrid(counts, cell, pixels, provenance)


def citation() -> str:
    """The citation of the product behind the grid."""
    return land_cover_grid().provenance["citation"]


def cover_fraction(lat_deg, lon_deg, step_deg: float, groups=DEFAULT_FOREST_GROUPS) -> np.ndarray:
    """Share (0-1) of the area of the square cells of side ``step_deg`` centred on ``lat_deg`` x ``lon_deg``
    (1-D axes, deg; longitude in any 360 deg range) that is in ``groups``: an array (n_lat, n_lon) (module
    docstring)."""
    grid = land_cover_grid()
    share = grid.share(groups)
    lat = np.asarray(lat_deg, float)
    lon = np.asarray(lon_deg, float)
    n = max(1, math.ceil(step_deg / grid.cell_deg - 1e-9))
    offsets = ((np.arange(n) + 0.5) / n - 0.5) * step_deg
    sub_lat = np.clip(lat[:, None] + offsets[None, :], -90.0, 90.0).ravel()
    sub_lon = (lon[:, None] + offsets[None, :]).ravel()
    n_lat, n_lon = share.shape
    i = np.clip(np.floor((sub_lat + 90.0) / grid.cell_deg).astype(int), 0, n_lat - 1)
    j = np.mod(np.floor((sub_lon + 180.0) / grid.cell_deg).astype(int), n_lon)
    weight = np.cos(np.radians(sub_lat)).reshape(lat.size, n)  # the area of a sample's strip of latitude
    weight = np.where(weight.sum(axis=1, keepdims=True) > 0, weight, 1.0)  # a cell on a pole: equal weights
    values = share[np.ix_(i, j)].reshape(lat.size, n, lon.size, n)
    return np.einsum("anbm,an->ab", values, weight) / (n * weight.sum(axis=1))[:, None]


def forest_fraction(lat_deg, lon_deg, step_deg: float, groups=DEFAULT_FOREST_GROUPS) -> np.ndarray:
    """Forest share (0-1) of each cell (``cover_fraction`` of the forest groups; only ``FOREST_GROUPS``)."""
    other = sorted(set(groups) - set(FOREST_GROUPS))
    if other:
        raise ValueError(f"{other} are not forest groups; forest groups: {', '.join(FOREST_GROUPS)}")
    return cover_fraction(lat_deg, lon_deg, step_deg, tuple(groups))
