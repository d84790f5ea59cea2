"""What a record of the resume journal must hold before a resumed run uses it.

Decoding a record (``e2esim.runner.plaindata``) builds only plain data and e2esim's own classes, but it
builds whatever the file says: a ``Column`` whose values are text, a block of three cases with verdicts for
two, a product of the wrong class or with a field missing. Such a record decodes and then crashes the run
far from the journal. So every decoded block is checked here against what the run itself makes
(``e2esim.runner.run.BlockResult``): its columns field by field (classes, dtypes, one value per case, codes
inside their tables, one ``RequirementColumns`` per requirement of the scenario), and its kept products:
per case exactly the products its chain declares, each of its declared class, and every e2esim object in
them with all the fields of its dataclass, each of the type its annotation names. A record that does not
check out makes the journal corrupt (exit status 2).
"""

from __future__ import annotations

import dataclasses
import functools
import re
import types
import typing
from collections.abc import Mapping

import numpy as np

from e2esim.block import Values
from e2esim.case import Products
from e2esim.requirements.uncertainty import AGREE, MOMENTS, SHAPE
from e2esim.runner.case_results import BlockResult
from e2esim.runner.columns import Column, RequirementColumns

CODED_DETAILS = {"basis_disagreement": (AGREE, SHAPE, MOMENTS)}
"""Verdict details that are codes (``e2esim.requirements.uncertainty``), with their values (or NaN)."""


class BadRecord(ValueError):
    """A decoded journal record that is not a finished block of this run (the message says what is wrong)."""


def check_block(block, resolved, packages: frozenset) -> None:
    """Raise ``BadRecord`` unless ``block`` is a ``BlockResult`` of the run ``resolved`` as the run makes it."""
    if type(block) is not BlockResult:
        raise BadRecord(f"it holds a {type(block).__name__}, not a block of results")
    _fields(block, "the block")
    n_cases = len(resolved.cases)
    indices = block.indices
    _array(indices, "the block's case numbers", "iu", None)
    size = len(indices)
    if size == 0 or indices.min() < 0 or indices.max() >= n_cases or len(np.unique(indices)) != size:
        raise BadRecord(f"its case numbers are not distinct cases 0 to {n_cases - 1} of this run")
    _mapping(block.scalars, "its scalars", lambda v, what: _column(v, what, size))
    requirements = block.requirements
    if type(requirements) is not list or len(requirements) != len(resolved.requirement_names):
        raise BadRecord(f"it does not hold the verdicts of the {len(resolved.requirement_names)} requirements of "
                        "this run")
    for j, columns in enumerate(requirements):
        _requirement(columns, f"the verdicts of requirement {j}", size)
    _values(block.notes, "its notes", size, _texts_tuple)
    _values(block.groups, "its source groups", size, _text_mapping)
    if block.products is not None:
        if type(block.products) is not list or len(block.products) != size:
            raise BadRecord("its products are not one set per case")
        for k, products in enumerate(block.products):
            _products(products, resolved.cases[int(indices[k])], f"the products of case {int(indices[k])}", packages)


def _requirement(columns, what: str, size: int) -> None:
    if type(columns) is not RequirementColumns:
        raise BadRecord(f"{what} are a {type(columns).__name__}, not requirement columns")
    _fields(columns, what)
    for name in ("name", "unit", "basis", "dominant", "reason", "coverage_text"):
        _values(getattr(columns, name), f"{what}: {name}", size, _text)
    for name in ("notes", "coverage"):
        _values(getattr(columns, name), f"{what}: {name}", size, _texts_tuple)
    for name in ("passed", "applicable"):
        _array(getattr(columns, name), f"{what}: {name}", "b", size)
    for name in ("value", "limit", "margin"):
        _array(getattr(columns, name), f"{what}: {name}", "f", size)
    _mapping(columns.details, f"{what}: details", lambda v, w: _column(v, w, size))
    for name, codes in CODED_DETAILS.items():
        column = columns.details.get(name)
        if column is not None and not np.all(np.isin(column.values, codes) | np.isnan(column.values)):
            raise BadRecord(f"{what}: the detail {name} holds a value other than {', '.join(map(str, codes))}")
    if columns.curves is not None:
        _values(columns.curves, f"{what}: curves", size,
                lambda v, w: _mapping(v, w, lambda a, w2: _array(a, w2, "f", None)))


def _column(column, what: str, size: int) -> None:
    if type(column) is not Column:
        raise BadRecord(f"{what} is a {type(column).__name__}, not a column of values")
    _fields(column, what)
    _array(column.values, what, "f", size)
    if column.present is not None:
        _array(column.present, f"{what} (where present)", "b", size)


def _values(column, what: str, size: int, check_item) -> None:
    if type(column) is not Values:
        raise BadRecord(f"{what} are a {type(column).__name__}, not a column of values")
    _fields(column, what)
    if type(column.values) is not list:
        raise BadRecord(f"{what}: the distinct values are not a list")
    _array(column.index, f"{what} (codes)", "iu", size)
    if size and (column.index.min() < 0 or column.index.max() >= len(column.values)):
        raise BadRecord(f"{what}: a case's code points to no value")
    for item in column.values:
        check_item(item, what)


def _array(value, what: str, kinds: str, size: int | None) -> None:
    if type(value) is not np.ndarray or value.dtype.kind not in kinds or value.ndim != 1 or \
            (size is not None and len(value) != size):
        shown = f"{value.dtype} array of shape {value.shape}" if isinstance(value, np.ndarray) else type(value).__name__
        length = f" of {size} values" if size is not None else ""
        raise BadRecord(f"{what} is a {shown}, not a one-dimensional array{length} ({_KINDS[kinds]})")


_KINDS = {"f": "floating-point", "b": "booleans", "iu": "integers"}


def _mapping(value, what: str, check_item) -> None:
    """A dict of names (the names of output datasets: text, not empty, without "/" or control characters)."""
    if type(value) is not dict or not all(type(k) is str and _NAME.fullmatch(k) for k in value):
        raise BadRecord(f"{what} are not a mapping of names")
    for key, item in value.items():
        check_item(item, f"{what}: {key[:60]}")


_NAME = re.compile(r"(?!\.{1,2}\Z)[^/\x00-\x1f\x7f]{1,200}")


def _text(value, what: str) -> None:
    if not isinstance(value, str):
        raise BadRecord(f"{what} holds a {type(value).__name__} where text belongs")


def _texts_tuple(value, what: str) -> None:
    if type(value) is not tuple or not all(isinstance(v, str) for v in value):
        raise BadRecord(f"{what} holds a {type(value).__name__} where a tuple of text belongs")


def _text_mapping(value, what: str) -> None:
    _mapping(value, what, _text)


# Products --------------------------------------------------------------------------------------------------
def _products(products, spec, what: str, packages: frozenset) -> None:
    """Exactly the products the case's chain declares, in its order, each of its class, each object in them
    complete and typed as annotated."""
    values = getattr(products, "_values", None)  # a decoded record may leave the slot unset
    if type(products) is not Products or type(values) is not types.MappingProxyType:
        raise BadRecord(f"{what} are a {type(products).__name__}, not products")
    declared = [p for stage in spec.chain for p in stage.provides]
    if list(products) != [p.name for p in declared]:
        raise BadRecord(f"{what} are not those the case's chain makes")
    for product in declared:
        try:
            product.check(products[product.name], "the journal")
        except TypeError as exc:
            raise BadRecord(f"{what}: {exc}") from None
    _objects(values, what, packages)


def _objects(root, what: str, packages: frozenset) -> None:
    """Check every e2esim (or plug-in) object reachable from ``root``: each dataclass field present and of the
    type its annotation names. Iterative, each object once: a record's graph may be deep or cyclic."""
    stack, seen = [(root, what)], set()
    while stack:
        value, where = stack.pop()
        if id(value) in seen or value is None or isinstance(value, (str, bytes, int, float, complex, np.generic)):
            continue
        seen.add(id(value))
        if isinstance(value, (list, tuple, set, frozenset)):
            stack += [(x, where) for x in value]
        elif isinstance(value, Mapping) and type(value).__module__ in ("builtins", "mappingproxy"):
            stack += [(x, where) for pair in value.items() for x in pair]
        elif isinstance(value, np.ndarray):
            if value.dtype.kind == "O":
                stack += [(x, where) for x in value.flat]
        elif _package(value) in packages:
            stack += [(x, f"{where}: {type(value).__name__}") for x in _object_fields(value, where, packages)]


def _package(value) -> str:
    return (getattr(type(value), "__module__", "") or "").split(".")[0]


def _object_fields(obj, where: str, packages: frozenset) -> list:
    """The field values of ``obj``; a dataclass must have every field, and one of e2esim (whose annotations the
    tests hold to every shipped scenario) each of its annotated type. Where the annotation names a class, any
    object of e2esim or a plug-in passes: e2esim's code works by interface there (a ``LogErrorMap`` serves
    where a ``RelativeErrorMap`` is annotated)."""
    cls = type(obj)
    own = dict(vars(obj)) if hasattr(obj, "__dict__") else {}
    for name in _slots(cls):
        if name not in own and _has_slot(obj, name):
            own[name] = object.__getattribute__(obj, name)
    if dataclasses.is_dataclass(cls):
        hints = _hints(cls) if cls.__module__.startswith("e2esim.") else {}
        for field in dataclasses.fields(cls):
            if field.name not in own:
                raise BadRecord(f"{where}: a {cls.__name__} without its field {field.name}")
            hint = hints.get(field.name)
            value = own[field.name]
            if hint is not None and not _matches(value, hint, _package(value) in packages):
                raise BadRecord(f"{where}: the field {field.name} of a {cls.__name__} is a "
                                f"{type(value).__name__}, not {_hint_name(hint)}")
    return list(own.values())


def _slots(cls) -> tuple:
    from e2esim.runner.plaindata import slot_names

    return slot_names(cls)


def _has_slot(obj, name: str) -> bool:
    try:
        object.__getattribute__(obj, name)
    except AttributeError:
        return False
    return True


@functools.cache
def _hints(cls) -> dict:
    try:
        return typing.get_type_hints(cls)
    except Exception:  # an annotation that does not resolve: that class's fields are not type-checked
        return {}


_NUMBER = (int, float, np.integer, np.floating)
_SIMPLE = {
    float: lambda v: isinstance(v, _NUMBER) or _scalar_array(v, "biuf"),
    int: lambda v: isinstance(v, (int, np.integer)) or _scalar_array(v, "biu"),
    complex: lambda v: isinstance(v, (*_NUMBER, complex, np.complexfloating)) or _scalar_array(v, "biufc"),
    bool: lambda v: isinstance(v, (bool, np.bool_)),
    str: lambda v: isinstance(v, str),
    np.ndarray: lambda v: isinstance(v, (np.ndarray, np.generic, int, float, complex)),
}


def _scalar_array(value, kinds: str) -> bool:
    return isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in kinds


def _matches(value, hint, own_object: bool) -> bool:
    """Whether ``value`` is of the annotated type ``hint`` (forms the checker does not know pass; so does an
    object of e2esim or a plug-in, ``own_object``, where the annotation names another class)."""
    if hint is typing.Any or hint is object:
        return True
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        return any(_matches(value, arg, own_object) for arg in typing.get_args(hint))
    if origin is typing.ClassVar:
        return True
    if origin is not None:
        hint = origin
    if hint is type(None):
        return value is None
    if hint in _SIMPLE:
        return _SIMPLE[hint](value)
    if isinstance(hint, type):
        try:
            return isinstance(value, hint) or (own_object and hint.__module__ != "builtins")
        except TypeError:  # a protocol that cannot be checked at run time
            return True
    return True


def _hint_name(hint) -> str:
    return getattr(hint, "__name__", None) or str(hint).replace("typing.", "")


def _fields(obj, what: str) -> None:
    """Every dataclass field of ``obj`` present (a record may leave some out)."""
    missing = [f.name for f in dataclasses.fields(obj) if f.name not in vars(obj)]
    if missing:
        raise BadRecord(f"{what} lack their field {missing[0]}")


__all__ = ["BadRecord", "check_block"]
