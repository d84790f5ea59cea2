"""A variable of a map dataset held as the values of its swept cases (``SweptCells``), not as a dense grid.

A map sweep runs only the forest cells of its grid, so most of a (solar, pass, month, lat, lon) variable is its
fill value (NaN, or a flag's fill). ``SweptCells`` keeps the cases' values and their grid positions and behaves as
the dense array to numpy and xarray (``np.asarray``, ufuncs, numpy functions and the array's methods give the
dense grid), made only when read. The writer of results.nc (``e2esim.maps.netcdf``) writes it chunk by chunk
(``chunk_writes``), skipping the chunks without a case, which HDF5 then returns as the fill value: the file reads
back as the dense grid, bit for bit.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

DENSE_METHODS = frozenset({"astype", "copy", "reshape", "transpose", "ravel", "tolist", "item", "view", "T"})
"""The ndarray attributes a ``SweptCells`` answers with those of its dense grid."""


class SweptCells(np.lib.mixins.NDArrayOperatorsMixin):
    """The grid ``shape`` (dtype of ``values``) filled with ``fill``, ``values`` at ``index`` (a tuple of integer
    arrays, one per axis, as numpy's advanced indexing takes it), then ``overlay`` ((mask over the last two axes,
    value) or None) over every leading index: what ``np.full(shape, fill); grid[index] = values;
    grid[..., mask] = value`` gives. Python's operators go through numpy's ufuncs (``NDArrayOperatorsMixin``)."""

    __slots__ = ("case_values", "dtype", "fill", "index", "nbytes", "ndim", "overlay", "shape", "size")

    def __init__(self, shape, index, values, fill, overlay=None):
        self.shape = tuple(int(n) for n in shape)
        self.index = index
        self.case_values = np.asarray(values)
        self.dtype = self.case_values.dtype
        self.fill = self.dtype.type(fill)
        self.overlay = overlay
        self.ndim, self.size = len(self.shape), math.prod(self.shape)
        self.nbytes = self.size * self.dtype.itemsize

    def __len__(self) -> int:
        return self.shape[0]

    def __repr__(self) -> str:
        return f"SweptCells(shape={self.shape}, dtype={self.dtype}, {self.case_values.size} cases, fill {self.fill})"

    def dense(self, out=None) -> np.ndarray:
        """The dense grid (into ``out``, an array of the shape and dtype, where given: a buffer reused)."""
        if out is None:
            out = np.full(self.shape, self.fill, self.dtype)
        else:
            out.fill(self.fill)
        out[self.index] = self.case_values
        if self.overlay is not None:
            mask, value = self.overlay
            out[..., mask] = value
        return out

    def __array__(self, dtype=None, copy=None):
        grid = self.dense()
        return grid if dtype is None else grid.astype(dtype, copy=False)

    def __getitem__(self, key):
        return self.dense()[key]

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        return getattr(ufunc, method)(*_dense_all(inputs), **kwargs)

    def __array_function__(self, func, types, args, kwargs):
        return func(*_dense_all(args), **{k: _dense_all(v) for k, v in kwargs.items()})

    def __getattr__(self, name):
        # the array's methods that xarray and numpy call on a duck array, on the dense grid; any other name is not
        # an attribute (a probe such as hasattr(cells, "chunks") never makes the grid)
        if name not in DENSE_METHODS:
            raise AttributeError(name)
        return getattr(self.dense(), name)

    def occupied_chunks(self, chunks) -> list:
        """The chunks (tuples of slices; ``chunks``: the chunk's size on each axis) that hold a case or the overlay,
        in C order."""
        counts = [-(-n // c) for n, c in zip(self.shape, chunks)]
        hit = np.zeros(counts, bool)
        hit[tuple(np.asarray(k) // c for k, c in zip(self.index, chunks))] = True
        if self.overlay is not None:
            rows, cols = np.nonzero(self.overlay[0])
            hit[..., rows // chunks[-2], cols // chunks[-1]] = True
        return [tuple(slice(k * c, min((k + 1) * c, n)) for k, c, n in zip(where, chunks, self.shape))
                for where in itertools.product(*(range(n) for n in counts)) if hit[where]]


def _dense_all(values):
    """``values`` with every ``SweptCells`` in it (a tuple, list or one value) made dense."""
    if isinstance(values, SweptCells):
        return values.dense()
    if isinstance(values, (tuple, list)):
        return type(values)(_dense_all(v) for v in values)
    return values
