"""Sweeps: from the ``sweep`` section of a scenario to the list of case inputs, and the case labels.

``sweep.parameters`` maps dotted keys to value lists (or ``{linspace: [start, stop, n]}``,
``{logspace: [...]}``), combined as a grid or side by side (``mode: zip``); a key "a.b, c.d" varies several
keys together. ``sweep.cases`` lists the cases explicitly. ``sweep.map`` sweeps the forest cells of a
latitude-longitude grid over months, passes and solar levels (e2esim.maps.grid).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from e2esim.errors import ConfigError, Location
from e2esim.limits import MAX_CASES, SPLIT_ADVICE, check_count, shorten
from e2esim.maps.grid import map_table
from e2esim.params import Param, unknown_key_error, validate_section
from e2esim.runner.joined_labels import NO_PART, SEPARATOR, JoinedLabels, numbered

SWEEP_PARAMS = (
    Param("mode", "str", "grid: every combination of the parameter lists; zip: the lists side by side",
          default="grid", choices=("grid", "zip")),
)
SWEEP_KEYS = ("mode", "parameters", "cases", "map")
"""``sweep.parameters``: mapping of dotted key -> list of values, or ``{linspace: [start, stop, num]}``
or ``{logspace: [start_exp, stop_exp, num]}``; a key "a.b, c.d" with a list of [a, c] pairs varies
two keys together; ``sweep.cases``: list of mappings dotted key -> value."""


ABSENT = "<absent>"
"""Code text of a key a case of ``sweep.cases`` does not set (the scenario's own value applies)."""


@dataclass(frozen=True)
class KeyGroup:
    """Sweep keys varied together and their values: ``values[k]`` holds one value per key, for position k."""

    keys: tuple
    values: tuple

    @property
    def size(self) -> int:
        return len(self.values)


@dataclass(frozen=True, eq=False)
class SweepTable:
    """A sweep in factored form: groups of keys and, per case, the position of each group. Nothing is stored per
    case for a grid (case i is the C-order position ``unravel_index(i, sizes)``, the order of
    ``itertools.product``); ``zip``, ``cases`` and map sweeps keep a table of positions (n, groups).

    layout : "none" (one case, no sweep), "grid", "zip", "cases" or "map" (``e2esim.maps.grid``).
    groups : ``KeyGroup`` per parameter entry (for ``cases``, one per key, its distinct values, ``ABSENT`` where
    a case does not set it; for a map: cell, month, pass, solar level). table : the positions, None for a grid.
    """

    layout: str
    groups: tuple
    table: np.ndarray | None = None
    _distinct: dict = field(default_factory=dict, repr=False)  # sweep key -> its group's values (``column``)

    @property
    def keys(self) -> tuple:
        return tuple(k for g in self.groups for k in g.keys)

    @property
    def sizes(self) -> tuple:
        return tuple(g.size for g in self.groups)

    @property
    def n(self) -> int:
        if self.layout == "none":
            return 1
        if self.table is not None:
            return len(self.table)
        return math.prod(self.sizes)

    def codes(self, indices) -> np.ndarray:
        """(len(indices), groups) positions of every group in the cases ``indices``."""
        indices = np.asarray(indices, dtype=np.int64)
        if not self.groups:
            return np.zeros((indices.size, 0), dtype=np.int64)
        if self.table is not None:
            return self.table[indices]
        return np.stack(np.unravel_index(indices, self.sizes), axis=-1).astype(np.int64)

    def inputs(self, index: int) -> dict:
        """The sweep values of case ``index``: dotted key -> value (keys the case does not set left out)."""
        out = {}
        for group, code in zip(self.groups, self.codes([index])[0]):
            for key, value in zip(group.keys, group.values[code]):
                if value is not NOT_SET:
                    out[key] = value
        return out

    def column(self, key: str, indices) -> np.ndarray:
        """The value of sweep key ``key`` in the cases ``indices``, (len(indices),) array (None where a case of
        ``cases`` does not set it), made from the distinct values of its group."""
        g, k = next((g, group.keys.index(key)) for g, group in enumerate(self.groups) if key in group.keys)
        if key not in self._distinct:
            distinct = [None if values[k] is NOT_SET else values[k] for values in self.groups[g].values]
            self._distinct[key] = np.asarray(distinct, dtype=None if None not in distinct else object)
        return self._distinct[key][self.codes(indices)[:, g]]

    def all_inputs(self) -> list:
        return [self.inputs(i) for i in range(self.n)]

    def input_columns(self) -> dict:
        """{sweep key: list of its value in every case} (None where a case of ``cases`` does not set it), made
        per group of keys rather than per case."""
        out = {}
        for key, (distinct, codes) in self.input_codes().items():
            values = np.empty(len(distinct), dtype=object)
            for p, value in enumerate(distinct):  # one by one: a list value must stay one object
                values[p] = value
            out[key] = values[codes].tolist()
        return out

    def input_codes(self) -> dict:
        """{sweep key: (its distinct values, (n,) position of every case's value among them)}, None for a case of
        ``cases`` that does not set the key."""
        codes = self.codes(np.arange(self.n)) if self.layout != "none" else np.zeros((1, 0), dtype=np.int64)
        return {key: ([None if values[k] is NOT_SET else values[k] for values in group.values], codes[:, g])
                for g, group in enumerate(self.groups) for k, key in enumerate(group.keys)}


class _Absent:
    def __repr__(self) -> str:
        return ABSENT


NOT_SET = _Absent()
"""The value of a key a case of ``sweep.cases`` does not set (shown as ``ABSENT``)."""


def expand_sweep(sweep: Any, where: Location, scenario: dict | None = None) -> tuple[list, tuple]:
    """Sweep section -> (list of case input dicts, sweep keys). No sweep gives one case with no inputs."""
    table = sweep_table(sweep, where, scenario)
    return table.all_inputs(), table.keys


def sweep_table(sweep: Any, where: Location, scenario: dict | None = None, services=None) -> SweepTable:
    """The ``SweepTable`` of a sweep section (validated; ``ConfigError`` names the bad key). ``scenario`` (the raw
    scenario) lets a map sweep check its sections and leave out cells without forest; ``services`` (the
    resolve's ``Services``, or None) reach its stages' map hooks."""
    if sweep is None:
        return SweepTable("none", ())
    if not isinstance(sweep, dict):
        raise ConfigError(where, f"{shorten(repr(sweep))} is not a mapping",
                          "expected 'parameters:' and/or 'mode:', or 'cases:'")
    for key in sweep:
        if key not in SWEEP_KEYS:
            raise unknown_key_error(where.child(key), key, SWEEP_KEYS)
    if "map" in sweep:
        if len(sweep) > 1:
            raise ConfigError(where, "has 'map' beside " + ", ".join(repr(k) for k in sweep if k != "map"),
                              "a map sweep stands alone")
        groups, table = map_table(sweep["map"], where.child("map"), scenario, services)
        return SweepTable("map", tuple(KeyGroup(keys, values) for keys, values in groups), table)
    mode = validate_section(SWEEP_PARAMS, {k: v for k, v in sweep.items() if k == "mode"}, where)["mode"]
    params, cases = sweep.get("parameters"), sweep.get("cases")
    if params is not None and cases is not None:
        raise ConfigError(where, "has both 'parameters' and 'cases'", "give one of them")
    if cases is not None:
        return _cases_table(cases, where.child("cases"))
    if not isinstance(params, dict) or not params:
        raise ConfigError(where.child("parameters"), "is missing or empty", "expected dotted.key: [values]")
    groups = []
    for key, spec in params.items():
        here = where.child("parameters").child(key)
        subkeys = tuple(k.strip() for k in str(key).split(","))
        items = sweep_values(spec, here)
        if len(subkeys) > 1:  # "a.b, c.d": [[a1, c1], [a2, c2]] varies the keys together
            for i, item in enumerate(items):
                if not isinstance(item, list) or len(item) != len(subkeys):
                    raise ConfigError(here.child(i), f"{shorten(repr(item))} is not a list of {len(subkeys)} values",
                                      f"each item gives one value for each of {', '.join(subkeys)}")
        groups.append(KeyGroup(subkeys, tuple(tuple(item) if len(subkeys) > 1 else (item,) for item in items)))
    if mode == "zip":
        lengths = {", ".join(g.keys): g.size for g in groups}
        if len(set(lengths.values())) != 1:
            raise ConfigError(where.child("parameters"), f"lists of unequal length {lengths} in zip mode",
                              "give lists of the same length, or use mode: grid")
        n = groups[0].size
        return SweepTable("zip", tuple(groups), np.repeat(np.arange(n, dtype=np.int64)[:, None], len(groups), 1))
    check_count("sweep cases", math.prod(g.size for g in groups), MAX_CASES, where.child("parameters").describe(),
                SPLIT_ADVICE)
    return SweepTable("grid", tuple(groups))


def _cases_table(cases: Any, where: Location) -> SweepTable:
    if not isinstance(cases, list) or not cases:
        raise ConfigError(where, "is not a non-empty list", "expected a list of mappings")
    check_count("sweep cases", len(cases), MAX_CASES, where.describe(), SPLIT_ADVICE)
    rows = []
    for i, case in enumerate(cases):
        if not isinstance(case, dict):
            raise ConfigError(where.child(i), f"{shorten(repr(case))} is not a mapping",
                              "expected dotted.key: value pairs")
        rows.append({str(k): _plain(v) for k, v in case.items()})
    keys = tuple(dict.fromkeys(k for row in rows for k in row))
    groups, table = [], np.zeros((len(rows), len(keys)), dtype=np.int64)
    for g, key in enumerate(keys):
        positions: dict = {}
        values: list = []
        for i, row in enumerate(rows):
            value = row.get(key, NOT_SET)
            text = _text(value)
            if text not in positions:
                positions[text] = len(values)
                values.append((value,))
            table[i, g] = positions[text]
        groups.append(KeyGroup((key,), tuple(values)))
    return SweepTable("cases", tuple(groups), table)


def sweep_values(spec: Any, where: Location) -> list:
    if isinstance(spec, list):
        if not spec:
            raise ConfigError(where, "is an empty list", "expected at least one value")
        return [_plain(v) for v in spec]
    if isinstance(spec, dict) and len(spec) == 1:
        (kind, args), = spec.items()
        if kind in ("linspace", "logspace"):
            ok = isinstance(args, list) and len(args) == 3 and all(
                isinstance(a, (int, float)) and not isinstance(a, bool) for a in args
            )
            if not ok or not all(math.isfinite(a) for a in args) or int(args[2]) != args[2] or args[2] < 1:
                raise ConfigError(where.child(kind), f"{shorten(repr(args))} is not [start, stop, number]",
                                  "expected two finite numbers and a positive integer")
            check_count("sweep values", args[2], MAX_CASES, where.child(kind).describe(), SPLIT_ADVICE)
            fn = np.linspace if kind == "linspace" else np.logspace
            return [float(x) for x in fn(args[0], args[1], int(args[2]))]
    raise ConfigError(where, f"{shorten(repr(spec))} is not a list of values",
                      "expected a list, {linspace: [start, stop, n]} or {logspace: [start, stop, n]}")


def case_labels(case_inputs: list) -> list:
    """One short, unique label per case, naming the keys whose values differ between cases:
    ``forest=boreal_200, calibration.0.type=faraday_correction``.

    A key is shown when it varies and is not already fixed by the keys shown before it (the site's latitude
    beside its name, the biome beside the latitude it goes with); each key is named by the shortest tail of
    its dotted path that tells it from the other shown keys and is more than a list index or a generic word.
    Cases that would still share a label (a sweep that repeats a case) get their index appended.
    """
    shown = differing_keys(case_inputs)
    names = _short_names(shown)
    labels = [SEPARATOR.join(f"{names[k]}={_value_text(inputs.get(k))}" for k in shown) or NO_PART
              for inputs in case_inputs]
    counts: dict = {}
    for label in labels:
        counts[label] = counts.get(label, 0) + 1
    return [numbered(label, i) if counts[label] > 1 else label for i, label in enumerate(labels)]


class CaseLabels(Sequence):
    """The labels of a ``SweepTable``'s cases (``case_labels``), made when asked for: a grid's label is the join of
    one text per group, so nothing is stored per case."""

    def __init__(self, table: SweepTable):
        self.table = table
        if table.layout not in ("grid", "map"):
            self._labels = case_labels(table.all_inputs())
            return
        self._labels = None
        shown: list = []
        for group in table.groups:  # a grid's (a map's) groups vary independently: a key is fixed only within its group
            shown += differing_keys([dict(zip(group.keys, values)) for values in group.values])
        names = _short_names(shown)
        self._parts = [[", ".join(f"{names[k]}={_value_text(v)}" for k, v in zip(g.keys, values) if k in names)
                        for values in g.values] for g in table.groups]
        self._repeats = []
        for parts in self._parts:
            counts: dict = {}
            for part in parts:
                counts[part] = counts.get(part, 0) + 1
            self._repeats.append([counts[part] for part in parts])

    def __len__(self) -> int:
        return self.table.n

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        if self._labels is not None:
            return self._labels[index]
        index = range(len(self))[index]
        codes = self.table.codes([index])[0]
        label = SEPARATOR.join(p for p in (parts[c] for parts, c in zip(self._parts, codes)) if p) or NO_PART
        repeated = math.prod(r[c] for r, c in zip(self._repeats, codes)) > 1
        return numbered(label, index) if repeated else label

    def __eq__(self, other) -> bool:
        return isinstance(other, Sequence) and not isinstance(other, str) and list(self) == list(other)

    __hash__ = None

    def tolist(self) -> list:
        """Every label, made group by group (a million labels in about a second)."""
        return self.joined().tolist()

    def joined(self) -> JoinedLabels:
        """The labels in factored form (``JoinedLabels``: the parts of every group in one table, a code per case
        and group), as results.h5 stores them."""
        if self._labels is not None:
            return JoinedLabels.of(self._labels)
        n = len(self)
        codes = self.table.codes(np.arange(n))
        offsets = np.cumsum([0] + [len(parts) for parts in self._parts[:-1]], dtype=np.int64)
        repeats = np.ones(n, dtype=np.int64)
        for g, r in enumerate(self._repeats):
            repeats *= np.asarray(r, dtype=np.int64)[codes[:, g]]
        return JoinedLabels([p for parts in self._parts for p in parts], codes + offsets, repeats > 1)


def differing_keys(case_inputs: list) -> list:
    """The sweep keys that tell cases apart, in order: each varies and is not fixed by the keys before it."""
    keys = list(dict.fromkeys(k for inputs in case_inputs for k in inputs))
    shown: list = []
    for key in keys:
        seen: dict = {}
        for inputs in case_inputs:
            context = tuple(_text(inputs.get(k)) for k in shown)
            seen.setdefault(context, set()).add(_text(inputs.get(key)))
        if any(len(values) > 1 for values in seen.values()):
            shown.append(key)
    return shown


_GENERIC = {"type", "name", "value", "mode", "level_db", "mean_deg", "sd_deg"}
"""Last parts of dotted keys that say too little alone (``calibration.0.type``, ``crosstalk.level_db``)."""


def _short_names(keys: list) -> dict:
    def tail(key, n):
        return ".".join(key.split(".")[-n:])

    out = {}
    for key in keys:
        parts = key.split(".")
        n = 1
        while n < len(parts) and (parts[-n] in _GENERIC or parts[-n].isdigit() or parts[-n - 1].isdigit()
                                  or sum(tail(k, n) == tail(key, n) for k in keys) > 1):
            n += 1
        out[key] = tail(key, n)
    return out


def _text(value: Any) -> str:
    return repr(value)


def _value_text(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _plain(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    return value
