"""Land and ocean: the fraction of each cell of a latitude-longitude grid that is land.

The shoreline is that of GSHHG, the Global Self-consistent, Hierarchical, High-resolution Geography database
(Wessel & Smith 1996, J. Geophys. Res. 101(B4), 8741-8743), rasterised at 15 arc-seconds (about 460 m) by the
maintained ``roaring-landmask`` package (G. Hope, MIT licence; PyPI ``roaring-landmask``), which ships the mask
and needs no download. A cell's land fraction is the share of ``n x n`` points spread evenly over it (their
centres, at most ``MAX_SUBSAMPLES`` a side, about 0.25 deg apart) that fall on land: 0 over open ocean, 1 inside
a continent. Inland water bodies inside GSHHG's land polygons count as land.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from e2esim.extras import optional_import

SUBSAMPLE_SPACING_DEG = 0.25
"""Spacing of the points tested in each cell (deg): a 1 deg cell is tested at 4 x 4 points."""

MAX_SUBSAMPLES = 16
"""At most this many points a side per cell (a 20 deg cell: 16 x 16 points)."""


@lru_cache(maxsize=1)
def _mask():
    """The GSHHG raster of roaring-landmask, loaded once per process (about a second)."""
    roaring_landmask = optional_import("roaring_landmask", "maps", "the land mask of a map sweep")

    return roaring_landmask.RoaringMask.new(roaring_landmask.LandmaskProvider.Gshhg)


def is_land(lat_deg, lon_deg) -> np.ndarray:
    """True where the point (lat, lon in deg, any equal shapes; longitude in any 360 deg range) is on land."""
    lat = np.asarray(lat_deg, float)
    lon = np.mod(np.asarray(lon_deg, float) + 180.0, 360.0) - 180.0
    lat, lon = np.broadcast_arrays(lat, lon)
    flat = _mask().contains_many(np.ascontiguousarray(lon.ravel()), np.ascontiguousarray(lat.ravel()))
    return np.asarray(flat, bool).reshape(lat.shape)


def land_fraction(lat_deg, lon_deg, step_deg: float) -> np.ndarray:
    """Land fraction (0-1) of the square cells of side ``step_deg`` centred on ``lat_deg`` x ``lon_deg`` (1-D
    axes, deg): an array (n_lat, n_lon)."""
    lat = np.asarray(lat_deg, float)
    lon = np.asarray(lon_deg, float)
    n = int(min(MAX_SUBSAMPLES, max(1, math.ceil(step_deg / SUBSAMPLE_SPACING_DEG))))
    offsets = ((np.arange(n) + 0.5) / n - 0.5) * step_deg
    sub_lat = np.clip(lat[:, None] + offsets[None, :], -90.0, 90.0).ravel()
    sub_lon = (lon[:, None] + offsets[None, :]).ravel()
    land = is_land(sub_lat[:, None], sub_lon[None, :])  # (n_lat * n, n_lon * n)
    return land.reshape(lat.size, n, lon.size, n).mean(axis=(1, 3))
