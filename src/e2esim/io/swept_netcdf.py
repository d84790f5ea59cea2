"""Writing a map dataset whose (solar, pass, month, lat, lon) variables are held as their swept cases
(``e2esim.maps.swept_cells.SweptCells``): results.nc (``e2esim.maps.netcdf.write_map_netcdf``).

xarray lays the file out as ``Dataset.to_netcdf(engine="netcdf4")`` does (the same CF encoding, variables,
attributes and filters: zlib, no shuffle), and writes every other variable itself. A ``SweptCells`` variable is
chunked (every solar level, pass and month of ``CHUNK_CELLS`` x ``CHUNK_CELLS`` cells) and only its chunks that
hold a case are written, whole and already deflated, through HDF5's direct chunk write (h5py): the bytes HDF5's own
deflate filter stores. A chunk never written reads back as the variable's fill value (``_FillValue``: NaN, or the
flag's fill), which is what the dense grid holds there, so the file reads back as the dense grid, bit for bit,
while no all-fill chunk is made, compressed or stored (a global 1 deg map sweeps about a tenth of its cells).
"""

from __future__ import annotations

import os
import zlib
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from e2esim.extras import optional_import
from e2esim.maps.swept_cells import SweptCells

CHUNK_CELLS = 15
"""Cells on each side of a chunk, which holds every solar level, pass and month (a chunk of 15 x 15 one-degree
cells of 2 solar levels, 2 passes and 12 months holds 86 kB)."""


COMPRESS_THREADS = 2
"""Threads that compress the chunks (the map's workers have finished when results.nc is written)."""


def swept_chunk_sizes(shape) -> tuple:
    """The chunk of a (solar, pass, month, lat, lon) variable of ``shape``."""
    return (*shape[:3], min(shape[3], CHUNK_CELLS), min(shape[4], CHUNK_CELLS))


def write_swept_netcdf(ds, path, encoding: dict) -> None:
    """``ds.to_netcdf(path, engine="netcdf4", encoding=encoding)``, its ``SweptCells`` variables written by their
    occupied chunks (module docstring); ``encoding`` gives them zlib without shuffle and ``swept_chunk_sizes``."""
    xr = optional_import("xarray", "maps", "writing results.nc")
    conventions = optional_import("xarray.conventions", "maps", "writing results.nc")
    h5py = optional_import("h5py", "maps", "writing results.nc")
    swept = {id(v.data): str(k) for k, v in ds.data_vars.items() if isinstance(v.data, SweptCells)}
    writer = _DeferSweptCells(swept)
    store = xr.backends.NetCDF4DataStore.open(os.fspath(path), mode="w", format="NETCDF4")
    try:
        variables, attrs = conventions.encode_dataset_coordinates(ds)
        for name, enc in encoding.items():
            variables[name].encoding = enc
        store.store(variables, attrs, set(encoding), writer)
    finally:
        store.close()
    if writer.deferred:
        with h5py.File(path, "r+") as f:
            _write_occupied_chunks(f, writer.deferred, {k: e.get("complevel", 4) for k, e in encoding.items()})


class _DeferSweptCells:
    """The writer of an xarray store (``add(source, target)``, as ``xarray.backends.common.ArrayWriter`` for
    arrays in memory): every array written whole, but a ``SweptCells`` of ``swept`` ({id: variable name}) that
    reaches it unchanged kept for the direct chunk write (``deferred``: [(name, cells)])."""

    def __init__(self, swept: dict):
        self.swept = swept
        self.deferred = []

    def add(self, source, target, region=None):
        name = self.swept.get(id(source)) if isinstance(source, SweptCells) else None
        if name is None:
            target[region or ...] = source
        else:
            self.deferred.append((name, source))


def _write_occupied_chunks(f, deferred: list, levels: dict) -> None:
    """Write the chunks of each (name, ``SweptCells``) that hold a case, deflated at the variable's level, each made
    dense in a buffer shared by the variables of a shape and dtype; an edge chunk padded with the fill value. zlib
    runs outside Python's lock, so the chunks of a variable are compressed on up to ``COMPRESS_THREADS`` cores."""
    buffers, occupied = {}, {}
    with ThreadPoolExecutor(max(1, min(COMPRESS_THREADS, os.cpu_count() or 1))) as pool:
        for name, cells in deferred:
            dataset = f[name]
            chunk = dataset.chunks
            if (dataset.compression != "gzip" or dataset.shuffle or dataset.fletcher32 or dataset.dtype != cells.dtype
                    or len(chunk) != cells.ndim):
                raise ValueError(f"results.nc: {name} is not stored as deflated chunks")  # xarray's layout changed
            key = (cells.shape, cells.dtype)
            grid = buffers[key] = cells.dense(buffers.get(key))
            where = (id(cells.index), id(cells.overlay), chunk)  # a map's variables share their cases' positions
            if where not in occupied:
                occupied[where] = cells.occupied_chunks(chunk)
            blocks = [_padded(grid[slices], chunk, cells.fill).tobytes() for slices in occupied[where]]
            level = levels.get(name, 4)
            for slices, data in zip(occupied[where], pool.map(lambda b, n=level: zlib.compress(b, n), blocks)):
                dataset.id.write_direct_chunk(tuple(s.start for s in slices), data)


def _padded(block, chunk, fill):
    """``block``, or an edge chunk padded to the whole ``chunk`` with ``fill`` (as HDF5 stores it)."""
    if block.shape == chunk:
        return block
    padded = np.full(chunk, fill, block.dtype)
    padded[tuple(slice(0, n) for n in block.shape)] = block
    return padded
