"""The answer to a scenario's own question, computed by ``e2esim run`` (issue 23, item 7: "reports show the answer
on the first screen").

A scenario asks its question in a ``solve:`` section (``for``: one or two keys; ``bounds``: a LO HI pair per key;
``worst_case``; ``points`` of a two-key boundary) or an ``allocate:`` section (``sources``, and ``requirement``,
``split``, ``weights``, ``fix``). ``e2esim solve`` and ``e2esim allocate`` answer it on their own; with
``output.answer`` on (its default) ``e2esim run`` answers it too, after the run, through the same functions
(``e2esim.flowdown.inverse.solve``, ``e2esim.flowdown.allocation.allocate``), and the report gives the answer
first, summary.json under ``answer`` and results.h5 in its ``answer`` group (docs/output-format.md). The answer
is derived, never stated text.
"""

from __future__ import annotations

import json

import yaml

from e2esim.errors import UserError
from e2esim.flowdown.allocation import allocate, allocation_markdown, allocation_yaml
from e2esim.flowdown.campaign_schedule import campaign_answer, has_campaign
from e2esim.flowdown.inverse import solve
from e2esim.flowdown.report import solve_json, solve_lines
from e2esim.runner.scenario import Scenario


def stated_solve(raw: dict, keys=None, bounds=None, worst_case: bool = False) -> tuple:
    """(keys, bounds as ``solve`` takes them, worst case) of the scenario's ``solve`` section, the given
    ``keys``/``bounds``/``worst_case`` (the command line's) first."""
    stated = raw.get("solve") or {}
    keys = list(keys or stated.get("for", []))
    bounds = bounds if bounds is not None else stated.get("bounds")
    if bounds is not None and len(bounds) != len(keys):
        raise UserError(f"--bounds: give one LO HI pair per --for key ({len(keys)})")
    one = None if bounds is None else (bounds[0] if len(keys) == 1 else bounds)
    return keys, one, bool(worst_case or stated.get("worst_case", False))


def scenario_answer(resolved, workers: int = 1) -> dict | None:
    """The answer to ``resolved``'s ``solve`` or ``allocate`` section (a ``ResolvedScenario``), or None when it
    asks none or ``output.answer`` is off: {"question": "solve" or "allocate", "lines": the answer as text,
    "result": what ``e2esim solve --json`` prints, or the specification of ``e2esim allocate``}. workers : the
    run's ``--workers``, over which the solve's engine runs spread their blocks (the same answer as one)."""
    raw = resolved.raw
    asked = [s for s in ("solve", "allocate") if raw.get(s)]
    if not resolved.output.get("answer", True):
        return None
    if not asked:  # a calibration campaign asks which visit schedule keeps the requirement met (issue 25, item 6)
        return campaign_answer(resolved) if has_campaign(raw) else None
    if len(asked) == 2:
        raise UserError(f"{resolved.source}: a scenario asks one question: a solve or an allocate section, not both "
                        "(or set output.answer: false and run e2esim solve / e2esim allocate)")
    scenario = Scenario(raw, resolved.source)
    if asked[0] == "solve":
        keys, bounds, worst = stated_solve(raw)
        if not keys:
            raise UserError(f"{resolved.source}: solve.for: name the key(s) to solve for")
        result = solve(scenario, keys, bounds, worst_case=worst, points=int(raw["solve"].get("points", 100)),
                       workers=workers)
        return {"question": "solve", "lines": solve_lines(resolved.name, result),
                "result": json.loads(solve_json(result))}
    stated = raw["allocate"]
    result = allocate(scenario, int(stated.get("requirement", 1)), str(stated.get("split", "equal")))
    text = allocation_markdown(resolved.name, result).splitlines()
    lines = [line for line in text[2:] if line.strip() and not line.startswith("|")]  # its sentences
    for source, key, spec, by in zip(result.sources, result.keys, result.specification, result.binding):
        value = "no value meets its share" if spec != spec else f"{key} = {spec:.4g}"
        lines.append(f"{source}: {value} (set by {'fixed' if key in result.fixed else by or 'every case'})")
    return {"question": "allocate", "lines": lines, "result": yaml.safe_load(allocation_yaml(result))}
