"""Reading an HDF5 file e2esim did not just write (a results.h5 from a colleague): checked before it is read.

An HDF5 file can point outside itself and can be far larger read than stored. A dataset may keep its bytes
in another file (external storage: ``/etc/passwd`` read as text) or map other files (a virtual dataset); a
link may open another HDF5 file (an external link); a dataset declared with a billion elements and never
written reads as fill values; a compressed chunk can inflate far past its declared size. ``H5Reader`` reads
only through checks that refuse all of these before any data is read or any memory allocated:

* every step of a path is a hard link: soft and external links are refused (e2esim writes none);
* a dataset is neither virtual nor stored outside the file;
* its type is of the kind expected (numbers, integer codes or text), its shape the one expected;
* uncompressed, it stores every byte it declares (no fill values), so what is read is at most the file;
* compressed (deflate, shuffle and Fletcher-32 only, as ``h5repack`` writes them), each chunk is first
  decompressed here never beyond its declared size, and at most ``MAX_H5_DECOMPRESSED_BYTES`` in all;
* attributes are read only when they are short numbers or text.

Whatever else goes wrong inside HDF5 on a damaged file becomes a ``ResultsFileError`` naming the file
(``H5Reader.guard``), never a traceback.
"""

from __future__ import annotations

import contextlib
import math
import zlib
from pathlib import Path

import h5py
import numpy as np

from e2esim.errors import ResultsFileError, UserError
from e2esim.input_files import check_regular
from e2esim.limits import MAX_H5_CHUNKS, MAX_H5_DECOMPRESSED_BYTES, shorten

FILTERS = {h5py.h5z.FILTER_DEFLATE: "deflate", h5py.h5z.FILTER_SHUFFLE: "shuffle",
           h5py.h5z.FILTER_FLETCHER32: "fletcher32"}
"""The HDF5 filters read: those of gzip compression. Others (szip, lzf, plug-ins) are refused."""
MAX_ATTRIBUTE_VALUES = 10_000
MAX_ATTRIBUTE_BYTES = 2**20
"""An attribute larger than this is not read (e2esim writes short text and numbers)."""
_DAMAGE = (OSError, KeyError, ValueError, TypeError, IndexError, RuntimeError, OverflowError, RecursionError,
           MemoryError, UnicodeError)
"""What h5py and numpy raise on a damaged file."""


class H5Reader:
    """An HDF5 file open for checked reading. ``what``: how messages name the file (``"results file"``)."""

    def __init__(self, path, what: str = "results file"):
        self.path = Path(path)
        self.what = what
        check_regular(self.path, what, ResultsFileError)
        self.decompressed = 0
        self._groups: dict = {}  # {path: group} reached by ``get``
        with self.guard():
            try:
                self.file = h5py.File(self.path, "r")
            except OSError as exc:
                raise ResultsFileError(f"{self.path}: not an HDF5 file, or a damaged one; a {what} is the "
                                       "results.h5 of an e2esim run") from exc
            sizes = self.file.id.get_create_plist().get_sizes()
        self._vlen_bytes = 8 + sizes[0]  # a variable-length value in the file: length, heap address and index

    def __enter__(self) -> H5Reader:
        return self

    def __exit__(self, *exc) -> None:
        with contextlib.suppress(Exception):
            self.file.close()

    @contextlib.contextmanager
    def guard(self):
        """Turn anything HDF5 or numpy raise on a damaged file into a ``ResultsFileError`` naming it."""
        try:
            yield
        except UserError:
            raise
        except _DAMAGE as exc:
            raise ResultsFileError(f"{self.path}: cannot be read as a {self.what}: it is damaged or not of e2esim "
                                   f"({type(exc).__name__}: {shorten(str(exc), 160)})") from exc

    def fail(self, where: str, problem: str, allowed: str = ""):
        raise ResultsFileError(f"{self.path}: {where}: {problem}" + (f"; {allowed}" if allowed else ""))

    # Links and objects --------------------------------------------------------------------------------
    def get(self, path: str, kind=h5py.Dataset, required: bool = True):
        """The object at ``path`` (``"cases/results"``) reached by hard links only, of ``kind``; None when
        missing and not ``required``."""
        node = self.file
        parts = [p for p in path.split("/") if p]
        for depth, part in enumerate(parts):
            where = "/" + "/".join(parts[:depth + 1])
            child = self._groups.get(where) or self._child(node, part, where)
            if child is None:
                if required:
                    self.fail(where, "is missing", f"a {self.what} of e2esim has it (docs/output-format.md)")
                return None
            if isinstance(child, h5py.Group):
                self._groups[where] = child  # its links checked once: the file is open for reading only
            node = child
        if not isinstance(node, kind):
            self.fail("/" + "/".join(parts), f"is a {_kind_name(type(node))}, not a {_kind_name(kind)}")
        return node

    def _child(self, group, name: str, where: str):
        if not isinstance(group, h5py.Group):
            self.fail(where, "lies below something that is not a group")
        if name not in (".", ".."):  # a hard link (what e2esim writes): checked and opened in two HDF5 calls
            encoded = _encoded(name)
            try:
                hard = group.id.links.get_info(encoded).type == h5py.h5l.TYPE_HARD
            except RuntimeError:  # no such link (or a damaged one): h5py's lookup below says which
                hard = False
            if hard:
                return _open(group, encoded)
        link = group.get(name, getlink=True)
        if link is None:
            return None
        if isinstance(link, h5py.ExternalLink):
            self.fail(where, f"is an external link to {shorten(link.filename)}; e2esim never follows links out of "
                      "a file (it writes none)")
        if not isinstance(link, h5py.HardLink):
            self.fail(where, "is a soft link; e2esim writes none and follows none")
        return group[name]

    def members(self, group, kind=h5py.Dataset) -> list:
        """[(name, object)] of ``group``'s members, each reached by a hard link and of ``kind``."""
        out, base = [], group.name.rstrip("/")
        for name in list(group):
            node = self._child(group, name, f"{base}/{name}")
            if not isinstance(node, kind):
                self.fail(f"{base}/{name}", f"is a {_kind_name(type(node))}, not a {_kind_name(kind)}")
            out.append((name, node))
        return out

    # Data ---------------------------------------------------------------------------------------------
    def read(self, ds, kinds: str, shape: tuple):
        """The data of ``ds`` (numeric kinds ``kinds``, e.g. "fiub"), checked to have ``shape`` (None: any length
        on that axis) before it is read."""
        type_id = ds.id.get_type()
        dtype = type_id.dtype  # ds.dtype, from the one HDF5 type
        if dtype.kind not in kinds or dtype.fields is not None or dtype.subdtype is not None:
            self.fail(ds.name, f"holds {_type_name(dtype)}", f"expected {_KINDS.get(kinds, kinds)}")
        dims = self._check(ds, shape, type_id, dtype)
        out = np.zeros(dims, dtype=dtype)  # what ds[()] reads, without h5py's selection machinery
        if out.size:
            ds.id.read(h5py.h5s.ALL, h5py.h5s.ALL, out, mtype=_memory_type(dtype, None))
        return out[()] if out.ndim == 0 else out

    def read_text(self, ds, shape: tuple) -> np.ndarray:
        """Text data of ``ds`` as an object array of ``str`` (bytes decoded as UTF-8, bad bytes replaced)."""
        type_id = ds.id.get_type()
        dtype = type_id.dtype
        if h5py.check_string_dtype(dtype) is None:
            self.fail(ds.name, f"holds {_type_name(dtype)}", "expected text")
        self._check(ds, shape, type_id, dtype)
        data = np.asarray(ds[()], dtype=object)
        out = np.empty(data.shape, dtype=object)
        out.flat[:] = [as_text(x) for x in data.flat]
        return out

    def shape(self, ds) -> tuple:
        """The shape of ``ds``; one without any (an HDF5 null dataspace) is refused."""
        if ds.shape is None:
            self.fail(ds.name, "holds no data (an empty HDF5 dataspace)")
        return ds.shape

    def _check(self, ds, shape: tuple, type_id, dtype) -> tuple:
        """Refuse ``ds`` (of HDF5 type ``type_id``, ``dtype``) unless it lies in this file, has ``shape``, stores
        what it declares and, compressed, decompresses within the limits; its shape."""
        plist = ds.id.get_create_plist()
        dims = self.shape(ds)
        if plist.get_layout() == h5py.h5d.VIRTUAL:
            self.fail(ds.name, "is a virtual dataset (its data lies in other files); e2esim reads only data stored "
                      "in the file itself")
        if plist.get_external_count():
            self.fail(ds.name, "keeps its data in another file (HDF5 external storage); e2esim reads only data "
                      "stored in the file itself")
        if len(dims) != len(shape) or any(s is not None and s != n for s, n in zip(shape, dims)):
            expected = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "")
            self.fail(ds.name, f"has shape {dims}", f"expected {expected})")
        element = self._vlen_bytes if dtype.kind == "O" else type_id.get_size()
        declared = math.prod(dims) * element
        filters = [plist.get_filter(i)[0] for i in range(plist.get_nfilters())]
        if not filters:
            if ds.id.get_storage_size() < declared:
                self.fail(ds.name, f"declares {declared:,} bytes but stores {ds.id.get_storage_size():,} (the rest "
                          "would be made up of fill values)", "e2esim reads only data stored in the file")
            return dims
        unknown = [FILTERS.get(f, f"number {f}") for f in filters if f not in FILTERS]
        if unknown:
            self.fail(ds.name, f"is compressed with the HDF5 filter {', '.join(map(str, unknown))}",
                      "e2esim reads uncompressed data and gzip (deflate, shuffle, fletcher32)")
        self.decompressed += declared
        if self.decompressed > MAX_H5_DECOMPRESSED_BYTES:
            self.fail(ds.name, f"compressed data of more than {MAX_H5_DECOMPRESSED_BYTES:,} bytes decompressed "
                      "(the limit of a file)", "decompress the file first (h5repack -f NONE)")
        self._check_chunks(ds, plist, filters, element)
        return dims

    def _check_chunks(self, ds, plist, filters: list, element: int) -> None:
        """Decompress every stored chunk of ``ds`` here, never beyond its declared size, before HDF5 does."""
        chunk = plist.get_chunk()
        count = math.prod(-(-n // c) for n, c in zip(ds.shape, chunk))
        if count > MAX_H5_CHUNKS:
            self.fail(ds.name, f"is compressed in {count:,} chunks", f"at most {MAX_H5_CHUNKS:,} are read")
        expected = math.prod(chunk) * element
        for i in range(ds.id.get_num_chunks()):
            mask, data = ds.id.read_direct_chunk(ds.id.get_chunk_info(i).chunk_offset)
            for k in reversed(range(len(filters))):
                if mask & (1 << k):
                    continue  # this filter was skipped for this chunk
                if filters[k] == h5py.h5z.FILTER_FLETCHER32:
                    data = data[:-4]
                elif filters[k] == h5py.h5z.FILTER_DEFLATE:
                    data = self._inflate(ds, data, expected)
            if len(data) > expected:
                self.fail(ds.name, "has a chunk larger than its declared size")

    def _inflate(self, ds, data: bytes, expected: int) -> bytes:
        inflater = zlib.decompressobj()
        try:
            out = inflater.decompress(data, expected + 1)
        except zlib.error:
            self.fail(ds.name, "has a damaged compressed chunk")
        if len(out) > expected or inflater.unconsumed_tail:
            self.fail(ds.name, f"has a compressed chunk that inflates past its declared {expected:,} bytes "
                      "(a decompression bomb)")
        return out

    # Attributes ---------------------------------------------------------------------------------------
    def attributes(self, obj) -> dict:
        """{name: value} of ``obj``'s attributes that are short numbers or text (others are left out)."""
        out = {}
        for name in list(obj.attrs):
            value = self.attribute(obj, name)
            if value is not None:
                out[name] = value
        return out

    def attribute(self, obj, name: str):
        """The attribute ``name`` of ``obj`` when it is short numbers or text, else None."""
        encoded = _encoded(name)
        if not h5py.h5a.exists(obj.id, encoded):
            return None
        aid = h5py.h5a.open(obj.id, encoded)
        dtype, shape = aid.dtype, aid.shape
        info = h5py.check_string_dtype(dtype)
        text = info is not None
        if not (text or (dtype.kind in "biuf" and dtype.fields is None and dtype.subdtype is None)) or \
                math.prod(shape) > MAX_ATTRIBUTE_VALUES or aid.get_storage_size() > MAX_ATTRIBUTE_BYTES:
            return None
        value = _attribute_value(aid, dtype, shape, info)
        if text and isinstance(value, np.ndarray):
            return [as_text(x) for x in value.flat]
        return as_text(value) if text else value

    def text_attribute(self, obj, name: str) -> str | None:
        """A text attribute (None: missing); anything else there is refused."""
        value = self.attribute(obj, name)
        if (value is None and h5py.h5a.exists(obj.id, _encoded(name))) or \
                (value is not None and not isinstance(value, str)):
            self.fail(f"{obj.name} (attribute {name})", "is not a short text")
        return value


def _encoded(name) -> bytes:
    """A member's or attribute's name as HDF5 stores it (h5py lists a name that is not UTF-8 as bytes)."""
    return name.encode("utf-8") if isinstance(name, str) else name


def _open(group, name: bytes):
    """The object a hard link of ``group`` names, as ``group[name]`` gives it (the file is open for reading)."""
    oid = h5py.h5o.open(group.id, name)
    kind = h5py.h5i.get_type(oid)
    if kind == h5py.h5i.GROUP:
        return h5py.Group(oid)
    if kind == h5py.h5i.DATASET:
        return h5py.Dataset(oid, readonly=True)
    if kind == h5py.h5i.DATATYPE:
        return h5py.Datatype(oid)
    raise TypeError("Unknown object type")


def _attribute_value(aid, dtype, shape, info):
    """The value of a numeric or text attribute (no array type: ``H5Reader.attribute`` checked it), as
    ``obj.attrs[name]`` reads it: a scalar for one value, variable-length text as ``str`` (``info``: its
    ``h5py.check_string_dtype``)."""
    out = np.zeros(shape, dtype=dtype)
    aid.read(out, mtype=_memory_type(dtype, info))
    if info is not None and info.length is None:
        out = np.array([b.decode("utf-8", "surrogateescape") for b in out.flat], dtype=dtype).reshape(out.shape)
    return out[()] if out.ndim == 0 else out


_MEMORY_TYPES = {**{dtype: h5py.h5t.py_create(dtype) for dtype in map(np.dtype, ("f8", "i8", "i4", "i1", "u1", "u2",
                                                                                   "u4", "?"))},
                 **{("text", code, None): h5py.h5t.py_create(h5py.string_dtype(code)) for code in ("utf-8", "ascii")}}
"""HDF5 memory types of the numbers and text results.h5 holds, as ``h5py.h5t.py_create`` makes them: made once."""


def _memory_type(dtype, text):
    """``h5py.h5t.py_create(dtype)``, the HDF5 type of ``dtype`` in memory (``text``: its
    ``h5py.check_string_dtype``; a string dtype is its encoding and length; a dtype with other metadata, e.g. an
    enum's, is made each time)."""
    key = ("text", text.encoding, text.length) if text is not None else dtype if dtype.metadata is None else None
    known = _MEMORY_TYPES.get(key)
    return known if known is not None else h5py.h5t.py_create(dtype)


def as_text(x) -> str:
    return x.decode("utf-8", errors="replace") if isinstance(x, bytes) else str(x)


_KINDS = {"fiub": "numbers", "iu": "integers", "fiu": "numbers", "biu": "booleans (0 or 1)"}


def _type_name(dtype) -> str:
    if dtype.fields is not None:
        return "records (a compound type)"
    if h5py.check_string_dtype(dtype) is not None:
        return "text"
    return {"f": "floating-point numbers", "i": "integers", "u": "integers", "b": "booleans", "O": "objects",
            "c": "complex numbers", "V": "raw bytes"}.get(dtype.kind, f"values of type {dtype}")


def _kind_name(cls) -> str:
    if isinstance(cls, tuple):
        return " or a ".join(_kind_name(c) for c in cls)
    return {h5py.Dataset: "dataset", h5py.Group: "group", h5py.Datatype: "named datatype"}.get(cls, cls.__name__)


__all__ = ["FILTERS", "H5Reader", "as_text"]
