"""What ``e2esim solve`` prints and writes: the answer first (one line per requirement), then every case."""

from __future__ import annotations

import json
import math

import numpy as np

SHOWN_CASES = 10


def _answer_text(key: str, answer) -> str:
    """One requirement's answer in words."""
    states = set(answer.state)
    if answer.binding is not None and answer.state[answer.binding] == "no value meets it":
        return f"no value of {key} meets it (case {answer.binding + 1} fails at every value)"
    if math.isfinite(answer.limit):
        side = "<=" if answer.side[answer.binding] == "at most" else ">="
        several = int(np.max(answer.crossings, initial=0))
        more = f" (up to {several} sign changes in the range: the first from its low end)" if several > 1 else ""
        return f"met for {key} {side} {answer.limit:.4g}{more}"
    if states <= {"every value meets it", "not applicable"}:
        return f"every value of {key} meets it"
    if states <= {"no effect", "not applicable"}:
        return f"{key} has no effect on it"
    if states == {"not applicable"}:
        return "not applicable in any case"
    return "met on different sides in different cases: see every case"


def _others(answer) -> str:
    m = np.asarray(answer.margins, dtype=float)
    m = m[np.isfinite(m)]
    if answer.binding is None or m.size < 2:
        return ""
    return f"; margins of the cases at that value: {m.min():.3g} to {m.max():.3g} (median {np.median(m):.3g})"


def solve_lines(name: str, result) -> list:
    """The answer as lines of text: the search, then per requirement the value, the binding case and the margins
    of the others."""
    if hasattr(result, "y"):
        return boundary_lines(name, result)
    how = "the worst case over the sweep" if result.worst_case else "every case"
    lines = [f"{name}: {result.key} where each requirement is exactly met, for {how} ({len(result.labels)} case(s), "
             f"searched {result.bounds[0]:g} to {result.bounds[1]:g}; {result.calls} engine runs over "
             f"{result.rows} rows)"]
    for j, answer in enumerate(result.answers, 1):
        binding = "" if answer.binding is None else f"; binding case: {result.labels[answer.binding]}"
        lines.append(f"  requirement {j} ({answer.requirement}): {_answer_text(result.key, answer)}{binding}"
                     f"{_others(answer)}")
    return lines


def boundary_lines(name: str, result) -> list:
    """The boundary in words: the range of the second key on it, the allowed region as (first, second) pairs,
    the case that binds at how many points and the smallest margin the other cases keep there."""
    met = [i for i, s in enumerate(result.state) if s == "met at"]
    (k1, k2) = result.keys
    lines = [f"{name}: boundary of the region of {k1} and {k2} where every requirement holds in every case "
             f"({len(result.labels)} case(s), {len(result.x)} points of {k1} from {result.bounds[0][0]:g} to "
             f"{result.bounds[0][1]:g}; {result.calls} engine runs over {result.rows} rows)"]
    if met:
        y = result.y[met]
        lines.append(f"  {k2} on the boundary: {np.min(y):.4g} to {np.max(y):.4g} ({result.side[met[0]]} it meets)")
        sign = "<=" if result.side[met[0]] == "at most" else ">="
        pairs = ", ".join(f"{result.x[i]:.4g}: {sign} {result.y[i]:.4g}" for i in met)
        lines.append(f"  allowed region ({k1}: {k2}): {pairs}")
        lines += _binding_lines(result, met)
    for state in ("every value meets it", "no value meets it"):
        count = result.state.count(state)
        if count:
            at = ", ".join(f"{result.x[i]:.4g}" for i, s in enumerate(result.state) if s == state)
            lines.append(f"  {count} point(s) of {k1} ({at}): {state} ({k2} from {result.bounds[1][0]:g} to "
                         f"{result.bounds[1][1]:g})")
    return lines


def _binding_lines(result, met: list) -> list:
    """Which case binds on the boundary (at how many of its points, through which requirement), and the smallest
    margin each other case keeps there (``case_margins``, the requirements' unit)."""
    cases = [result.binding[i][1] for i in met]
    counts = {c: cases.count(c) for c in dict.fromkeys(cases)}
    requirements = sorted({result.binding[i][0] for i in met})
    lines = ["  binding case: " + ", ".join(f"{c} at {k} of {len(met)} point(s)" for c, k in counts.items())
             + f" (requirement {', '.join(requirements)})"]
    margins = getattr(result, "case_margins", None)
    if margins is None:
        return lines
    for c, label in enumerate(result.labels):
        others = [i for i in met if result.binding[i][1] != label]
        m = np.asarray(margins, dtype=float)[c, others]
        if m.size and np.any(np.isfinite(m)):
            lines.append(f"  {label} where another case binds: smallest margin {np.nanmin(m):.3g} to "
                         f"{np.nanmax(m):.3g}")
    return lines


def solve_markdown(name: str, result) -> str:
    """solve.md: the answer on the first screen, then the table of every case (or of the boundary's points)."""
    lines = [f"# {name}: solve", "", "## Answer", ""] + [f"    {line}" for line in solve_lines(name, result)] + [""]
    if hasattr(result, "y"):
        lines += ["## Boundary", "", f"| {result.keys[0]} | {result.keys[1]} | state | binding requirement | "
                  "binding case |", "|---|---|---|---|---|"]
        lines += [f"| {x:.4g} | {y:.4g} | {s} | {b[0]} | {b[1]} |"
                  for x, y, s, b in zip(result.x, result.y, result.state, result.binding)]
        return "\n".join(lines) + "\n"
    lines += ["## Every case", "", "| case | " + " | ".join(f"requirement {j}" for j in
                                                              range(1, len(result.answers) + 1)) + " |",
              "|---" * (len(result.answers) + 1) + "|"]
    for i, label in enumerate(result.labels):
        cells = [(f"{a.side[i]} {a.value[i]:.4g}" if a.state[i] == "met at" else a.state[i]) for a in result.answers]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def solve_json(result) -> str:
    """The result as JSON (NaN as null)."""
    def plain(v):
        if isinstance(v, np.ndarray):
            return [plain(x) for x in v.tolist()]
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        if isinstance(v, float) and not math.isfinite(v):
            return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
        return v
    if hasattr(result, "y"):
        out = {k: plain(getattr(result, k)) for k in ("keys", "bounds", "labels", "requirements", "x", "y", "state",
                                                     "side", "binding", "case_margins")}
    else:
        out = {"key": result.key, "bounds": plain(result.bounds), "worst_case": result.worst_case,
               "labels": result.labels,
               "requirements": [{"requirement": a.requirement, "state": a.state, "value": plain(a.value),
                                 "side": a.side, "binding_case": a.binding, "limit": plain(a.limit),
                                 "margins_at_limit": plain(np.asarray(a.margins))} for a in result.answers]}
    return json.dumps(out, indent=1)
