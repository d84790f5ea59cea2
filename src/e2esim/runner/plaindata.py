"""Plain-data encoding of case results for files: JSON for the structure, raw bytes for numeric arrays.

The resume journal stores each finished case with this encoding, never with pickle: reading it builds only
numbers, strings, lists, mappings, numpy arrays of plain dtypes, arrays of such values and instances of
allowed classes, filled field by field without calling any of their code. So a crafted journal can give
wrong numbers at worst; it cannot run code. The encoding is generic (any dataclass-like object of e2esim
or of a registered plug-in), so it follows changes to the result types without a schema to maintain,
and round-trips exactly: floats through ``repr``, arrays byte for byte, shared references kept. Fields a class
names in ``plain_transient`` are caches of what its other fields determine: they are not stored and come back
as empty dicts; the values of its ``functools.cached_property``s are not stored either (derived again when asked).

Layout of one encoded value: ``(header, payload)``; ``header`` is a JSON text ``{"tree": ..., "arrays":
[[dtype, shape] or [dtype, shape, "read-only"], ...]}``, ``payload`` the arrays' bytes back to back, in C order.
"""

from __future__ import annotations

import datetime as dt
import functools
import json
import re
import sys
from types import MappingProxyType

import numpy as np

from e2esim.allocator import collector_paused

ARRAY_KINDS = frozenset("biufcUSMm")
"""numpy dtype kinds stored: booleans, integers, floats, complex, text, bytes, datetimes, time deltas."""

_CLASS = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*):([A-Za-z_][A-Za-z0-9_.]*)$")
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class NotPlainData(TypeError):
    """The value holds something this encoding does not store (a function, a file, an object array...)."""


class BadPlainData(ValueError):
    """Encoded data that is malformed, inconsistent or names a class that is not allowed."""


def allowed_packages() -> frozenset:
    """Top-level packages whose classes may be stored: e2esim and the packages of registered modules."""
    from e2esim import registry

    return frozenset({"e2esim"} | {r.package for r in registry.available()})


# ---------------------------------------------------------------------------------------------- encoding
def encode(value, packages: frozenset) -> tuple[bytes, bytes]:
    """(header, payload) of ``value``; raises NotPlainData for what cannot be stored. The garbage collector is
    paused meanwhile: the tree has no cycles, and a block keeping its cases' products has a million nodes."""
    with collector_paused():
        enc = _Encoder(packages)
        tree = enc.encode(value)
        header = json.dumps({"tree": tree, "arrays": enc.specs}, separators=(",", ":"), allow_nan=True)
    return header.encode("utf-8"), b"".join(enc.chunks)


class _Encoder:
    """One ``encode`` call: a value's node by its exact type (``_BY_TYPE``); a class or dtype checked once."""

    def __init__(self, packages: frozenset):
        self.packages = packages
        self.specs: list = []
        self.chunks: list = []
        self.memo: dict = {}  # id -> reference number, for objects met twice (shared or cyclic)
        self.keep: list = []  # keeps encoded objects alive, so that their ids stay unique
        self.classes: dict = {}  # class -> (stored name, slots, cache fields), or the NotPlainData to raise

    def encode(self, v):
        t = type(v)
        if t in _AS_IS:
            return v
        if (handler := _BY_TYPE.get(t)) is None:
            return self._other(v)
        if t in _SHARED:  # an array, list or dict met before: a reference to it
            ref = self.memo.get(id(v))
            if ref is not None:
                return {"$": "r", "r": ref}
        return handler(self, v)

    def _ndarray(self, v):
        if v.dtype.kind == "O":  # an array of Python values: its items, one by one
            node = self._remember(v, {"$": "oa", "s": list(v.shape), "i": []})
            node["i"] = [self.encode(x) for x in v.ravel()]
            return node
        return self._remember(v, {"$": "a", "a": self._array(v)})

    def _filled(self, v, tag: str, items) -> dict:  # remembered before its items: they may refer back to it
        node = self._remember(v, {"$": tag, "i": []})
        node["i"] = items()
        return node

    def _other(self, v):
        """A numpy scalar, an object met before, a module's noting values (a dict subclass) or an object."""
        if isinstance(v, np.generic):
            return {"$": "n", "a": self._array(np.asarray(v))}
        ref = self.memo.get(id(v))
        if ref is not None:
            return {"$": "r", "r": ref}
        if getattr(type(v), "plain_as_dict", False) and isinstance(v, dict):  # a module's noting values
            return _BY_TYPE[dict](self, v)
        return self._object(v)

    def _remember(self, v, node: dict) -> dict:
        node["id"] = self.memo[id(v)] = len(self.memo)
        self.keep.append(v)
        return node

    def _array(self, a: np.ndarray) -> int:
        dtype = _plain_dtype(a.dtype)
        self.specs.append([dtype, list(a.shape)] + ([] if a.flags.writeable else ["read-only"]))
        self.chunks.append(a.tobytes())  # C order, whatever the array's own layout
        return len(self.specs) - 1

    def _object(self, v):
        cls = type(v)
        known = self.classes.get(cls) or self.classes.setdefault(cls, self._class(cls))
        if isinstance(known, NotPlainData):
            raise known
        name, slots, transient = known  # transient: caches, not stored, decoded empty
        fields = dict(vars(v)) if hasattr(v, "__dict__") else {}
        fields.update((slot, getattr(v, slot)) for slot in slots if hasattr(v, slot))
        fields = {k: x for k, x in fields.items() if k not in transient}  # caches, cached_property values: not data
        if not fields and not hasattr(v, "__dict__"):
            raise NotPlainData(f"an object without fields, {name.replace(':', '.')}")
        node = self._remember(v, {"$": "o", "c": name, "f": []})
        node["f"] = [[field, self.encode(x)] for field, x in fields.items()]
        return node

    def _class(self, cls: type):
        """(stored name, slot names, cache fields) of instances of ``cls``, or the NotPlainData they raise."""
        module = getattr(cls, "__module__", "") or ""
        if module.split(".")[0] not in self.packages or issubclass(cls, (type, BaseException)):
            return NotPlainData(f"an object of type {module}.{cls.__qualname__}")
        derived = {n for k in cls.__mro__ for n, a in vars(k).items() if isinstance(a, functools.cached_property)}
        return f"{module}:{cls.__qualname__}", slot_names(cls), derived.union(getattr(cls, "plain_transient", ()))


_AS_IS, _INF = frozenset({type(None), bool, str, int}), float("inf")
_SHARED = frozenset({np.ndarray, list, dict})
_BY_TYPE = {
    float: lambda enc, v: {"$": "f", "v": repr(v)} if v != v or v in (_INF, -_INF) else v,
    complex: lambda enc, v: {"$": "c", "v": [repr(v.real), repr(v.imag)]},
    tuple: lambda enc, v: {"$": "t", "i": [enc.encode(x) for x in v]},
    set: lambda enc, v: {"$": "s", "i": [enc.encode(x) for x in v]},
    frozenset: lambda enc, v: {"$": "fs", "i": [enc.encode(x) for x in v]},
    dt.datetime: lambda enc, v: {"$": "dt", "v": v.isoformat()},
    dt.date: lambda enc, v: {"$": "date", "v": v.isoformat()},
    dt.timedelta: lambda enc, v: {"$": "td", "v": [v.days, v.seconds, v.microseconds]},
    MappingProxyType: lambda enc, v: {"$": "mp", "i": [[enc.encode(k), enc.encode(x)] for k, x in v.items()]},
    np.ndarray: _Encoder._ndarray,
    list: lambda enc, v: enc._filled(v, "l", lambda: [enc.encode(x) for x in v]),
    dict: lambda enc, v: enc._filled(v, "d", lambda: [[enc.encode(k), enc.encode(x)] for k, x in v.items()]),
}  # the node of a value of exactly this type; any other type (a subclass included): _Encoder._other


@functools.lru_cache(maxsize=64)
def _plain_dtype(dtype: np.dtype) -> str:
    """``dtype.str`` of a stored dtype (``ARRAY_KINDS``, not structured, not a sub-array); else NotPlainData."""
    if dtype.kind not in ARRAY_KINDS or dtype.fields is not None or dtype.subdtype is not None:
        raise NotPlainData(f"an array of dtype {dtype}")
    return dtype.str


def slot_names(cls: type) -> tuple:
    """The ``__slots__`` of ``cls`` and its bases (without ``__dict__`` and ``__weakref__``)."""
    names = []
    for klass in cls.__mro__:
        slots = klass.__dict__.get("__slots__", ())
        for name in (slots,) if isinstance(slots, str) else slots:
            if name not in ("__dict__", "__weakref__") and not name.startswith("__") and name not in names:
                names.append(name)
    return tuple(names)


# ---------------------------------------------------------------------------------------------- decoding
def decode(header: bytes, payload: bytes, packages: frozenset):
    """The value encoded by ``encode``; raises BadPlainData if anything does not check out. Builds no
    object other than plain data and instances of classes already defined in ``packages``."""
    try:
        doc = json.loads(header.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise BadPlainData(f"the record header is not JSON ({type(exc).__name__})") from exc
    if not isinstance(doc, dict) or set(doc) != {"tree", "arrays"} or not isinstance(doc["arrays"], list):
        raise BadPlainData("the record header does not have the expected fields")
    arrays = _arrays(doc["arrays"], payload)
    try:
        return _Decoder(arrays, packages).decode(doc["tree"])
    except RecursionError as exc:
        raise BadPlainData("the record is nested too deeply") from exc
    except BadPlainData:
        raise
    except Exception as exc:  # e.g. hashing a decoded object that lacks a field, to put it in a set
        raise BadPlainData(f"the record does not decode ({type(exc).__name__})") from exc


MAX_DIMENSIONS = 32
"""Dimensions of a stored array (numpy allows 64; e2esim's arrays have at most 4)."""


def _arrays(specs: list, payload: bytes) -> list:
    buffer = bytearray(payload)  # writeable arrays, like the ones that were stored
    out, pos = [], 0
    for spec in specs:
        if not (isinstance(spec, list) and len(spec) in (2, 3) and isinstance(spec[0], str) and len(spec[0]) <= 40
                and isinstance(spec[1], list) and len(spec[1]) <= MAX_DIMENSIONS
                and all(type(n) is int and 0 <= n < 2**62 for n in spec[1]) and spec[2:] in ([], ["read-only"])):
            raise BadPlainData("an array description is malformed")
        try:
            dtype = np.dtype(spec[0])
        except (TypeError, ValueError) as exc:
            raise BadPlainData(f"unknown array dtype {spec[0][:40]!r}") from exc
        if dtype.kind not in ARRAY_KINDS or dtype.fields is not None or dtype.subdtype is not None \
                or dtype.itemsize == 0:
            raise BadPlainData(f"array dtype {spec[0][:40]!r} is not plain data")
        count = 1
        for n in spec[1]:
            count *= n
        size = count * dtype.itemsize
        if pos + size > len(buffer):
            raise BadPlainData("the arrays are longer than the record")
        if max(spec[1], default=1) * dtype.itemsize > 2**62:
            raise BadPlainData("an array's shape is too large")
        try:
            array = (np.frombuffer(buffer, dtype, count, pos) if count else np.zeros(0, dtype)).reshape(spec[1])
        except (ValueError, TypeError, MemoryError) as exc:
            raise BadPlainData(f"an array of shape {spec[1]} does not fit its record") from exc
        array.flags.writeable = not spec[2:]  # as it was stored: read-only arrays stay read-only
        out.append(array)
        pos += size
    if pos != len(buffer):
        raise BadPlainData("the record holds bytes that belong to no array")
    return out


class _Decoder:
    def __init__(self, arrays: list, packages: frozenset):
        self.arrays = arrays
        self.packages = packages
        self.memo: dict = {}

    def decode(self, node):
        if node is None or type(node) in (bool, str, int, float):
            return node
        if type(node) is not dict or not isinstance(node.get("$"), str):
            raise BadPlainData("an encoded value is malformed")
        tag = node["$"]
        handler = getattr(self, "_" + tag, None) if re.fullmatch(r"[a-z]+", tag) else None
        if handler is None:
            raise BadPlainData(f"unknown value tag {tag[:20]!r}")
        try:
            return handler(node)
        except (KeyError, TypeError, ValueError, IndexError, OverflowError) as exc:
            if isinstance(exc, BadPlainData):
                raise
            raise BadPlainData(f"a value tagged {tag!r} is malformed ({type(exc).__name__})") from exc

    def _items(self, node) -> list:
        items = node["i"]
        if type(items) is not list:
            raise BadPlainData("a collection is malformed")
        return items

    def _register(self, node, value):
        ref = node["id"]
        if type(ref) is not int or ref in self.memo:
            raise BadPlainData("a reference number is malformed or repeated")
        self.memo[ref] = value
        return value

    def _f(self, node):
        return float(node["v"]) if node["v"] in ("nan", "inf", "-inf") else _bad("a special float")

    def _c(self, node):
        re_, im = node["v"]
        return complex(float(re_), float(im))

    def _n(self, node):
        return self.arrays[node["a"]][()]

    def _a(self, node):
        return self._register(node, self.arrays[node["a"]])

    def _oa(self, node):
        shape, items = node["s"], self._items(node)
        if type(shape) is not list or len(shape) > MAX_DIMENSIONS or not all(type(n) is int and n >= 0 for n in shape):
            raise BadPlainData("the shape of an array of values is malformed")
        count = 1
        for n in shape:
            count *= n
        if count != len(items):  # checked before anything is allocated: the shape may claim terabytes
            raise BadPlainData("an array of values has the wrong number of items")
        out = self._register(node, np.empty(shape, dtype=object))
        items = [self.decode(x) for x in items]
        flat = out.ravel()
        for k, item in enumerate(items):  # one by one: numpy would read tuples as rows
            flat[k] = item
        return out

    def _t(self, node):
        return tuple(self.decode(x) for x in self._items(node))

    def _s(self, node):
        return {self.decode(x) for x in self._items(node)}

    def _fs(self, node):
        return frozenset(self.decode(x) for x in self._items(node))

    def _dt(self, node):
        return dt.datetime.fromisoformat(node["v"])

    def _date(self, node):
        return dt.date.fromisoformat(node["v"])

    def _td(self, node):
        days, seconds, micro = node["v"]
        return dt.timedelta(days=days, seconds=seconds, microseconds=micro)

    def _r(self, node):
        try:
            return self.memo[node["r"]]
        except (KeyError, TypeError) as exc:
            raise BadPlainData("a reference to nothing") from exc

    def _l(self, node):
        out = self._register(node, [])
        out.extend(self.decode(x) for x in self._items(node))
        return out

    def _d(self, node):
        out = self._register(node, {})
        for pair in self._items(node):
            if type(pair) is not list or len(pair) != 2:
                raise BadPlainData("a mapping entry is malformed")
            out[self.decode(pair[0])] = self.decode(pair[1])
        return out

    def _mp(self, node):
        out = {}
        for pair in self._items(node):
            if type(pair) is not list or len(pair) != 2:
                raise BadPlainData("a mapping entry is malformed")
            out[self.decode(pair[0])] = self.decode(pair[1])
        return MappingProxyType(out)

    def _o(self, node):
        cls = self._class(node["c"])
        obj = object.__new__(cls)  # no __init__, no __post_init__: nothing of the class runs
        self._register(node, obj)
        slots = slot_names(cls)
        for pair in node["f"]:
            if type(pair) is not list or len(pair) != 2 or not isinstance(pair[0], str) or not _NAME.match(pair[0]):
                raise BadPlainData("an object field is malformed")
            name, value = pair[0], self.decode(pair[1])
            if name in slots:
                object.__setattr__(obj, name, value)  # the slot's own descriptor: no code of the class
            elif hasattr(obj, "__dict__"):
                obj.__dict__[name] = value
            else:
                raise BadPlainData(f"{node['c'][:80]!r} has no field {name!r}")
        for name in getattr(cls, "plain_transient", ()):  # a cache the encoder left out: empty again
            if hasattr(obj, "__dict__"):
                obj.__dict__.setdefault(name, {})
        return obj

    def _class(self, path) -> type:
        m = _CLASS.match(path) if isinstance(path, str) else None
        if m is None:
            raise BadPlainData("a class name is malformed")
        module_name, qualname = m.groups()
        if module_name.split(".")[0] not in self.packages:
            raise BadPlainData(f"class {path[:80]!r} is not of e2esim or a registered plug-in")
        module = sys.modules.get(module_name)  # plug-ins: only classes already defined, never an import
        if module is None and module_name.startswith("e2esim."):
            module = _import_own(module_name)  # e2esim's own code, found through the e2esim package
        if module is None:
            raise BadPlainData(f"class {path[:80]!r} is not loaded")
        cls = module
        for part in qualname.split("."):
            cls = getattr(cls, part, None)
        if not isinstance(cls, type) or cls.__module__ != module_name or issubclass(cls, (BaseException, type)):
            raise BadPlainData(f"{path[:80]!r} is not a class of its module")
        return cls


def _import_own(module_name: str):
    import importlib

    try:
        return importlib.import_module(module_name)
    except ImportError:
        return None


def _bad(what: str):
    raise BadPlainData(f"{what} is malformed")
