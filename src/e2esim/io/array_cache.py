"""A cache of plain arrays in HDF5 files, keyed by a hash of everything that determines them.

Physics kernels (the Faraday-rotation climatologies) never import it: the runner hands them an
``ArrayCache`` (or None) through the stage, and they call ``get`` and ``put``. The location is a module
parameter; by default ``$E2ESIM_CACHE``, else ``$XDG_CACHE_HOME/e2esim``, else ``~/.cache/e2esim``. Files are
written atomically (``e2esim.atomic``), so an interrupted run never leaves a half-written table, and hold
plain numeric arrays only (nothing is unpickled or executed on reading). The key includes the cache schema
version and the PyIRI version.

Every file carries the SHA-256 checksum of its arrays and attributes, its own name and the versions that wrote
it (``cache_schema``, ``e2esim_version``, ``pyiri_version``). A file that is not exactly what this cache writes
(a special file, links or data kept outside the file, arrays larger than ``MAX_CACHE_FILE_BYTES``, numbers that
do not match their checksum, a table renamed from another key) is a cache miss with a ``CacheWarning``: the
table is recomputed and the file overwritten. The cache is optional: when its folder cannot be found, read or
written (read-only, a file, ``/dev/null``, a path too long, no home folder), the run goes on without it, with a
``CacheWarning`` (issue 22, docs/security.md).
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from pathlib import Path

import numpy as np

import e2esim
from e2esim.atomic import atomic_path
from e2esim.errors import E2ESimWarning
from e2esim.input_files import NotARegularFile, regular_file_stat

SCHEMA_VERSION = 2
"""Bumped whenever what is stored, or how it is computed, changes. 2: the checksum and the producing versions
are stored with the arrays (issue 22)."""

MAX_CACHE_FILE_BYTES = 4 * 2**30
"""Arrays of one cache file, as declared in it, before any is read: 4 GiB. A table of the 1 deg global map (one
month, both passes, one solar level, three swath positions: faraday, stec, vtec) takes 9 MB, and all twelve months
and both solar levels in one table would take 0.22 GB; a larger table is computed but not cached, and a file
declaring more is a cache miss (a fill-value bomb would otherwise allocate it)."""

MAX_ATTRIBUTE_BYTES = 1 << 20
"""One attribute of a cache file: 1 MiB (the description of a table is a few hundred bytes)."""

_FILTERS = frozenset({"gzip", "shuffle", "fletcher32"})
"""HDF5 filters a cache file may use: those ``write`` uses, and a checksum filter. Any other would make HDF5
look for a filter plug-in."""


class CacheWarning(E2ESimWarning):
    """The climatology cache could not be used (found, read, trusted or written): the run goes on without it."""


def default_cache_dir() -> Path:
    """``$E2ESIM_CACHE``, else ``$XDG_CACHE_HOME/e2esim``, else ``~/.cache/e2esim``."""
    env = os.environ.get("E2ESIM_CACHE")
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "e2esim"


def resolve_cache_dir(value) -> Path | None:
    """A cache folder from a parameter: None -> default folder, "off"/"" -> no cache, else the path."""
    if value is None:
        return default_cache_dir()
    if str(value).strip().lower() in ("", "off", "none", "false"):
        return None
    return Path(value).expanduser()


def open_cache(setting) -> ArrayCache | None:
    """The cache for a module's ``cache_dir`` setting (None: the default folder; "off": no cache); None, with a
    ``CacheWarning``, when the default folder cannot be found (no home folder)."""
    try:
        folder = resolve_cache_dir(setting)
    except (RuntimeError, KeyError, OSError) as exc:  # Path.home() without HOME and without a passwd entry
        _warn(f"no cache folder ({_why(exc)}); the climatology is computed without a cache (set E2ESIM_CACHE or the "
              "module's cache_dir)")
        return None
    return None if folder is None else ArrayCache(folder)


def _pyiri_version() -> str:
    try:
        from importlib.metadata import version

        return version("PyIRI")
    except Exception:  # pragma: no cover - PyIRI not installed as a distribution
        return "unknown"


def cache_key(kind: str, description: dict, arrays: dict | None = None) -> str:
    """Hex digest of the schema version, PyIRI version, a JSON description and the bytes of arrays."""
    h = hashlib.sha256()
    head = {"schema": SCHEMA_VERSION, "pyiri": _pyiri_version(), "kind": kind, **description}
    h.update(json.dumps(head, sort_keys=True, default=str).encode())
    for name in sorted(arrays or {}):
        a = np.ascontiguousarray(arrays[name])
        h.update(name.encode())
        h.update(str(a.dtype).encode() + str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:24]


def cache_file(folder: Path, kind: str, key: str) -> Path:
    return Path(folder) / f"{kind}_{key}.h5"


def read(path: Path, required: tuple = ()) -> dict | None:
    """The arrays and attributes stored in ``path``, or None if it is absent, unreadable or not what this cache
    writes (``read_checked`` says why)."""
    return read_checked(path, required)[0]


def read_checked(path: Path, required: tuple = ()) -> tuple:
    """``(stored, None)``: the arrays of ``path`` and its attributes (``stored["attrs"]``), every name of ``required``
    among them; ``(None, None)`` if there is no such file; ``(None, why)`` if the file is not what ``write`` wrote.
    Nothing in the file can run code (HDF5 through h5py holds no pickles); its structure and sizes are checked
    before any array is read, its checksum after."""
    import h5py

    try:
        regular_file_stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return None, None
    except OSError as exc:  # a FIFO, a device, a directory; no permission; a name too long
        return None, _why(exc)
    try:
        with h5py.File(path, "r") as f:
            problem = _structure_problem(f)
            if problem:
                return None, problem
            arrays = {name: f[name][()] for name in f}
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
    except Exception as exc:  # any unreadable or foreign file is only a cache miss
        return None, f"not a readable HDF5 file ({_why(exc)})"
    if not all(isinstance(v, (str, int, float, np.integer, np.floating)) for v in attrs.values()):
        return None, "an attribute is neither a number nor text"
    problem = _producer_problem(Path(path), arrays, attrs)
    if problem:
        return None, problem
    missing = [name for name in required if name not in arrays and name not in attrs]
    if missing:
        return None, f"it lacks {', '.join(missing)}"
    return {**arrays, "attrs": attrs}, None


def _structure_problem(f) -> str | None:
    """Why an open HDF5 file is not a plain cache file (None if it is): only numeric datasets at the top level,
    stored in the file with the filters ``write`` uses, at most ``MAX_CACHE_FILE_BYTES`` together; scalar
    attributes of at most ``MAX_ATTRIBUTE_BYTES``."""
    import h5py

    total = 0
    for name in f:
        if not isinstance(f.get(name, getlink=True), h5py.HardLink):
            return f"{name!r} is a link (links are never followed)"
        item = f[name]
        if not isinstance(item, h5py.Dataset) or item.dtype.kind not in "biuf":
            return f"{name!r} is not an array of numbers"
        if item.external or item.is_virtual:
            return f"{name!r} keeps its data outside the file"
        if not set(item._filters) <= _FILTERS:
            return f"{name!r} uses HDF5 filters {sorted(map(str, item._filters))}"
        total += int(np.prod(item.shape, dtype=object)) * item.dtype.itemsize
    if total > MAX_CACHE_FILE_BYTES:
        return f"its arrays would take {total:,} bytes, above the limit of {MAX_CACHE_FILE_BYTES:,}"
    for key in f.attrs:
        attr = f.attrs.get_id(key)
        if attr.shape != () or attr.get_storage_size() > MAX_ATTRIBUTE_BYTES:
            return f"attribute {key!r} is not a single number or a short text"
    return None


def _producer_problem(path: Path, arrays: dict, attrs: dict) -> str | None:
    """Why the arrays and attributes read from ``path`` are not those ``write`` wrote there (None if they are)."""
    if "checksum" not in attrs:
        return "it carries no checksum (not written by this version of e2esim)"
    if attrs["checksum"] != checksum(arrays, {k: v for k, v in attrs.items() if k != "checksum"}):
        return "its numbers do not match their checksum (altered or damaged)"
    if attrs.get("entry") != path.stem or attrs.get("cache_schema") != SCHEMA_VERSION:
        return (f"it holds the table {attrs.get('entry')!r} of cache schema {attrs.get('cache_schema')!r}, not "
                f"{path.stem!r} of schema {SCHEMA_VERSION} (renamed or copied from elsewhere)")
    return None


def checksum(arrays: dict, attrs: dict) -> str:
    """SHA-256 (hex) of arrays (name, kind, size, shape and little-endian bytes) and of scalar attributes (numbers
    exactly, text), independent of the byte order and of whether a number came back as a numpy scalar."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.asarray(arrays[name])
        h.update(json.dumps([name, a.dtype.kind, a.dtype.itemsize, list(a.shape)]).encode())
        h.update(np.ascontiguousarray(a, dtype=a.dtype.newbyteorder("<")).tobytes())
    h.update(json.dumps({k: _canonical(v) for k, v in attrs.items()}, sort_keys=True).encode())
    return h.hexdigest()


def _canonical(value):
    if isinstance(value, (str, bytes)):
        return ["s", value.decode() if isinstance(value, bytes) else value]
    if isinstance(value, (int, np.integer)):
        return ["i", int(value)]
    return ["f", float(value).hex()]


def write(path: Path, arrays: dict, attrs: dict) -> None:
    """Write arrays (compressed) and JSON-able attributes to ``path`` atomically, with the file's name, the
    producing versions and the checksum of it all. Raises what the file system raises (``ArrayCache.put``
    turns that into a warning)."""
    from e2esim.io.guarded_h5 import check_writing, guarded_h5_file

    path = Path(path)
    arrays = {name: np.asarray(value) for name, value in arrays.items()}
    size = sum(a.nbytes for a in arrays.values())
    if size > MAX_CACHE_FILE_BYTES:
        raise OSError(f"the table takes {size:,} bytes, above the cache's limit of {MAX_CACHE_FILE_BYTES:,}")
    stored = {key: _attribute(value) for key, value in attrs.items()}
    stored.update(entry=path.stem, cache_schema=SCHEMA_VERSION, e2esim_version=e2esim.__version__,
                  pyiri_version=_pyiri_version())
    stored["checksum"] = checksum(arrays, stored)
    # through a GuardedFile: a full disk or the file-size limit is an OSError (a warning), never a crash at exit
    with atomic_path(path) as tmp, guarded_h5_file(tmp) as f:
        for name, value in arrays.items():
            check_writing()
            if value.size > 1024:
                f.create_dataset(name, data=value, compression="gzip", compression_opts=1, shuffle=True)
            else:
                f.create_dataset(name, data=value)
        for key, value in stored.items():
            f.attrs[key] = value


def _attribute(value):
    """An attribute as stored: numbers (booleans as 0 and 1) and text as they are, anything else as JSON."""
    if isinstance(value, bool):
        return int(value)
    return value if isinstance(value, (int, float, str)) else json.dumps(value, default=str)


def _why(exc: BaseException, filename: bool = True) -> str:
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror + (f": {exc.filename}" if filename and exc.filename else "")
    return f"{type(exc).__name__}: {exc}"


_warned: set = set()
"""What this process has warned about: a folder that cannot be written is said once, not once per table."""


def _warn_once(what, message: str) -> None:
    if what not in _warned:
        _warned.add(what)
        _warn(message)


def _warn(message: str) -> None:
    warnings.warn(f"climatology cache: {message}", CacheWarning, stacklevel=4)


class ArrayCache:
    """Plain-array cache in one folder: ``get`` what ``put`` stored under the same kind, description and
    input arrays (HDF5, one file per key)."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)

    def _path(self, kind: str, description: dict, inputs: dict | None) -> Path:
        return cache_file(self.folder, f"faraday_{kind}", cache_key(kind, description, inputs))

    def get(self, kind: str, description: dict, inputs: dict | None = None, required: tuple = ()) -> dict | None:
        """The arrays stored for this key (and ``attrs``), or None: no such file, or (with a ``CacheWarning``) one
        that cannot be read, is not what ``put`` writes or lacks a name of ``required`` (see ``read_checked``)."""
        path = self._path(kind, description, inputs)
        try:
            regular_file_stat(path)
        except (FileNotFoundError, NotADirectoryError):
            return None
        except NotARegularFile as exc:
            _warn_once(path, f"ignoring {path}: it is {exc.kind}, not a file of this cache; the table is recomputed")
            return None
        except OSError as exc:  # no permission, a name too long: the folder's problem, said once
            _warn_once((self.folder, exc.strerror), f"cannot read in the cache folder {self.folder} "
                       f"({_why(exc, False)}); the climatology is recomputed")
            return None
        stored, why = read_checked(path, required)
        if why:
            _warn_once(path, f"ignoring {path} ({why}); the table is recomputed")
        return stored

    def put(self, kind: str, description: dict, inputs: dict | None, arrays: dict, attrs: dict) -> None:
        """Store the arrays for this key; if that fails, warn (``CacheWarning``, once per folder and reason) and go
        on: the cache is optional."""
        path = self._path(kind, description, inputs)
        try:
            write(path, arrays, attrs)
        except Exception as exc:  # a read-only folder, a file in the way, a full disk: the run needs no cache
            _warn_once((self.folder, _why(exc, False)), f"cannot write in the cache folder {self.folder} "
                       f"({_why(exc, False)}); the run goes on without caching there (give the "
                       "module's cache_dir, or E2ESIM_CACHE, a writable folder, or 'off')")
