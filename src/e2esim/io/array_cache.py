"""A cache of plain arrays in HDF5 files, keyed by a hash of everything that determines them.

Physics kernels (the Faraday-rotation climatologies) never import it: the runner hands them an
``ArrayCache`` (or None) through the stage, and they call ``get`` and ``put``. The location is a module
parameter; by default ``$E2ESIM_CACHE``, else ``$XDG_CACHE_HOME/e2esim``, else ``~/.cache/e2esim``. Files are
written atomically (``e2esim.io.atomic``), so an interrupted run never leaves a half-written table, and hold
plain numeric arrays only (nothing is unpickled or executed on reading). The key includes the cache schema
version and the PyIRI version.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

from e2esim.io.atomic import atomic_path

SCHEMA_VERSION = 1
"""Bumped whenever what is stored, or how it is computed, changes."""


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
    """The arrays and attributes stored in ``path``, or None if it is absent, unreadable or not what this
    cache writes: numeric datasets at the top level and attributes of numbers and text, with every name of
    ``required`` among the datasets or the attributes. Nothing in the file can run code (HDF5 through h5py
    holds no pickles); anything unexpected is a cache miss, recomputed and overwritten."""
    import h5py

    if not Path(path).exists():
        return None
    try:
        with h5py.File(path, "r") as f:
            out = {}
            for name, item in f.items():
                if not isinstance(item, h5py.Dataset) or item.dtype.kind not in "biuf":
                    return None
                out[name] = item[()]
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
    except Exception:  # any unreadable or foreign file is only a cache miss
        return None
    if any(name not in out and name not in attrs for name in required):
        return None
    if not all(isinstance(v, (str, int, float, np.integer, np.floating)) for v in attrs.values()):
        return None
    out["attrs"] = attrs
    return out


def write(path: Path, arrays: dict, attrs: dict) -> None:
    """Write arrays (compressed) and JSON-able attributes to ``path`` atomically."""
    import h5py

    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        for name, value in arrays.items():
            value = np.asarray(value)
            if value.size > 1024:
                f.create_dataset(name, data=value, compression="gzip", compression_opts=1, shuffle=True)
            else:
                f.create_dataset(name, data=value)
        for key, value in attrs.items():
            f.attrs[key] = value if isinstance(value, (int, float, str)) else json.dumps(value, default=str)


class ArrayCache:
    """Plain-array cache in one folder: ``get`` what ``put`` stored under the same kind, description and
    input arrays (HDF5, one file per key)."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)

    def _path(self, kind: str, description: dict, inputs: dict | None) -> Path:
        return cache_file(self.folder, f"faraday_{kind}", cache_key(kind, description, inputs))

    def get(self, kind: str, description: dict, inputs: dict | None = None, required: tuple = ()) -> dict | None:
        """The arrays stored for this key (and ``attrs``), or None (also when one of the arrays or attributes
        named in ``required`` is missing, or the file is not what ``put`` writes: see ``read``)."""
        return read(self._path(kind, description, inputs), required)

    def put(self, kind: str, description: dict, inputs: dict | None, arrays: dict, attrs: dict) -> None:
        write(self._path(kind, description, inputs), arrays, attrs)


def open_cache(setting) -> ArrayCache | None:
    """The cache for a module's ``cache_dir`` setting (None: the default folder; "off": no cache)."""
    folder = resolve_cache_dir(setting)
    return None if folder is None else ArrayCache(folder)
