"""Read a scenario YAML file into plain Python objects, keeping the line of every key.

Differences from ``yaml.safe_load``, all in the user's favour:

* duplicate keys are an error (PyYAML silently keeps the last one, losing data);
* numbers in exponent notation without a dot (``1e5``) are numbers, not strings (a YAML 1.1 quirk);
* every mapping key path is recorded with its line number, so errors can point at the line;
* a scenario is plain data: mappings with text keys, lists, strings, numbers, booleans and null. Tags
  other than the standard ones of those types (``!!python/name:...``, ``!!binary``, custom ``!tags``)
  are refused, and keys that YAML reads as numbers, booleans or null must be quoted;
* merge keys (``<<: *defaults``) work as in YAML 1.1: the keys of the merged mappings are added where the
  mapping does not set them itself;
* the limits of ``e2esim.limits`` hold before anything is built: file size, nesting depth and the
  number of values after aliases are expanded (so an alias bomb is refused, not expanded).
"""

from __future__ import annotations

import errno
import os
import re
import stat
from pathlib import Path

import yaml

from e2esim.errors import LimitError, ScenarioFileError
from e2esim.limits import MAX_DEPTH, MAX_DOCUMENT_BYTES, MAX_NODES, shorten


class _Loader(yaml.SafeLoader):
    pass


_FLOAT = re.compile(
    r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
    |\.[0-9_]+(?:[eE][-+][0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""",
    re.X,
)
_Loader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+0123456789."))

_FAST = getattr(yaml, "CSafeLoader", None)  # libyaml's parser when present: ten times faster
if _FAST is not None:
    class _FastLoader(_FAST):
        pass

    _FastLoader.yaml_implicit_resolvers = _Loader.yaml_implicit_resolvers
else:  # pragma: no cover - PyYAML without libyaml
    _FastLoader = None
_SCAN_LOADER = _FastLoader or _Loader
_STANDARD = "tag:yaml.org,2002:"
ALLOWED_TAGS = frozenset(_STANDARD + t for t in ("str", "int", "float", "bool", "null", "seq", "map")) | {"!"}
"""Explicit tags a scenario may use: those of plain data only."""
_MERGE = _STANDARD + "merge"
_CONSTRUCT_ERRORS = (yaml.YAMLError, ValueError, TypeError, KeyError, OverflowError)  # e.g. !!int "abc"


def read_scenario_text(path: str | Path, source: str) -> str:
    """The text of a scenario file, read with the size limit; every problem is a one-line message."""
    path = Path(path)
    try:
        info = os.stat(path)  # follows symbolic links
    except OSError as exc:
        raise ScenarioFileError(f"{source}: {_path_problem(path, exc)}") from exc
    if stat.S_ISDIR(info.st_mode):
        raise ScenarioFileError(f"{source}: is a folder, not a scenario file")
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_DOCUMENT_BYTES + 1)  # never more: /dev/zero or a huge file stop here
    except OSError as exc:
        raise ScenarioFileError(f"{source}: cannot read the scenario file: {exc.strerror or exc}") from exc
    if len(data) > MAX_DOCUMENT_BYTES:
        raise LimitError(f"{source}: the scenario file is larger than the limit of {MAX_DOCUMENT_BYTES:,} bytes; "
                         "write long value lists as {linspace: [start, stop, n]} or split the scenario")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioFileError(f"{source}: cannot read the scenario file: it is not UTF-8 text (byte "
                                f"{data[exc.start]:#04x} at offset {exc.start})") from exc


def _path_problem(path: Path, exc: OSError) -> str:
    if exc.errno == errno.ELOOP:
        return "is a symbolic link loop (the links point at each other and never reach a file)"
    if exc.errno == errno.ENOENT:
        if os.path.islink(path):
            return f"is a broken symbolic link (it points to {os.readlink(path)}, which does not exist)"
        return "no such scenario file"
    if exc.errno == errno.ENAMETOOLONG:
        return "the file name is too long"
    return f"cannot read the scenario file: {exc.strerror or exc}"


def load_yaml(text: str, source: str) -> tuple[object, dict]:
    """Parse YAML text; return (data, lines) where lines maps key-path tuples to 1-based line numbers."""
    if len(text) > MAX_DOCUMENT_BYTES:
        raise LimitError(f"{source}: the scenario is larger than the limit of {MAX_DOCUMENT_BYTES:,} characters")
    check_structure(text, source)
    node = _compose(text, source)
    if node is None:
        return None, {}
    lines: dict = {}
    data = _construct(node, (), lines, _Loader(""), source)
    return data, lines


def _compose(text: str, source: str):
    """The node tree of ``text``: libyaml's composer, and PyYAML's for the message when the text is malformed
    (it names the offending character)."""
    if _FastLoader is not None:
        try:
            return yaml.compose(text, Loader=_FastLoader)
        except yaml.YAMLError:
            pass
    try:
        return yaml.compose(text, Loader=_Loader)
    except yaml.YAMLError as exc:
        raise ScenarioFileError(f"{source}: malformed YAML: {_yaml_message(exc)}") from exc
    except ValueError as exc:  # e.g. an escape "\U..." beyond Unicode
        problem = "an escape sequence names no Unicode character" if "chr()" in str(exc) else shorten(str(exc))
        raise ScenarioFileError(f"{source}: malformed YAML: {problem}") from exc
    except RecursionError as exc:
        raise LimitError(f"{source}: mappings and lists are nested deeper than the limit of {MAX_DEPTH} levels") \
            from exc


def load_plain_yaml(text: str, source: str, max_bytes: int, max_values: int):
    """YAML text that e2esim stored (the scenario in a results.h5) as ``yaml.safe_load`` reads it, with the
    checks and limits of a scenario (``check_structure``) before anything is built."""
    if len(text) > max_bytes:
        raise LimitError(f"{source}: the text is larger than the limit of {max_bytes:,} characters")
    check_structure(text, source, max_values)
    try:
        return yaml.load(text, Loader=_FAST or yaml.SafeLoader)
    except (yaml.YAMLError, ValueError, TypeError, RecursionError) as exc:
        raise ScenarioFileError(f"{source}: malformed YAML: {shorten(_error_text(exc), 160)}") from exc


def check_structure(text: str, source: str, max_values: int = MAX_NODES) -> None:
    """Stream the YAML events once (no objects are built) and refuse, at the first offending line, a
    disallowed tag, nesting deeper than ``MAX_DEPTH``, an alias of a collection that contains it, or more
    than ``max_values`` values once aliases are expanded. Malformed YAML is left to the composer, whose
    message names the problem."""
    sizes: dict = {}  # anchor -> number of values it stands for
    stack: list = []  # open collections: [values so far, anchor]
    expanded = 0
    try:
        for event in yaml.parse(text, Loader=_SCAN_LOADER):
            if isinstance(event, (yaml.ScalarEvent, yaml.CollectionStartEvent)):
                if event.tag is not None and event.tag not in ALLOWED_TAGS:
                    raise ScenarioFileError(
                        f"{source}:{_line(event)}: the tag {shorten(event.tag)} is not allowed; a scenario is plain "
                        "data (mappings, lists, text, numbers, true/false, null), so tags that build Python "
                        "objects or custom types are refused")
            if isinstance(event, yaml.CollectionStartEvent):
                if len(stack) >= MAX_DEPTH:
                    raise LimitError(f"{source}:{_line(event)}: mappings and lists are nested deeper than the "
                                     f"limit of {MAX_DEPTH} levels")
                stack.append([1, event.anchor])  # its values are added to it as they come
                count = 1
            elif isinstance(event, yaml.CollectionEndEvent):
                count, anchor = stack.pop()
                if anchor is not None:
                    sizes[anchor] = count
                if stack:
                    stack[-1][0] += count
                continue  # already in ``expanded``, value by value
            elif isinstance(event, yaml.ScalarEvent):
                count = 1
                if event.anchor is not None:
                    sizes[event.anchor] = 1
                if stack:
                    stack[-1][0] += count
            elif isinstance(event, yaml.AliasEvent):
                if any(anchor == event.anchor for _, anchor in stack):
                    raise ScenarioFileError(f"{source}:{_line(event)}: the alias *{shorten(event.anchor)} refers to "
                                            "a mapping or list that contains it (a recursive structure)")
                count = sizes.get(event.anchor, 1)  # an undefined alias is reported by the composer
                if stack:
                    stack[-1][0] += count
            else:
                continue
            expanded += count
            if expanded > max_values:
                raise LimitError(f"{source}:{_line(event)}: the scenario holds more than the limit of {max_values:,} "
                                 "values once its YAML aliases (*name) are expanded; write long value lists as "
                                 "{linspace: [start, stop, n]}, or avoid nesting aliases in aliases")
    except (yaml.YAMLError, ValueError):
        return  # malformed: the composer says where and why


def _line(event) -> int:
    return event.start_mark.line + 1


def _construct(node, path: tuple, lines: dict, loader, source: str):
    if isinstance(node, yaml.MappingNode):
        result: dict = {}
        merged: list = []
        for key_node, value_node in node.value:
            if key_node.tag == _MERGE:
                merged.append(value_node)
                continue
            key = _scalar(key_node, loader, source)
            if not isinstance(key, str):
                raise ScenarioFileError(_key_problem(source, key_node, key, path))
            if key in result:
                raise ScenarioFileError(
                    f"{source}:{key_node.start_mark.line + 1}: duplicate key {shorten(repr(key))} "
                    f"(first at line {lines.get(path + (key,), '?')}); each key may appear once"
                )
            lines[path + (key,)] = key_node.start_mark.line + 1
            result[key] = _construct(value_node, path + (key,), lines, loader, source)
        for value_node in merged:
            _merge(result, value_node, path, lines, loader, source)
        return result
    if isinstance(node, yaml.SequenceNode):
        items = []
        for i, item in enumerate(node.value):
            lines[path + (i,)] = item.start_mark.line + 1
            items.append(_construct(item, path + (i,), lines, loader, source))
        return items
    return _scalar(node, loader, source)


def _merge(result: dict, value_node, path: tuple, lines: dict, loader, source: str) -> None:
    """``<<: *a`` or ``<<: [*a, *b]``: add the keys of the mappings that ``result`` does not have (the
    mapping's own keys win; of several merged mappings, the first that has a key gives it)."""
    sources = value_node.value if isinstance(value_node, yaml.SequenceNode) else [value_node]
    for src in sources:
        if not isinstance(src, yaml.MappingNode):
            raise ScenarioFileError(f"{source}:{src.start_mark.line + 1}: a merge key (<<) needs a mapping or a "
                                    "list of mappings, e.g. '<<: *defaults'")
        own_lines: dict = {}
        mapping = _construct(src, path, own_lines, loader, source)
        for key, value in mapping.items():
            if key not in result:
                result[key] = value
                lines.update({p: n for p, n in own_lines.items() if p[:len(path) + 1] == path + (key,)})


def _scalar(node, loader, source: str):
    try:
        return loader.construct_object(node, deep=True)
    except _CONSTRUCT_ERRORS as exc:
        value = shorten(repr(getattr(node, "value", "")))
        raise ScenarioFileError(f"{source}:{node.start_mark.line + 1}: cannot read the value {value}: "
                                f"{shorten(_error_text(exc), 160)}") from exc


def _key_problem(source: str, key_node, key, path: tuple) -> str:
    where = f"{source}:{key_node.start_mark.line + 1}"
    inside = ".".join(str(p) for p in path)
    inside = f" in {inside}" if inside else ""
    if isinstance(key, (list, dict)):
        return f"{where}: a key must be a plain value{inside}, not a mapping or list"
    return (f"{where}: the key {shorten(key_node.value)!r}{inside} is read as {type(key).__name__} "
            f"{shorten(repr(key))}; keys must be text: quote it, e.g. '{shorten(key_node.value)}':")


def parse_scalar(text: str, source: str = "--set"):
    """A command-line value as YAML reads it (``-28`` -> -28, ``null`` -> None, ``[1, 2]`` -> list), with
    the same rules and limits as a scenario file; text that is not valid YAML is taken as a string."""
    check_structure(text, source)
    try:
        node = _compose(text, source)
    except ScenarioFileError:
        return text
    if node is None:
        return None
    return _construct(node, (), {}, _Loader(""), source)


def _error_text(exc: Exception) -> str:
    if isinstance(exc, yaml.YAMLError):
        return _yaml_message(exc)
    return str(exc)


def _yaml_message(exc: yaml.YAMLError) -> str:
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None) or str(exc)
    problem = " ".join(str(problem).split())
    if mark is not None:
        return f"line {mark.line + 1}, column {mark.column + 1}: {problem}"
    return problem
