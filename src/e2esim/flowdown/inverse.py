"""The inverse question (issue 23, item 4): at which value of a key is each requirement exactly met?

``solve(scenario, ["instrument.crosstalk.level_db"])`` finds, for every case (or for the worst case over the sweep,
``worst_case=True``), the value of one key at which each requirement's margin is zero: the margins at ``SCAN``
points of the search range bracket it (the first sign change from the low end, ``e2esim.flowdown.scan``), and
Brent's method (``e2esim.flowdown.brent``), vectorised over every case and requirement, finds it through the
engine's forward model (``e2esim.flowdown.evaluate``), a handful of batched runs in all. Two keys give the
boundary of the region where every requirement holds in every case (``boundary``).

States, per case and requirement (``STATES``):

* ``met at``: the margin changes sign in the range; ``value`` is where it is zero, ``side`` says which values meet
  it ("at most" or "at least" the value);
* ``every value meets it`` / ``no value meets it``: the margin has one sign at every scanned point (the search
  range is the parameter's allowed range unless ``bounds`` narrow it);
* ``no effect``: the margin is the same at every scanned point (the key does not reach this requirement here);
* ``not applicable``: the requirement does not apply to the case (no margin).

Errors (``UserError``, exit status 2): an unknown key, a key that is not one number, a key the sweep sets
(``e2esim.flowdown.keys``); a key with no effect on any requirement in any case; and explicit ``bounds`` within which no
requirement changes its verdict in any case (the given range brackets no answer: widen it). Without ``bounds`` the
whole allowed range was searched, and one sign there is an answer, given as a state.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from e2esim.api import load_scenario
from e2esim.errors import UserError
from e2esim.flowdown.boundary import boundary
from e2esim.flowdown.brent import brent
from e2esim.flowdown.evaluate import Evaluator
from e2esim.flowdown.keys import bounds_of, solve_key
from e2esim.flowdown.scan import SCAN, scan_brackets

STATES = ("met at", "every value meets it", "no value meets it", "no effect", "not applicable")
XTOL = 1e-6
"""Tolerance of a root, relative to the width of the search range (0.00002 dB over -40 to -20 dB)."""


@dataclass
class Answer:
    """One requirement over the cases. state, value, side : per case (``STATES``; the key's value where the margin is
    zero, NaN otherwise; "at most" / "at least" / ""). binding : the case whose answer is the strictest (None: no case
    has one); limit : its value; margins : every case's margin (the requirement's unit) with the key at ``limit``;
    crossings : per case, how many sign changes the scan of the range saw (more than one: ``value`` is the first
    from the low end)."""

    requirement: str
    state: list
    value: np.ndarray
    side: list
    binding: int | None = None
    limit: float = float("nan")
    margins: np.ndarray = field(default_factory=lambda: np.zeros(0))
    crossings: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))


@dataclass
class SolveResult:
    """What ``solve`` found: the key, the search range, the cases' labels, one ``Answer`` per requirement, and how
    many engine runs (``calls``) over how many rows it took. ``worst_case``: the answers are for the worst case over
    the sweep (one value per requirement, ``value`` the same in every case)."""

    key: str
    bounds: tuple
    labels: list
    answers: list
    worst_case: bool
    calls: int = 0
    rows: int = 0


def _check_effect(evaluator, state, key, bounds, given):
    if np.all((state == "no effect") | (state == "not applicable")):
        raise UserError(f"--for {key}: no effect on any requirement in any case (the margins are the same at "
                        f"{bounds[0]:g} and {bounds[1]:g}): solve needs a key the requirements depend on")
    if given is not None and not np.any(state == "met at"):
        meets = "every value meets" if np.any(state == "every value meets it") else "no value meets"
        raise UserError(f"--bounds {bounds[0]:g} {bounds[1]:g}: no requirement changes sign in any case within them "
                        f"({meets} {evaluator.names[0] if len(evaluator.names) == 1 else 'them'}): widen --bounds, "
                        "or leave them out to search the key's whole allowed range")


def solve(scenario, keys, bounds=None, worst_case: bool = False, points: int = 100, set: dict | None = None,
          workers: int = 1):
    """The value of one key (``keys``: a key or a list of one) at which each requirement is exactly met, for every
    case or for the worst case over the sweep (``SolveResult``); with two keys the boundary of the allowed region
    (``e2esim.flowdown.boundary.boundary``, ``points`` values of the first key). scenario : path, dict or
    ``Scenario``; set : overrides as ``e2esim.run`` takes them; bounds : (lo, hi) of the search (default: the
    parameter's allowed range); workers : processes each engine run spreads its blocks over (the same answer as
    one)."""
    loaded = load_scenario(scenario, set)
    resolved = loaded.resolve()
    keys = [keys] if isinstance(keys, str) else list(keys)
    if not 1 <= len(keys) <= 2 or len(dict.fromkeys(keys)) != len(keys):
        raise UserError(f"--for: give one or two different keys, got {', '.join(keys) or 'none'}")
    solve_keys = [solve_key(resolved, k) for k in keys]
    if len(solve_keys) == 2:
        return boundary(loaded, resolved, solve_keys, bounds, points, workers)
    key = solve_keys[0]
    lo, hi = bounds_of(key, bounds)
    evaluator = Evaluator(loaded, resolved, (key,), workers)
    n, r = evaluator.n, len(evaluator.names)
    xs = np.linspace(lo, hi, SCAN)
    scan = evaluator.grid_margins(xs)  # (R, n, SCAN)
    xtol = XTOL * (hi - lo)
    if worst_case:
        state, a, b, fa, fb, side_lo, crossings = scan_brackets(xs, _worst(np.moveaxis(scan, 2, 1)))
        _check_effect(evaluator, state, key.name, (lo, hi), bounds)
        todo = np.flatnonzero(state == "met at")

        def f(active, x):  # every case at each requirement's own value: one run
            m = evaluator.grid_margins(x)
            return _worst(m[todo[active], :, np.arange(len(active))])
        roots = np.full(r, np.nan)
        if todo.size:
            roots[todo], _ = brent(f, a[todo], b[todo], fa[todo], fb[todo], xtol)
        state, value = np.repeat(state[:, None], n, 1), np.repeat(roots[:, None], n, 1)
        side_lo, crossings = np.repeat(side_lo[:, None], n, 1), np.repeat(crossings[:, None], n, 1)
    else:
        state, a, b, fa, fb, side_lo, crossings = scan_brackets(xs, scan)
        _check_effect(evaluator, state, key.name, (lo, hi), bounds)
        j_todo, i_todo = np.nonzero(state == "met at")

        def f(active, x):
            m = evaluator.margins(i_todo[active], x)
            return m[j_todo[active], np.arange(len(active))]
        value = np.full((r, n), np.nan)
        if j_todo.size:
            value[j_todo, i_todo], _ = brent(f, a[j_todo, i_todo], b[j_todo, i_todo], fa[j_todo, i_todo],
                                             fb[j_todo, i_todo], xtol)
    side = np.where(state == "met at", np.where(side_lo, "at most", "at least"), "")
    answers = [_answer(evaluator, j, state[j], value[j], side[j], key, n) for j in range(r)]
    for answer, count in zip(answers, crossings):
        answer.crossings = count
    return SolveResult(key.name, (lo, hi), evaluator.labels, answers, worst_case, evaluator.calls, evaluator.rows)


def _worst(m: np.ndarray) -> np.ndarray:
    """The smallest margin over the cases (last axis), ignoring cases where the requirement does not apply."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all NaN: not applicable anywhere, NaN it stays
        return np.nanmin(m, axis=-1)


def _answer(evaluator, j, state, value, side, key, n) -> Answer:
    """The requirement's answer: the binding case (strictest value; any "no value meets it" case binds) and every
    case's margin with the key at that value."""
    answer = Answer(evaluator.names[j], list(state), value, list(side))
    met = np.flatnonzero(state == "met at")
    if np.any(state == "no value meets it") or met.size == 0:
        answer.binding = int(np.flatnonzero(state == "no value meets it")[0]) if np.any(
            state == "no value meets it") else None
        return answer
    strict = value[met] if side[met[0]] == "at most" else -value[met]
    if len({side[i] for i in met}) > 1:
        return answer  # cases allowed on opposite sides: no single strictest value
    answer.binding = int(met[np.argmin(strict)])
    answer.limit = float(value[answer.binding])
    answer.margins = evaluator.grid_margins(np.array([answer.limit]))[j, :, 0]
    return answer
