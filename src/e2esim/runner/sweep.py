"""Sweeps: from the ``sweep`` section of a scenario to the list of case inputs, and the case labels.

``sweep.parameters`` maps dotted keys to value lists (or ``{linspace: [start, stop, n]}``,
``{logspace: [...]}``), combined as a grid or side by side (``mode: zip``); a key "a.b, c.d" varies several
keys together. ``sweep.cases`` lists the cases explicitly. ``sweep.map`` sweeps the forest cells of a
latitude-longitude grid over months, passes and solar levels (e2esim.runner.map_sweep).
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

from e2esim.errors import ConfigError, Location
from e2esim.params import Param, unknown_key_error, validate_section
from e2esim.runner.limits import MAX_CASES, SPLIT_ADVICE, check_count, shorten

SWEEP_PARAMS = (
    Param("mode", "str", "grid: every combination of the parameter lists; zip: the lists side by side",
          default="grid", choices=("grid", "zip")),
)
SWEEP_KEYS = ("mode", "parameters", "cases", "map")
"""``sweep.parameters``: mapping of dotted key -> list of values, or ``{linspace: [start, stop, num]}``
or ``{logspace: [start_exp, stop_exp, num]}``; a key "a.b, c.d" with a list of [a, c] pairs varies
two keys together; ``sweep.cases``: list of mappings dotted key -> value."""


def expand_sweep(sweep: Any, where: Location, scenario: dict | None = None) -> tuple[list, tuple]:
    """Sweep section -> (list of case input dicts, sweep keys). No sweep gives one case with no inputs.
    ``scenario`` (the raw scenario) lets a map sweep check its sections and leave out cells without forest."""
    if sweep is None:
        return [{}], ()
    if not isinstance(sweep, dict):
        raise ConfigError(where, f"{shorten(repr(sweep))} is not a mapping",
                          "expected 'parameters:' and/or 'mode:', or 'cases:'")
    for key in sweep:
        if key not in SWEEP_KEYS:
            raise unknown_key_error(where.child(key), key, SWEEP_KEYS)
    if "map" in sweep:
        from e2esim.runner.map_sweep import expand_map_sweep

        if len(sweep) > 1:
            raise ConfigError(where, "has 'map' beside " + ", ".join(repr(k) for k in sweep if k != "map"),
                              "a map sweep stands alone")
        return expand_map_sweep(sweep["map"], where.child("map"), scenario)
    mode = validate_section(SWEEP_PARAMS, {k: v for k, v in sweep.items() if k == "mode"}, where)["mode"]
    params, cases = sweep.get("parameters"), sweep.get("cases")
    if params is not None and cases is not None:
        raise ConfigError(where, "has both 'parameters' and 'cases'", "give one of them")
    if cases is not None:
        if not isinstance(cases, list) or not cases:
            raise ConfigError(where.child("cases"), "is not a non-empty list", "expected a list of mappings")
        out = []
        for i, case in enumerate(cases):
            if not isinstance(case, dict):
                raise ConfigError(where.child("cases").child(i), f"{shorten(repr(case))} is not a mapping",
                                  "expected dotted.key: value pairs")
            out.append({str(k): _plain(v) for k, v in case.items()})
        keys = tuple(dict.fromkeys(k for c in out for k in c))
        return out, keys
    if not isinstance(params, dict) or not params:
        raise ConfigError(where.child("parameters"), "is missing or empty", "expected dotted.key: [values]")
    values = {}
    for key, spec in params.items():
        here = where.child("parameters").child(key)
        subkeys = tuple(k.strip() for k in str(key).split(","))
        items = _sweep_values(spec, here)
        if len(subkeys) > 1:  # "a.b, c.d": [[a1, c1], [a2, c2]] varies the keys together
            for i, item in enumerate(items):
                if not isinstance(item, list) or len(item) != len(subkeys):
                    raise ConfigError(here.child(i), f"{shorten(repr(item))} is not a list of {len(subkeys)} values",
                                      f"each item gives one value for each of {', '.join(subkeys)}")
        values[subkeys] = [tuple(item) if len(subkeys) > 1 else (item,) for item in items]
    keys = tuple(k for sub in values for k in sub)
    if mode == "zip":
        lengths = {", ".join(k): len(v) for k, v in values.items()}
        if len(set(lengths.values())) != 1:
            raise ConfigError(where.child("parameters"), f"lists of unequal length {lengths} in zip mode",
                              "give lists of the same length, or use mode: grid")
        combos = zip(*values.values())
    else:
        check_count("sweep cases", math.prod(len(v) for v in values.values()), MAX_CASES,
                    where.child("parameters").describe(), SPLIT_ADVICE)
        combos = itertools.product(*values.values())
    return [dict(zip(keys, (v for group in combo for v in group))) for combo in combos], keys


def _sweep_values(spec: Any, where: Location) -> list:
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
    labels = [", ".join(f"{names[k]}={_value_text(inputs.get(k))}" for k in shown) or "base case"
              for inputs in case_inputs]
    counts: dict = {}
    for label in labels:
        counts[label] = counts.get(label, 0) + 1
    return [f"{label} (#{i})" if counts[label] > 1 else label for i, label in enumerate(labels)]


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
