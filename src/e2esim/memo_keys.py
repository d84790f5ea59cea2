"""Keys of the kernel memo by the content of what a value is computed from (docs/architecture.md, "Caching").

A key built here is equal for equal values, whatever the objects: arrays by dtype, shape and bytes; dicts, tuples,
lists, numbers, strings and None by value (a float by its round-trip repr, so -0.0 is not 0.0); dataclasses by their
type and compared fields. Anything else cannot key a memo (TypeError): a caller then computes anew.
"""

from __future__ import annotations

import hashlib
from dataclasses import fields, is_dataclass

import numpy as np


def value_key(*inputs) -> str:
    """A key of ``inputs`` by their content (the SHA-256 of their key bytes): equal for equal values."""
    digest = hashlib.sha256()
    digest_update(digest, inputs)
    return digest.hexdigest()


def digest_update(digest, value) -> None:
    """Feed ``value``'s key bytes to ``digest`` (in one piece: the same digest as fed part by part)."""
    parts: list = []
    _key_bytes(parts, value)
    digest.update(b"".join(parts))


_PLAIN_SCALARS = (bool, int, float, complex, str, type(None))


def _key_bytes(out: list, value) -> None:
    """The key bytes of ``value`` appended to ``out``."""
    kind = type(value)
    if kind is np.ndarray:  # the common kinds first, by their exact type (none of them a dataclass)
        a = np.ascontiguousarray(value)
        out.append(f"a{a.dtype.str}{a.shape}".encode())
        out.append(a.tobytes())
    elif kind is tuple or kind is list:
        out.append(f"({len(value)}".encode())
        for item in value:
            _key_bytes(out, item)
    elif kind in _PLAIN_SCALARS:
        out.append(f"{kind.__name__}:{value!r};".encode())
    elif is_dataclass(value) and not isinstance(value, type):
        out.append(f"{kind.__module__}.{kind.__qualname__}{{".encode())
        _key_bytes(out, [(f.name, getattr(value, f.name)) for f in fields(value) if f.compare])
    elif isinstance(value, dict):
        _key_bytes(out, [(str(k), value[k]) for k in sorted(value)])
    elif isinstance(value, (tuple, list)):
        out.append(f"({len(value)}".encode())
        for item in value:
            _key_bytes(out, item)
    elif isinstance(value, np.ndarray):
        a = np.ascontiguousarray(value)
        out.append(f"a{a.dtype.str}{a.shape}".encode())
        out.append(a.tobytes())
    elif value is None or isinstance(value, (bool, int, float, complex, str)):
        out.append(f"{type(value).__name__}:{value!r};".encode())
    else:
        raise TypeError(f"cannot key a kernel memo by a {type(value).__name__}")
