"""Sensitivity of each requirement's checked value to every numeric parameter of the chain (``output.sensitivity``).

For each requirement, at its worst case (smallest margin; the case that binds), the elasticity of the checked value V
with respect to every float parameter p of the chain's modules (requirements, simulation and output settings
excepted), by central finite differences through the engine: one extra run of the scenario whose sweep holds the
worst cases and, for each of them, every parameter stepped down and up (``simulation.mode: analytic``), so that the
whole table is one batched run. Common random numbers: every row of that sweep sets ``simulation.stream`` to the
stream of its worst case in the scenario's run, so each stepped case draws the same numbers as its unstepped case
(and as that case did in the run); the batched values are bit for bit those of one run per row
(``checked_values(..., batched=False)``, the reference).

* a parameter in dB (a power ratio): V per dB, E = (V+ − V−) / (2 Δ V), Δ = ``DB_STEP`` (0.5 dB);
* any other: d ln V / d ln p, E = (V+ − V−) / (V (ln(1 + h) − ln(1 − h))), h = ``RELATIVE_STEP`` (5 %).

A step outside the parameter's allowed range makes the difference one-sided (said so); a parameter at zero has no
relative elasticity (said so); one whose steps leave V unchanged (to 1e-12 of V) has no effect (said so, not
dropped). The margin a parameter buys is |E| V for a 10 % change (or 1 dB) in its favourable direction: the ranked
list. Kernels and stages are not touched: this is the runner asking the chain again.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from e2esim.errors import ConfigError, Location, UserError
from e2esim.params import Param, ParamGroup
from e2esim.runner.scenario import Scenario

RELATIVE_STEP = 0.05
"""h: a parameter p is stepped to p (1 ± h)."""
DB_STEP = 0.5
"""Δ: a parameter in dB is stepped to p ± Δ dB."""
BUY_RELATIVE, BUY_DB = 0.10, 1.0
"""The improvement whose margin the ranked list gives: 10 % of a parameter, or 1 dB."""
SKIPPED_SECTIONS = ("requirements", "simulation", "output", "sweep")


def chain_parameters(modules) -> list:
    """[(dotted key, Param, value)] of every float parameter of ``modules`` that has a value (nested groups
    included), outside the requirements."""
    out = []
    for m in modules:
        path = tuple(getattr(m.location, "key_path", ()))
        if not path or path[0] in SKIPPED_SECTIONS:
            continue
        for p in m.params:
            if isinstance(p, ParamGroup):
                group = m.config.get(p.name) or {}
                out += [(_key(path + (p.name, q.name)), q, group[q.name]) for q in p.params
                        if isinstance(q, Param) and _numeric(q, group.get(q.name))]
            elif isinstance(p, Param) and _numeric(p, m.config.get(p.name)):
                out.append((_key(path + (p.name,)), p, m.config[p.name]))
    return out


def _numeric(p, value) -> bool:
    return (isinstance(p, Param) and p.type == "float" and p.length is None and not p.variable_length
            and isinstance(value, (int, float)) and not isinstance(value, bool))


def _key(path: tuple) -> str:
    return ".".join(str(k) for k in path)


def _steps(p: Param, value: float) -> tuple:
    """(kind, [(sign, stepped value)] within the allowed range)."""
    kind = "per_db" if p.unit == "dB" else "relative"
    if kind == "relative" and value == 0.0:
        return kind, []
    out = []
    for sign in (-1, 1):
        stepped = value + sign * DB_STEP if kind == "per_db" else value * (1 + sign * RELATIVE_STEP)
        try:
            p.validate(stepped, Location())
        except ConfigError:
            continue
        out.append((sign, float(stepped)))
    return kind, out


def parameter_sensitivity(result, run) -> dict | None:
    """The sensitivity table of ``result`` (``output.sensitivity: true``), or None when not asked for; ``run`` is
    ``run_scenario`` (handed in: this module is below it)."""
    scenario = result.scenario
    if not scenario.output.get("sensitivity") or not result.requirement_names:
        return None
    table = result.table
    worst = {}
    for j in range(len(result.requirement_names)):
        applies = np.nonzero(table.applies(j))[0]
        if len(applies):
            margin = np.asarray(table.requirements[j].margin, dtype=float)[applies]
            worst[j] = int(applies[np.argmin(np.where(np.isfinite(margin), margin, np.inf))])
    head = {"relative_step": RELATIVE_STEP, "db_step": DB_STEP, "buy_relative": BUY_RELATIVE, "buy_db": BUY_DB}
    if scenario.raw.get("sweep", {}).get("map") if isinstance(scenario.raw.get("sweep"), dict) else False:
        return {**head, "requirements": [], "note": "not computed for a map sweep: run it on one cell"}
    rows, specs = [], []
    for case in sorted(set(worst.values())):
        settings = scenario.cases[case].settings
        inputs = {**result.cases[case].inputs, "simulation.stream": settings.stream_of(case)}  # common random numbers
        knobs = chain_parameters(scenario.cases[case].modules)
        specs.append((case, len(rows), knobs))
        rows.append(inputs)
        for key, p, value in knobs:
            for _, stepped in _steps(p, value)[1]:
                rows.append({**inputs, key: stepped})
    try:
        values = checked_values(scenario, rows, run)
    except UserError as exc:
        return {**head, "requirements": [], "note": f"not computed: {exc}"}
    out = []
    for j, name in enumerate(result.requirement_names):
        if j not in worst:
            continue
        case, base, knobs = next(s for s in specs if s[0] == worst[j])
        out.append(_requirement_table(name, case, base, knobs, values[j]))
    return {**head, "requirements": out}


def checked_values(scenario, rows: list, run, batched: bool = True) -> np.ndarray:
    """(requirements, rows) checked values of the cases ``rows`` (their sweep inputs, each with its
    ``simulation.stream``), analytic: one run whose sweep is the rows, or (``batched=False``) one one-case run per
    row; the same numbers, since a case's draws follow its stream, not its place in the sweep."""
    if batched:
        return _run_rows(scenario, rows, run)
    return np.concatenate([_run_rows(scenario, [row], run) for row in rows], axis=1)


def _run_rows(scenario, rows: list, run) -> np.ndarray:
    raw = copy.deepcopy(scenario.raw)
    raw["sweep"] = {"cases": rows}
    raw.setdefault("simulation", {})["mode"] = "analytic"
    raw.setdefault("output", {})["sensitivity"] = False
    stepped = run(Scenario(raw, f"{scenario.source} (sensitivity)").resolve(), progress=False)
    return np.array([np.asarray(r.value, dtype=float) for r in stepped.table.requirements]).reshape(-1, len(rows))


def _requirement_table(name: str, case: int, base: int, knobs: list, v) -> dict:
    v0 = float(v[base])
    position = base + 1
    params = []
    for key, p, value in knobs:
        kind, steps = _steps(p, value)
        at = {}
        for sign, stepped in steps:
            at[sign] = (stepped, float(v[position]))
            position += 1
        params.append({"key": key, "value": value, "unit": p.unit, "kind": kind,
                       **_elasticity(kind, value, v0, at)})
    ranked = sorted((r for r in params if r["margin_bought"] is not None), key=lambda r: -r["margin_bought"])
    return {"name": name, "case": case, "value": v0, "parameters": params, "ranked": [r["key"] for r in ranked]}


def _elasticity(kind: str, value: float, v0: float, at: dict) -> dict:
    if not at:
        why = "at zero: no relative elasticity" if kind == "relative" and value == 0.0 else \
            "no step within the parameter's allowed range"
        return {"elasticity": None, "sides": 0, "effect": None, "margin_bought": None, "note": why}
    lo = at.get(-1, (value, v0))
    hi = at.get(1, (value, v0))
    if kind == "per_db":
        run_ = hi[0] - lo[0]
    else:
        run_ = math.log(hi[0] / value) - math.log(lo[0] / value)
    dv = hi[1] - lo[1]
    effect = abs(dv) > 1e-12 * max(abs(v0), 1e-300)
    elasticity = dv / (run_ * v0) if v0 != 0 and effect else 0.0
    buy = BUY_DB if kind == "per_db" else BUY_RELATIVE
    note = "" if len(at) == 2 else "one-sided: the other step leaves the allowed range"
    if not effect:
        note = (note + "; " if note else "") + "no effect on the checked value"
    return {"elasticity": elasticity, "sides": len(at), "effect": bool(effect),
            "margin_bought": abs(elasticity) * abs(v0) * buy, "note": note}
