"""Datasets of results.h5: each with its ``units`` and ``description``; text columns over cases as integer codes.

A column of text that repeats over cases (the dominant error source of a verdict, the basis, a text sweep value)
is stored as the integer code of each case into a table of its distinct texts: the dataset ``<name>`` (codes,
attribute ``text`` naming the table) beside ``<name>_text`` (strings). HDF5 writes and reads a million small
integers in milliseconds, a million variable-length strings in seconds (docs/output-format.md, format 3).
``read_text`` reads either form back as text.
"""

from __future__ import annotations

import h5py
import numpy as np

from e2esim.io.guarded_h5 import check_writing
from e2esim.io.scalar_units import TEXT

STRING = h5py.string_dtype("utf-8")
TABLE_ATTR = "text"
"""Attribute of a dataset of codes: the name of the sibling dataset holding its distinct texts."""


def put(group, name: str, data, units: str, description: str, dtype=None, table: str | None = None) -> None:
    """Create dataset ``name`` with its ``units`` and ``description`` attributes (and ``text``: ``table``, for
    codes), first stopping the writer if a write failed or Ctrl-C came (``e2esim.io.guarded_h5``).

    Made through h5py's low-level API in the very calls ``group.create_dataset(name, data=data, dtype=dtype)`` and
    ``ds.attrs[key] = text`` make (the same file, byte for byte: tests/test_results_h5_content.py), without their
    Python overhead: a results.h5 holds hundreds of small datasets."""
    check_writing()
    parent, _, leaf = name.rpartition("/")
    if parent:
        group = group.require_group(parent)  # as create_dataset makes the groups of a path
    array = np.asarray(data, order="C", dtype=dtype)
    if dtype is not None:
        array = array.view(dtype)  # keeps h5py's tag of a string dtype
    file_type, memory_type = _types(STRING if dtype is STRING else array.dtype)
    dataset = h5py.h5d.create(group.id, leaf.encode("utf-8"), file_type, h5py.h5s.create_simple(array.shape),
                              dcpl=_DATASET_CREATE)
    dataset.write(h5py.h5s.ALL, h5py.h5s.ALL, array, mtype=memory_type or h5py.h5t.py_create(array.dtype))
    _text_attribute(dataset, b"units", units)
    _text_attribute(dataset, b"description", description)
    if table is not None:
        _text_attribute(dataset, TABLE_ATTR.encode(), table)


def _dataset_create_plist():
    """What h5py's ``create_dataset`` sets for a dataset without chunks or filters: no times, no attribute order."""
    plist = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    plist.set_obj_track_times(False)
    plist.set_attr_creation_order(0)
    return plist


_DATASET_CREATE = _dataset_create_plist()
_SCALAR = h5py.h5s.create_simple(())
_STRING_FILE_TYPE = h5py.h5t.py_create(STRING, logical=True)
_STRING_MEMORY_TYPE = h5py.h5t.py_create(STRING)


_TYPES = {dtype: (h5py.h5t.py_create(dtype, logical=True), h5py.h5t.py_create(dtype))
          for dtype in map(np.dtype, ("f8", "i8", "i4", "i1", "u1", "u2", "u4", "?"))}
"""(HDF5 type in the file, in memory) of the numbers results.h5 holds, as h5py makes them: made once."""


def _types(dtype) -> tuple:
    """(HDF5 type in the file, in memory) of ``dtype`` as h5py makes them (``py_create``, logical for the file);
    memory type None: made for the array at hand."""
    if dtype is STRING:
        return _STRING_FILE_TYPE, _STRING_MEMORY_TYPE
    known = _TYPES.get(dtype) if dtype.metadata is None else None
    return known if known is not None else (h5py.h5t.py_create(dtype, logical=True), None)


def _text_attribute(obj_id, name: bytes, text: str) -> None:
    """``attrs[name] = text`` on a new object: a scalar variable-length UTF-8 string, as h5py stores a ``str``."""
    attribute = h5py.h5a.create(obj_id, name, _STRING_FILE_TYPE, _SCALAR)
    try:
        attribute.write(np.array(text, dtype=STRING), mtype=_STRING_MEMORY_TYPE)
    finally:
        attribute.close()


def put_text(group, name: str, values, description: str) -> None:
    """A string, or a short list of strings, as variable-length UTF-8 text."""
    put(group, name, values if isinstance(values, str) else list(values), TEXT, description, STRING)


def put_coded(group, name: str, texts, codes, description: str) -> None:
    """Text per case as ``codes`` (integers, any shape) into ``texts`` (the distinct texts), ``<name>_text``."""
    table = f"{name}_text"
    put_text(group, table, texts, f"the distinct texts of {name}")
    codes = np.asarray(codes).astype(code_dtype(len(texts)))
    put(group, name, codes, TEXT, f"{description} (codes into {table})", table=table)


def code_dtype(count: int) -> np.dtype:
    """The smallest unsigned integer type that numbers ``count`` texts."""
    for dtype in (np.uint8, np.uint16, np.uint32):
        if count <= np.iinfo(dtype).max + 1:
            return np.dtype(dtype)
    return np.dtype(np.uint64)


def coded_values(columns: list) -> tuple:
    """(texts, codes (n, len(columns))) of ``Values`` columns of text (``e2esim.block.Values``), one table for all."""
    lookup: dict = {}
    per_column = []
    for column in columns:
        codes = np.array([lookup.setdefault(str(v), len(lookup)) for v in column.values], dtype=np.int64)
        per_column.append(codes[column.index] if len(codes) else np.zeros(len(column.index), dtype=np.int64))
    n = len(columns[0].index) if columns else 0
    return list(lookup), (np.stack(per_column, axis=1) if per_column else np.zeros((n, 0), dtype=np.int64))


def read_text(ds) -> np.ndarray:
    """A text dataset as an object array of ``str``, whether written as codes (format 3) or as strings."""
    if TABLE_ATTR in ds.attrs:
        table = np.array([as_str(t) for t in ds.parent[as_str(ds.attrs[TABLE_ATTR])][()]], dtype=object)
        return table[ds[()]]
    data = np.asarray(ds[()], dtype=object)
    out = np.empty(data.shape, dtype=object)
    out.flat[:] = [as_str(x) for x in data.flat]
    return out


def as_str(x) -> str:
    return x.decode() if isinstance(x, bytes) else str(x)


__all__ = ["STRING", "TABLE_ATTR", "as_str", "code_dtype", "coded_values", "put", "put_coded", "put_text",
           "read_text"]
