"""``e2esim compare RUN_A RUN_B``: what differs between two runs, in inputs, verdicts and numbers.

Inputs are the resolved scenarios (every module's settings with defaults filled in), compared key by key;
cases are matched by their sweep inputs (by index when the sweeps differ); numbers are every output scalar
of matched cases, reported when they differ by more than a relative ``rtol``.
"""

from __future__ import annotations

import math

import numpy as np

from e2esim.results import Results

PROVENANCE_ONLY = ("output",)
"""Sections of the resolved scenario that do not change a number."""


def flatten(value, prefix: str = "") -> dict:
    """{dotted key: leaf value} of nested mappings and lists."""
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            out.update(flatten(v, f"{prefix}{k}."))
        return out
    if isinstance(value, list) and any(isinstance(v, (dict, list)) for v in value):
        out = {}
        for i, v in enumerate(value):
            out.update(flatten(v, f"{prefix}{i}."))
        return out
    return {prefix[:-1]: value}


def input_differences(a: Results, b: Results) -> list:
    """[(key, value in A, value in B)] of the resolved scenarios, output settings left out."""
    fa = {k: v for k, v in flatten(a.resolved_scenario).items() if k.split(".")[0] not in PROVENANCE_ONLY}
    fb = {k: v for k, v in flatten(b.resolved_scenario).items() if k.split(".")[0] not in PROVENANCE_ONLY}
    missing = "(not set)"
    return [
        (k, fa.get(k, missing), fb.get(k, missing))
        for k in sorted(set(fa) | set(fb))
        if fa.get(k, missing) != fb.get(k, missing)
    ]


def matched_cases(a: Results, b: Results) -> list:
    """[(index in A, index in B)]: cases with the same sweep inputs, else by position."""
    key_a = [tuple((k, repr(a.inputs[k][i])) for k in a.sweep_keys) for i in range(a.n_cases)]
    key_b = {tuple((k, repr(b.inputs[k][i])) for k in b.sweep_keys): i for i in range(b.n_cases)}
    pairs = [(i, key_b[k]) for i, k in enumerate(key_a) if k in key_b]
    if len(pairs) == min(a.n_cases, b.n_cases):
        return pairs
    return [(i, i) for i in range(min(a.n_cases, b.n_cases))]


STATUS_WORDS = {"pass": "PASS", "fail": "FAIL", "not_applicable": "N/A"}


def verdict_differences(a: Results, b: Results, pairs: list) -> list:
    """[(requirement, case label, A, B)] where a verdict (PASS, FAIL or N/A) or its dominant contributor
    differs."""
    out = []
    for j, name in enumerate(a.requirements):
        if name not in b.requirements:
            out.append((name, "(all cases)", "stated", "not stated"))
            continue
        jb = b.requirements.index(name)
        covered = [sorted({t for t in r.coverage_text[[p[k] for p in pairs], i] if t}) for r, i, k in
                   ((a, j, 0), (b, jb, 1))]
        if covered[0] != covered[1]:
            out.append((name, "(error sources covered)", "; ".join(covered[0]) or "-", "; ".join(covered[1]) or "-"))
        for ia, ib in pairs:
            va = (STATUS_WORDS[a.status[ia, j]], a.dominant[ia, j])
            vb = (STATUS_WORDS[b.status[ib, jb]], b.dominant[ib, jb])
            if va != vb:
                out.append((name, a.labels[ia], f"{va[0]} ({va[1] or '-'})", f"{vb[0]} ({vb[1] or '-'})"))
    out += [(name, "(all cases)", "not stated", "stated") for name in b.requirements if name not in a.requirements]
    return out


def number_differences(a: Results, b: Results, pairs: list, rtol: float) -> list:
    """[(scalar, unit, cases differing, largest |B - A|, A, B at that case)] over matched cases."""
    ia = np.array([p[0] for p in pairs], dtype=int)
    ib = np.array([p[1] for p in pairs], dtype=int)
    out = []
    for name in sorted(set(a.scalars) | set(b.scalars)):
        if name not in a.scalars or name not in b.scalars:
            out.append(
                (
                    name,
                    a.units.get(name, b.units.get(name, "")),
                    "only in " + ("B" if name in b.scalars else "A"),
                    math.nan,
                    math.nan,
                    math.nan,
                )
            )
            continue
        x, y = a.scalars[name][ia], b.scalars[name][ib]
        both_nan = np.isnan(x) & np.isnan(y)
        with np.errstate(invalid="ignore"):
            differ = ~both_nan & ~np.isclose(x, y, rtol=rtol, atol=0.0, equal_nan=False)
        if differ.any():
            delta = np.where(differ, np.abs(np.nan_to_num(y - x, nan=np.inf)), -1.0)
            k = int(np.argmax(delta))
            out.append((name, a.units.get(name, ""), f"{int(differ.sum())} of {len(pairs)}", float(y[k] - x[k]),
                        float(x[k]), float(y[k])))
    return out


def compare_report(a: Results, b: Results, name_a: str, name_b: str, rtol: float = 1e-9) -> tuple[str, bool]:
    """(Markdown report, whether anything differs)."""
    pairs = matched_cases(a, b)
    inputs = input_differences(a, b)
    verdicts = verdict_differences(a, b, pairs)
    numbers = number_differences(a, b, pairs, rtol)
    lines = ["# Comparison of two runs", "", f"- A: `{name_a}` ({a.scenario_name}, {a.n_cases} cases)",
             f"- B: `{name_b}` ({b.scenario_name}, {b.n_cases} cases)",
             f"- cases compared: {len(pairs)}, matched by their sweep inputs" if a.sweep_keys == b.sweep_keys else
             f"- cases compared: {len(pairs)}, matched by position (the sweeps differ)", ""]
    lines += _section("Inputs", "resolved scenario, every setting with its default",
                      ("setting", "A", "B"), inputs)
    lines += _section("Verdicts", "verdict (dominant contributor)", ("requirement", "case", "A", "B"), verdicts)
    lines += _section("Numbers", f"output scalars differing by more than a relative {rtol:g}; the case with the "
                      "largest difference", ("scalar", "unit", "cases", "B - A", "A", "B"), numbers)
    return "\n".join(lines), bool(inputs or verdicts or numbers)


def _section(title: str, what: str, header: tuple, rows: list) -> list:
    out = [f"## {title}", ""]
    if not rows:
        return out + [f"No differences ({what}).", ""]
    out += [
        f"{len(rows)} difference{'s' if len(rows) > 1 else ''} ({what}).",
        "",
        "| " + " | ".join(header) + " |",
        "|" + "---|" * len(header),
    ]
    out += ["| " + " | ".join(_cell(v) for v in row) + " |" for row in rows]
    return out + [""]


def _cell(value) -> str:
    if isinstance(value, float):
        return "–" if math.isnan(value) else f"{value:.6g}"
    return str(value).replace("|", "\\|")
