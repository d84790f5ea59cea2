"""The sensitivity table (``output.sensitivity``, ``e2esim.runner.sensitivity``) in results.h5: the group
``/sensitivity``, one subgroup per requirement, the same numbers as summary.json's ``sensitivity``
(docs/output-format.md)."""

from __future__ import annotations

import numpy as np

from e2esim.io.h5_datasets import put, put_text

_EFFECT = {True: 1, False: 0, None: -1}


def _number(v) -> float:
    return float("nan") if v is None else float(v)


def write_sensitivity(f, table: dict) -> None:
    """Write ``table`` (``ScenarioResult.sensitivity``) into the open file ``f`` as ``/sensitivity``."""
    g = f.create_group("sensitivity")
    for name in ("relative_step", "db_step", "buy_relative", "buy_db"):
        g.attrs[name] = table[name]
    if table.get("note"):
        g.attrs["note"] = table["note"]
    for j, req in enumerate(table["requirements"]):
        r = g.create_group(str(j))
        r.attrs["name"], r.attrs["case"], r.attrs["value"] = req["name"], req["case"], req["value"]
        rows = req["parameters"]
        put_text(r, "key", [p["key"] for p in rows] or [""], "dotted scenario key of each parameter")
        put(r, "value", np.array([_number(p["value"]) for p in rows]), "see unit", "the parameter's value in the case")
        put_text(r, "unit", [p["unit"] or "" for p in rows] or [""], "the unit of each parameter's value")
        put_text(r, "kind", [p["kind"] for p in rows] or [""],
                 "relative: d ln V / d ln p; per_db: d ln V / dp per dB")
        put(r, "elasticity", np.array([_number(p["elasticity"]) for p in rows]), "1 (relative) or 1/dB (per_db)",
            "elasticity of the checked value V at the requirement's worst case; NaN where it has none")
        put(r, "sides", np.array([p["sides"] for p in rows], dtype=np.int8), "1",
            "2: central difference; 1: one-sided; 0: not stepped")
        put(r, "effect", np.array([_EFFECT[p["effect"]] for p in rows], dtype=np.int8), "1",
            "1: the steps change the checked value; 0: no effect; -1: not stepped")
        put(r, "margin_bought", np.array([_number(p["margin_bought"]) for p in rows]), "requirement's unit",
            "|elasticity| x value x the improvement (buy_relative or buy_db); NaN where there is none")
        put_text(r, "note", [p["note"] for p in rows] or [""], "why a parameter has no elasticity, or is one-sided")
        put_text(r, "ranked", list(req["ranked"]) or [""], "the keys, largest margin bought first")
