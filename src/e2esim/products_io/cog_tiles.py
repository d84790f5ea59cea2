"""The uncertainty product's Cloud-Optimised GeoTIFF, written while the bands come: the full-resolution image and
its overviews are each written as a tiled GeoTIFF (ZSTD level 1, 512 x 512 tiles, pixel-interleaved, compressed on
GDAL's threads as each row of tiles is complete), and laid out as a COG at the end by copying their compressed tiles
(``e2esim.products_io.cog_layout``). The COG driver (GDAL ``COG``, ``CreateCopy``) did the same work serially after
the run, compressing every tile again.

The overviews are the COG driver's, pixel for pixel: sizes halved (rounded down) until both are at most the tile
size, each resampled by nearest neighbour from the one before it, the pixel ``int(0.5 + i * n_before / n_after)``
of each axis (GDAL's ``GDALResampleChunk_Near``; checked against the COG driver by
tests/test_uncertainty_product.py). GDAL's block cache is capped (``CACHE_BYTES``) while the files are written: a
row of tiles is all it needs to hold."""

from __future__ import annotations

import os
import warnings
from contextlib import ExitStack

import numpy as np

from e2esim.products_io.cog_layout import read_tiled, write_cog

TILE = 512
COMPRESSION = "ZSTD"
"""The COG's compression, at level 1: lossless, about half the CPU time of DEFLATE level 1 for a file of about the
same size (docs/real-data.md, Speed). Readers need libtiff with ZSTD (GDAL 2.3 or later, as rasterio's wheels)."""
CACHE_BYTES = 256 * 2**20
"""GDAL's block cache while the COG is written: more than a row of tiles of a 5,000-column grid of 18 float32
layers (180 MB), so that a tile is compressed once, whole."""


def overview_sizes(height: int, width: int) -> list:
    """(rows, columns) of each overview, as GDAL's COG driver chooses them: halved, rounded down, while either
    side of the level before is larger than a tile (a side halved to 0 is 1 pixel)."""
    sizes = []
    while height > TILE or width > TILE:
        height, width = height // 2, width // 2
        sizes.append((max(height, 1), max(width, 1)))
    return sizes


def nearest(n_before: int, n_after: int) -> np.ndarray:
    """Indices of the pixels a nearest-neighbour overview of ``n_after`` pixels takes from ``n_before``
    (GDAL ``GDALResampleChunk_Near``: ``int(0.5 + i * ratio)``, in double precision)."""
    return (0.5 + np.arange(n_after) * (n_before / n_after)).astype(np.int64)


class _Level:
    """One image of the COG (full resolution or an overview): its tiled GeoTIFF, the full-resolution rows and
    columns it takes, and its row of tiles being filled."""

    def __init__(self, dataset, rows: np.ndarray, columns: np.ndarray | None):
        self.dataset, self.rows, self.columns = dataset, rows, columns
        self.buffer = np.empty((dataset.count, min(TILE, rows.size), dataset.width), dtype=np.float32)
        self.done = self.filled = 0  # rows written; rows of the buffer filled

    def add(self, first: int, values: np.ndarray) -> None:
        """Take this level's rows from full-resolution rows ``first``... (``values``: layers x rows x columns)."""
        lo, hi = np.searchsorted(self.rows, [first, first + values.shape[1]])
        while lo < hi:
            take = min(hi - lo, self.buffer.shape[1] - self.filled)
            if self.columns is None:  # the full-resolution image: every row and column
                part = values[:, lo - first:lo - first + take]
            else:
                part = values[:, self.rows[lo:lo + take] - first][:, :, self.columns]
            self.buffer[:, self.filled:self.filled + take] = part
            self.filled += take
            lo += take
            if self.filled == self.buffer.shape[1] or self.done + self.filled == self.rows.size:
                self._flush()

    def _flush(self) -> None:
        from rasterio.windows import Window  # lazy: start-up time

        window = Window(0, self.done, self.dataset.width, self.filled)
        self.dataset.write(self.buffer[:, :self.filled], window=window)
        self.done += self.filled
        self.filled = 0


class CogWriter:
    """``add(first_row, values)`` with the layers' rows in order; ``finish(target)`` writes the COG; ``close()``
    (also on failure) closes and removes the temporary files (``{stem}.level{k}.tif``)."""

    def __init__(self, stem, shape, count: int, profile: dict, descriptions, tags: dict):
        import rasterio  # lazy: start-up time

        self.paths = []
        self.levels: list = []
        self._stack = ExitStack()
        height, width = shape
        options = {"driver": "GTiff", "dtype": "float32", "count": count, "nodata": np.nan, "tiled": True,
                   "blockxsize": TILE, "blockysize": TILE, "interleave": "pixel", "compress": COMPRESSION,
                   "zstd_level": 1, "num_threads": "ALL_CPUS", "BIGTIFF": "IF_SAFER"}
        try:
            self._stack.enter_context(rasterio.Env(GDAL_CACHEMAX=CACHE_BYTES))
            self._stack.enter_context(warnings.catch_warnings())
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)  # overviews; radar grids
            rows, columns = np.arange(height), None
            for k, (h, w) in enumerate([(height, width), *overview_sizes(height, width)]):
                path = f"{stem}.level{k}.tif"
                self.paths.append(path)
                extra = profile if k == 0 else {}
                dataset = self._stack.enter_context(rasterio.open(path, "w", width=w, height=h, **options, **extra))
                if k == 0:
                    for band, name in enumerate(descriptions, start=1):
                        dataset.set_band_description(band, name)
                    dataset.update_tags(**tags)
                else:
                    before = self.levels[-1].dataset
                    rows = rows[nearest(before.height, h)]
                    columns = (np.arange(width) if columns is None else columns)[nearest(before.width, w)]
                self.levels.append(_Level(dataset, rows, columns))
        except BaseException:
            self.close()
            raise

    def add(self, first: int, values: np.ndarray) -> None:
        """The full-resolution rows ``first``... of every layer (layers x rows x columns, float32), in order."""
        for level in self.levels:
            level.add(first, values)

    def finish(self, target) -> None:
        """Close the tiled files (their last tiles compressed) and lay them out as the COG ``target``."""
        self._stack.close()
        write_cog(target, [read_tiled(p) for p in self.paths])
        self.close()

    def close(self) -> None:
        self._stack.close()
        for path in self.paths:
            if os.path.exists(path):
                os.unlink(path)
