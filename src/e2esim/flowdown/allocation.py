"""Allocation from the top (issue 23, item 6): a requirement's total flowed down to a specification of every source.

The sources are scenario keys (``{source: key}``: the scenario's ``allocate.sources``, or ``--source``), each with
a search range whose better end switches the source off (its ``off`` value: the end with the larger margin). The
checked value of an RMSE or a bound combines independent sources in quadrature, so the split is of its square:

1. the floor ``F_i`` of case i: the checked value with every allocated source off (what the other sources of the
   chain leave); the room ``B_i = limit^2 - F_i^2``;
2. fixed sources (``--fix KEY=VALUE``) take what they use, ``value(that source alone)^2 - F_i^2``; the rest of
   ``B_i`` is split equally, or by ``--weight`` (shares ``s_k = w_k / sum w``);
3. each source's specification is the key's value where the checked value with that source alone reaches
   ``sqrt(F_i^2 + s_k (B_i - fixed use))`` in case i, the strictest over every case (``e2esim.flowdown.brent``
   on the engine's forward model);
4. the specification is checked back: every case with every source at its specification, through the forward
   model; ``holds`` says whether every case meets the requirement, and the margins are reported. Where sources
   interact (or a quantile does not add in quadrature) the check says so; it is never assumed.

``allocation_percent`` (each source's allocated part of the checked value, ``sqrt(b_k)`` with ``b_k`` its share of
the room in the case of the largest floor, in the requirement's unit) and ``allocation_share`` (``b_k / limit^2``,
the floor the rest) are written next to the specification, as the
keys a requirement carries for its allocation table (issue 23, item 2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import yaml

from e2esim.api import load_scenario
from e2esim.errors import UserError
from e2esim.flowdown.brent import brent
from e2esim.flowdown.evaluate import Evaluator
from e2esim.flowdown.keys import bounds_of, solve_key

SPLITS = ("equal", "weighted")


@dataclass
class AllocationResult:
    """requirement : its name; limit : the total (its unit); floor : the checked value with every source off;
    sources, keys : per source; budget, allocated : its variance share and its value (``sqrt``); specification :
    the key's value (NaN: no value meets its share); fixed : sources held at a given value; binding : the case that
    sets each specification; margins : every case's margin with every source at its specification; holds : all
    of them >= 0."""

    requirement: str
    number: int
    limit: float
    unit: str
    split: str
    floor: float
    sources: list
    keys: list
    budget: np.ndarray
    allocated: np.ndarray
    specification: np.ndarray
    fixed: dict
    binding: list
    labels: list
    margins: np.ndarray
    holds: bool


def _sources(raw_allocate: dict, given) -> dict:
    sources = given if given else (raw_allocate or {}).get("sources")
    if not sources or not isinstance(sources, dict):
        raise UserError("allocate: name the sources and their keys (--source SOURCE=KEY, or the scenario's "
                        "'allocate: {sources: {crosstalk: calibration.0.crosstalk_db, ...}}')")
    return {str(s): (k if isinstance(k, dict) else {"key": k}) for s, k in sources.items()}


def allocate(scenario, requirement: int = 1, split: str = "equal", weights: dict | None = None,
             fixed: dict | None = None, sources: dict | None = None, set: dict | None = None) -> AllocationResult:
    """Flow requirement ``requirement`` (1 the first) down to the ``sources`` (``{source: key}`` or
    ``{source: {key: KEY, bounds: [LO, HI]}}``; default: the scenario's ``allocate.sources``)."""
    loaded = load_scenario(scenario, set)
    stated = loaded.raw.get("allocate") or {}
    specs = _sources(stated, sources)
    weights = {**stated.get("weights", {}), **(weights or {})}
    fixed = {**stated.get("fix", {}), **(fixed or {})}
    if split not in SPLITS:
        raise UserError(f"--split {split!r}: expected one of {', '.join(SPLITS)}")
    resolved = loaded.resolve()
    names = list(specs)
    keys = [solve_key(resolved, specs[s]["key"], "--source") for s in names]
    by_key = {k.name: s for s, k in zip(names, keys)}
    for key in fixed:
        if key not in by_key:
            raise UserError(f"--fix {key}: not the key of a source ({', '.join(by_key)})")
    if split == "weighted":
        unknown = [w for w in weights if w not in specs]
        if unknown or not weights:
            raise UserError(f"--weight {', '.join(unknown) or '(none)'}: give a weight for sources among "
                            f"{', '.join(names)}")
    ranges = [bounds_of(k, specs[s].get("bounds")) for s, k in zip(names, keys)]
    evaluator = Evaluator(loaded, resolved, tuple(keys))
    n, count = evaluator.n, len(keys)
    j = requirement - 1
    if not 0 <= j < len(evaluator.names):
        raise UserError(f"--requirement {requirement}: the scenario has {len(evaluator.names)} requirement(s)")
    current = np.array([[float(_current(loaded.raw, k.name, r)) for k, r in zip(keys, ranges)]])
    ends = evaluator.grid_margins(np.concatenate([_with(current, i, r[e]) for i, r in enumerate(ranges)
                                                  for e in (0, 1)]))[j]  # (n, 2 K)
    off = np.array([r[0] if np.nanmin(ends[:, 2 * i]) >= np.nanmin(ends[:, 2 * i + 1]) else r[1]
                    for i, r in enumerate(ranges)])
    limit, unit, value_of = _requirement(evaluator, off, j)
    floor_values = value_of(np.arange(n), np.repeat(off[None], n, 0))
    floor = float(np.nanmax(floor_values))
    room = limit**2 - floor_values**2  # per case: what the allocated sources may add to the checked value squared
    if not np.nanmin(room) > 0:
        raise UserError(f"allocate: requirement {requirement} fails with every source off (checked value "
                        f"{floor:.4g} {unit} against {limit:.4g}): nothing is left to allocate")
    used = np.zeros((count, n))
    for key, v in fixed.items():
        i = [k.name for k in keys].index(key)
        point = off.copy()
        point[i] = v
        used[i] = np.maximum(value_of(np.arange(n), np.repeat(point[None], n, 0)) ** 2 - floor_values**2, 0.0)
    free = [i for i, k in enumerate(keys) if k.name not in fixed]
    left = room - used.sum(0)
    if free and not np.nanmin(left) > 0:
        raise UserError("allocate: the fixed sources use the whole budget; nothing is left for the others")
    w = np.array([weights.get(names[i], 1.0) if split == "weighted" else 1.0 for i in free], dtype=float)
    shares = np.zeros(count)
    shares[free] = w / w.sum()
    worst = int(np.nanargmax(floor_values))
    budget = used[:, worst] + shares * left[worst]  # as the case with the largest floor has it
    spec = off.copy()
    binding = [""] * count
    for i, v in fixed.items():
        spec[[k.name for k in keys].index(i)] = v
    for i in free:
        target = np.sqrt(floor_values**2 + shares[i] * left)  # per case: its floor plus the source's share
        spec[i], binding[i] = _specification(evaluator, value_of, off, i, ranges[i], target)
    check = evaluator.grid_margins(spec[None])[j, :, 0]
    ok = np.isfinite(spec).all() and bool(np.all(check[np.isfinite(check)] >= -1e-9))
    return AllocationResult(evaluator.names[j], requirement, limit, unit, split, floor, names, [k.name for k in keys],
                            budget, np.sqrt(budget), spec, dict(fixed), binding, evaluator.labels, check, ok)


def _with(current, i, v):
    point = current.copy()
    point[0, i] = v
    return point


def _current(raw, key, bounds):
    node = raw
    for part in key.split("."):
        try:
            node = node[int(part)] if isinstance(node, list) else node[part]
        except (KeyError, IndexError, ValueError, TypeError):
            return bounds[0]
    return node if isinstance(node, (int, float)) and not isinstance(node, bool) else bounds[0]


def _requirement(evaluator, off, j):
    """(limit, unit, value_of): value_of(cases, points) is the checked value (limit - margin) of requirement j."""
    limit = float(evaluator.limit(j))
    unit = evaluator.unit(j)

    def value_of(cases, points):
        return limit - evaluator.margins(cases, points)[j]
    return limit, unit, value_of


def _specification(evaluator, value_of, off, i, bounds, target):
    """The value of source i's key (the others off) where the checked value reaches ``target`` (per case) in the
    strictest case, and that case's label (NaN, "" when no value of the range keeps it within the target)."""
    n = evaluator.n
    lo, hi = bounds
    cases = np.arange(n)

    def points(x):
        p = np.repeat(off[None], len(x), 0)
        p[:, i] = x
        return p
    g_lo = target - value_of(cases, points(np.full(n, lo)))
    g_hi = target - value_of(cases, points(np.full(n, hi)))
    bracket = np.flatnonzero((np.sign(g_lo) != np.sign(g_hi)) & np.isfinite(g_lo) & np.isfinite(g_hi))
    if np.any((g_lo < 0) & (g_hi < 0)):
        return math.nan, evaluator.labels[int(np.flatnonzero((g_lo < 0) & (g_hi < 0))[0])]
    if bracket.size == 0:
        return (hi if g_hi[0] >= 0 and off[i] == lo else lo), ""

    def f(active, x):
        return target[bracket[active]] - value_of(bracket[active], points(x))
    roots, _ = brent(f, np.full(bracket.size, lo), np.full(bracket.size, hi), g_lo[bracket], g_hi[bracket],
                     1e-6 * (hi - lo))
    strict = np.argmin(roots) if off[i] == lo else np.argmax(roots)
    return float(roots[strict]), evaluator.labels[int(bracket[strict])]


def allocation_markdown(name: str, result: AllocationResult) -> str:
    """The specification table: the answer first (does it hold), then per source its allocation and specification."""
    verdict = "holds in every case" if result.holds else "does NOT hold in every case"
    worst = float(np.nanmin(result.margins)) if np.isfinite(result.margins).any() else math.nan
    lines = [f"# {name}: allocation of requirement {result.number}", "",
             f"{result.requirement}: {result.split} split of {result.limit:.4g} {result.unit} over "
             f"{len(result.sources)} source(s); checked back over {len(result.labels)} case(s): the specification "
             f"{verdict} (smallest margin {worst:.3g} {result.unit}).", "",
             f"Floor (every allocated source off): {result.floor:.4g} {result.unit}.", "",
             f"| source | key | allocation ({result.unit}) | share of the total | specification | set by |",
             "|---|---|---|---|---|---|"]
    for i, source in enumerate(result.sources):
        spec = "no value meets its share" if math.isnan(result.specification[i]) else f"{result.specification[i]:.4g}"
        by = "fixed" if result.keys[i] in result.fixed else (result.binding[i] or "every case")
        lines.append(f"| {source} | {result.keys[i]} | {result.allocated[i]:.4g} | "
                     f"{result.budget[i] / result.limit**2:.3f} | {spec} | {by} |")
    lines += [f"| floor | (the rest of the chain) | {result.floor:.4g} | {result.floor**2 / result.limit**2:.3f} | "
              "| |", f"| total | | {result.limit:.4g} | 1.000 | | |", ""]
    return "\n".join(lines) + "\n"


def allocation_yaml(result: AllocationResult) -> str:
    """specification.yaml: each source key's value (dotted, as --set takes it) and the requirement's allocation
    (``allocation_percent``, ``allocation_share``: the keys of a requirement's allocation table)."""
    def number(x):
        return None if not math.isfinite(x) else round(float(x), 6)
    data = {
        "requirement": result.number,
        "name": result.requirement,
        "split": result.split,
        "holds": bool(result.holds),
        "specification": {k: number(v) for k, v in zip(result.keys, result.specification)},
        "allocation_percent": {s: number(a) for s, a in zip(result.sources, result.allocated)},
        "allocation_share": {s: number(b / result.limit**2) for s, b in zip(result.sources, result.budget)},
    }
    head = ("# e2esim allocate: the specification of every source (set each with --set KEY=VALUE, or copy it into "
            "the scenario)\n# and the allocation the requirement carries (requirements.N.allocation_percent / "
            "allocation_share)\n")
    return head + yaml.safe_dump(data, sort_keys=False)
