"""Read a scenario YAML file into plain Python objects, keeping the line of every key.

Differences from ``yaml.safe_load``, all in the user's favour:

* duplicate keys are an error (PyYAML silently keeps the last one, losing data);
* numbers in exponent notation without a dot (``1e5``) are numbers, not strings (a YAML 1.1 quirk);
* every mapping key path is recorded with its line number, so errors can point at the line.
"""

from __future__ import annotations

import re

import yaml

from e2esim.errors import ScenarioFileError


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


def load_yaml(text: str, source: str) -> tuple[object, dict]:
    """Parse YAML text; return (data, lines) where lines maps key-path tuples to 1-based line numbers."""
    try:
        node = yaml.compose(text, Loader=_Loader)
    except yaml.YAMLError as exc:
        raise ScenarioFileError(f"{source}: malformed YAML: {_yaml_message(exc)}") from exc
    if node is None:
        return None, {}
    lines: dict = {}
    loader = _Loader("")
    data = _construct(node, (), lines, loader, source)
    return data, lines


def _construct(node, path: tuple, lines: dict, loader, source: str):
    if isinstance(node, yaml.MappingNode):
        result = {}
        for key_node, value_node in node.value:
            key = loader.construct_object(key_node, deep=True)
            if isinstance(key, (list, dict)):
                raise ScenarioFileError(f"{source}:{key_node.start_mark.line + 1}: a key must be a plain value")
            if key in result:
                raise ScenarioFileError(
                    f"{source}:{key_node.start_mark.line + 1}: duplicate key {key!r} "
                    f"(first at line {lines.get(path + (key,), '?')}); each key may appear once"
                )
            lines[path + (key,)] = key_node.start_mark.line + 1
            result[key] = _construct(value_node, path + (key,), lines, loader, source)
        return result
    if isinstance(node, yaml.SequenceNode):
        items = []
        for i, item in enumerate(node.value):
            lines[path + (i,)] = item.start_mark.line + 1
            items.append(_construct(item, path + (i,), lines, loader, source))
        return items
    return loader.construct_object(node, deep=True)


def parse_scalar(text: str):
    """A command-line value as YAML reads it (``-28`` -> -28, ``null`` -> None, ``[1, 2]`` -> list)."""
    try:
        return yaml.load(text, Loader=_Loader)
    except yaml.YAMLError:
        return text


def _yaml_message(exc: yaml.YAMLError) -> str:
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None) or str(exc)
    if mark is not None:
        return f"line {mark.line + 1}, column {mark.column + 1}: {problem}"
    return problem
