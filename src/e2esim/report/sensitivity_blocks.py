"""The report's sensitivity tables (``output.sensitivity: true``): for every requirement, at its worst case, the
parameters of the chain ranked by the margin they buy (``result.sensitivity``, ``e2esim.runner.sensitivity``); its
tornado chart is ``e2esim.report.sensitivity_plots``. Kept apart from the chart so that the report's text (and the
command line's verdict lines, through ``e2esim.report.document``) does not import matplotlib. Nothing is computed
here."""

from __future__ import annotations

from e2esim.report.blocks import Paragraph, Table, fmt, table_blocks


def ranked_requirements(result) -> list:
    """The requirements of ``result.sensitivity`` that rank at least one parameter."""
    table = getattr(result, "sensitivity", None) or {}
    return [r for r in table.get("requirements", ()) if r["ranked"]]


def by_key(req: dict) -> dict:
    """A requirement's parameters by their key."""
    return {p["key"]: p for p in req["parameters"]}


def sensitivity_table(result, req: dict) -> Table:
    """The parameters of one requirement ranked by the margin they buy, then those with no effect or no
    elasticity (each with why)."""
    params = by_key(req)
    buy = result.sensitivity
    rows = []
    for key in req["ranked"]:
        p = params[key]
        if not p["effect"]:
            continue
        step = f"{buy['buy_db']:g} dB" if p["kind"] == "per_db" else f"{100 * buy['buy_relative']:g} %"
        better = "lower" if p["elasticity"] > 0 else "higher"
        rows.append((key, f"{fmt(p['value'], 4)} {p['unit']}".strip(), fmt(p["elasticity"], 3),
                     "per dB" if p["kind"] == "per_db" else "d ln V / d ln p",
                     f"{fmt(p['margin_bought'], 3)} ({step} {better})", p["note"]))
    rows += [(p["key"], f"{fmt(p['value'], 4)} {p['unit']}".strip(), "–", "", "–", p["note"])
             for p in req["parameters"] if not p["effect"]]
    return Table(("parameter", "value", "elasticity", "as", "margin bought", "note"), tuple(rows))


def sensitivity_blocks(result) -> list:
    """The report's tables: one per requirement with a sensitivity."""
    table = getattr(result, "sensitivity", None)
    if not table:
        return []
    out = []
    if table.get("note"):
        out.append(Paragraph(f"Sensitivity: {table['note']}."))
    for req in ranked_requirements(result):
        out += table_blocks(f"{req['name']}: the parameters that buy the most margin (case {req['case']})",
                            sensitivity_table(result, req), SENSITIVITY_INTRO)
    return out


SENSITIVITY_INTRO = (
    "Each numeric parameter of the chain, stepped down and up around its value at the requirement's worst case "
    "(central differences; one-sided where a step leaves the allowed range), each step a run of its own with the same "
    "random numbers; the margin a parameter buys is |elasticity| × the checked value for the improvement stated "
    "(10 % of the parameter, or 1 dB), in the requirement's unit. Parameters with no effect are listed last.")
