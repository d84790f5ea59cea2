"""Command-line changes to a scenario: ``--set KEY=VALUE`` and ``--replace-sweep KEY=VALUE``.

``e2esim run`` and ``e2esim validate`` apply them in the same way (``Scenario.load``), so a value that
validates is the value that runs. The rule for keys that a sweep sets:

* ``--set KEY=VALUE`` on a key that the sweep also sets (or on a section that contains it, or below it)
  is an error: the sweep would replace the value in every case, so it would be silently ignored.
* ``--set sweep.parameters.KEY=[values]`` replaces the list of values swept over KEY (everything after
  ``sweep.parameters.`` is the one dotted sweep key), ``--set sweep.cases.I.KEY=VALUE`` changes KEY in
  case I of an explicit case list.
* ``--replace-sweep KEY=VALUE`` takes KEY out of the sweep and gives it VALUE in every case.

Key paths (``value_at``, ``set_path``, ``dotted_path``) are shared with the sweep's plan
(``e2esim.runner.plan_builder``).
"""

from __future__ import annotations

import copy
from typing import Any

from e2esim.errors import ConfigError, Location
from e2esim.key_paths import override_path
from e2esim.limits import shorten
from e2esim.runner.yaml_loader import parse_scalar

EXAMPLE = "expected e.g. --set instrument.crosstalk.level_db=-28"


def split_assignment(assignment: str, flag: str, where: Location) -> tuple[str, str, tuple]:
    """``"a.b=1"`` -> ("a.b", "1", ("a", "b")); the key path of a sweep entry keeps its dotted key whole."""
    key, sep, text = str(assignment).partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError(where, f"{flag} {shorten(repr(assignment))} is not key=value",
                          EXAMPLE.replace("--set", flag))
    path = override_path(key)
    if any(part == "" for part in path):
        raise ConfigError(where, f"{flag} {shorten(repr(key))}: the key has an empty part",
                          "expected dotted names, e.g. instrument.crosstalk.level_db")
    return key, text, path


NOT_GIVEN = object()
"""``value_at`` of a key path the scenario does not set."""


def value_at(data, path: tuple):
    """The value at ``path`` in a scenario's raw data, or ``NOT_GIVEN``."""
    node = data
    for key in path:
        if isinstance(node, dict) and key in node:
            node = node[key]
        elif isinstance(node, list) and isinstance(key, int) and 0 <= key < len(node):
            node = node[key]
        else:
            return NOT_GIVEN
    return node


def parse_value(text: str, flag: str, key: str):
    """The value of an override, read as YAML with the scenario's rules and limits."""
    return parse_scalar(text, f"{flag} {shorten(key)}")


def swept_keys(sweep) -> dict:
    """Dotted keys that ``sweep`` sets -> where (``sweep.parameters`` or ``sweep.cases``); no expansion."""
    out: dict = {}
    if not isinstance(sweep, dict):
        return out
    if isinstance(sweep.get("map"), dict):
        from e2esim.maps.grid import MAP_KEYS

        out.update(dict.fromkeys(MAP_KEYS, "sweep.map"))
    params, cases = sweep.get("parameters"), sweep.get("cases")
    if isinstance(params, dict):
        for key in params:
            for sub in str(key).split(","):
                out.setdefault(sub.strip(), "sweep.parameters")
    if isinstance(cases, list):
        for case in cases:
            if isinstance(case, dict):
                for key in case:
                    out.setdefault(str(key), "sweep.cases")
    return out


def check_not_swept(raw: dict, set_keys: list, source: str) -> None:
    """Refuse a ``--set`` whose key the sweep also sets (or which contains, or lies below, a swept key)."""
    swept = swept_keys(raw.get("sweep"))
    for _key, path in set_keys:
        if path[:1] == ("sweep",):
            continue
        for skey, section in swept.items():
            spath = override_path(skey)
            n = min(len(path), len(spath))
            if path[:n] == spath[:n]:
                raise ConfigError(
                    Location(f"{source} (--set)", path),
                    f"the sweep sets {skey} in its cases ({section}), so this --set would never be used",
                    f"change the sweep instead: --set {section}."
                    + {"sweep.parameters": "KEY=[values]", "sweep.map": "KEY=VALUE (its ranges, months, passes, "
                       "solar levels)"}.get(section, "I.KEY=VALUE for case I")
                    + ("" if section == "sweep.map" else
                       f", or --replace-sweep {skey}=VALUE to give it one value in every case"))


def remove_from_sweep(raw: dict, key: str, where: Location) -> None:
    """Take ``key`` out of the sweep of ``raw`` (a parameter list, a member of a group "a, b" or a key of
    every explicit case); drop the sweep when nothing is left to vary."""
    sweep = raw.get("sweep")
    swept = swept_keys(sweep)
    if key not in swept:
        hint = ", ".join(sorted(swept)) or "the scenario has no sweep"
        raise ConfigError(where, f"--replace-sweep {shorten(key)}: the sweep does not set this key",
                          f"swept keys: {hint}; use --set for other keys")
    if swept[key] == "sweep.map":
        raise ConfigError(where, f"--replace-sweep {shorten(key)}: a map sweep sets it for every cell",
                          "narrow the map instead: --set sweep.map.KEY=VALUE (lat_range_deg, lon_range_deg, months, "
                          "passes, solar)")
    params, cases = sweep.get("parameters"), sweep.get("cases")
    if isinstance(params, dict):
        new: dict = {}
        for group, spec in params.items():
            names = [s.strip() for s in str(group).split(",")]
            if key not in names:
                new[group] = spec
            elif len(names) > 1:
                if not isinstance(spec, list) or not all(isinstance(i, list) and len(i) == len(names) for i in spec):
                    raise ConfigError(where.child(group), f"--replace-sweep {key}: cannot take it out of the group",
                                      f"each item must give one value for each of {', '.join(names)}")
                i = names.index(key)
                rest = [n for n in names if n != key]
                values = [[v for j, v in enumerate(item) if j != i] for item in spec]
                new[", ".join(rest)] = values if len(rest) > 1 else [v[0] for v in values]
        sweep["parameters"] = new
    if isinstance(cases, list):
        sweep["cases"] = [{k: v for k, v in c.items() if k != key} if isinstance(c, dict) else c for c in cases]
    left = swept_keys(sweep)
    if not left:
        del raw["sweep"]


def dotted_path(key: str) -> tuple:
    """Key path of a dotted sweep key: ``requirements.0.side`` -> ("requirements", 0, "side")."""
    return tuple(int(p) if p.isdigit() else p for p in key.split("."))


def set_path(data: dict, path: tuple, value: Any, where: Location, copy_on_write: bool = False) -> None:
    """Set ``data[path] = value``, creating mappings on the way; with ``copy_on_write`` every mapping or
    list on the path is replaced by a copy first, so the scenario's own objects are never changed."""
    node = data
    for i, key in enumerate(path[:-1]):
        if copy_on_write and isinstance(node, (dict, list)):
            child = node[key] if (isinstance(node, dict) and key in node) or (
                isinstance(node, list) and isinstance(key, int) and key < len(node)) else None
            if isinstance(child, (dict, list)):
                node[key] = copy.copy(child)
        if isinstance(node, list):
            if not isinstance(key, int) or key >= len(node):
                raise ConfigError(Location(where.source, path[: i + 1], where.lines), "no such list item",
                                  f"the list has {len(node)} items")
            node = node[key]
            continue
        if not isinstance(node, dict):
            raise ConfigError(Location(where.source, path[:i], where.lines), "is not a mapping",
                              "cannot set a key inside it")
        if key not in node or node[key] is None:
            node[key] = {}
        node = node[key]
    last = path[-1]
    if isinstance(node, list):
        if not isinstance(last, int) or last >= len(node):
            raise ConfigError(where, "no such list item", f"the list has {len(node)} items")
        node[last] = value
    elif isinstance(node, dict):
        node[last] = value
    else:
        raise ConfigError(Location(where.source, path[:-1], where.lines), "is not a mapping",
                          "cannot set a key inside it")
