"""The tables of the report: requirement verdicts, error budgets, margins, cases, analytic against Monte
Carlo. Every column says which error sources it covers; verdicts are badges."""

from __future__ import annotations

from e2esim.io.allocation_table import allocation_overview
from e2esim.io.error_budget import (
    SHAPLEY,
    agb_budget,
    budget_source_name,
    budget_split,
    interactions_share,
    source_groups,
    unattributed,
    unit_key,
    verdict_budget,
)
from e2esim.io.summary import requirement_overview
from e2esim.report.blocks import Table, fmt, status_badge
from e2esim.report.uncertainty import with_standard_error
from e2esim.requirements.source_names import source_name

LEVEL_NAMES = {"crosstalk": "crosstalk", "channel_imbalance": "channel imbalance", "nesz": "NESZ"}


def coverage_words(row: dict) -> str:
    """What a requirement's verdicts cover (its overview's ``coverage``): one text, or each with its cases."""
    parts = row["coverage"]
    if len(parts) == 1:
        return parts[0]["text"]
    return "; ".join(f"{p['text']} ({p['cases']} cases)" for p in parts)


def passing_words(row: dict) -> str:
    """"4/8" cases passing, with the cases the requirement does not apply to: "4/8 (4 N/A)"."""
    total = row["passed_cases"] + row["failed_cases"]
    outside = f" ({row['not_applicable_cases']} N/A)" if row["not_applicable_cases"] else ""
    return f"{row['passed_cases']}/{total}{outside}"


def verdict_table(result) -> Table:
    rows = []
    for row in requirement_overview(result):
        worst = "–" if row["worst_case"] is None else f"{row['worst_case']}: {row['worst_case_label']}"
        rows.append((row["name"], coverage_words(row), status_badge(row["status"]), passing_words(row),
                     f"{fmt(row['worst_margin'], 3)} {row['unit']}", worst))
    return Table(("requirement", "error sources covered", "verdict", "cases passing", "worst margin", "worst case"),
                 tuple(rows))


def budget_table(result, j: int) -> Table | None:
    """Requirement j: per case, each source's part of the checked value by the split the line uses (``split``:
    Euler shares where the sources add, Shapley where they couple; the parts sum to the value with the part not
    attributed) and, in brackets, how much the value falls without it (removal attribution)."""
    cases = result.cases
    rows = [verdict_budget(c.verdicts[j], source_groups(c)) for c in cases]
    sources = list(dict.fromkeys((r["source"], r["group"]) for case_rows in rows for r in case_rows))
    if not sources:
        return None
    unit = cases[0].verdicts[j].unit
    rests = [unattributed(c.verdicts[j]) for c in cases]
    shared = any(r is not None for r in rests)
    header = ("case", f"checked value ({unit})", "verdict") + (("split",) if shared else ()) + tuple(
        f"{budget_source_name(s, cases)} [{g}] ({unit})" for s, g in sources) + (("not attributed",) if shared else ())
    body = []
    for c, case_rows, rest in zip(cases, rows, rests):
        v = c.verdicts[j]
        by_source = {r["source"]: r for r in case_rows}
        body.append((f"{c.index}: {c.label}", fmt(v.value, 3), status_badge(v.status))
                    + ((split_words(v),) if shared else ())
                    + tuple(_budget_cell(by_source.get(s)) for s, _ in sources) + ((fmt(rest, 3),) if shared else ()))
    return Table(header, tuple(body))


def split_words(verdict) -> str:
    """Which split a budget line uses, and why: Shapley where the Euler split leaves a part not attributed (the
    sources couple), naming how large."""
    split = budget_split(verdict)
    if split is None:
        return "–"
    if split != SHAPLEY:
        return "Euler"
    return f"Shapley (sources couple: Euler leaves {fmt(interactions_share(verdict), 3)} not attributed)"


def allocation_table(result, j: int) -> Table | None:
    """Requirement j's allocation table at its worst case (``e2esim.io.allocation_table``): per source allocation,
    current best estimate (its share of the checked value) and margin, the smallest margin over the cases, then the
    total; None when it states no allocation."""
    table = allocation_overview(result, j)
    if table is None:
        return None
    unit, labels = table["unit"], result.labels

    def cell(x):
        return "–" if x is None else fmt(x, 3)

    body = [(source_name(r["source"]) if r["source"] != "interactions" else "not attributed (coupled sources)",
             cell(r["allocation"]), cell(r["estimate"]), cell(r["margin"]),
             "–" if r["worst_case"] is None else f"{cell(r['worst_margin'])} ({r['worst_case']}: "
             f"{labels[r['worst_case']]})") for r in table["rows"]]
    if table["unallocated"]:
        body.append(("not allocated", cell(table["unallocated"]), "", "", ""))
    total = table["total"]
    body.append(("**total**", f"**{cell(total['allocation'])}**", f"**{cell(total['estimate'])}**",
                 f"**{cell(total['margin'])}**", ""))
    return Table(("error source", f"allocation ({unit})", f"current best estimate ({unit})", f"margin ({unit})",
                  f"smallest margin over the cases ({unit})"), tuple(body))


def _budget_cell(row) -> str:
    if row is None:
        return "–"
    if row["part"] is None:
        return fmt(row["contribution"], 3)
    return f"{fmt(row['part'], 3)} ({fmt(row['contribution'], 3)})"


def agb_budget_table(result) -> Table | None:
    """Per case, the relative AGB error each named contribution causes on its own (RMSE) and its share of the
    variance of the relative σ_hv error."""
    rows = [agb_budget(c.scalars, source_groups(c)) for c in result.cases]
    sources = list(dict.fromkeys((r["source"], r["group"]) for case_rows in rows for r in case_rows))
    if not sources:
        return None
    header = ("case", "total RMSE, computed sources (%)") + tuple(
        f"{source_name(s)} [{g}]: RMSE alone (%) / variance share" for s, g in sources)
    body = []
    for c, case_rows in zip(result.cases, rows):
        by_source = {r["source"]: r for r in case_rows}
        cells = []
        for s, _ in sources:
            r = by_source.get(s)
            cells.append("–" if r is None else f"{fmt(r['rmse_percent'], 3)} / {fmt(100 * r['variance_share'], 2)} %")
        body.append((f"{c.index}: {c.label}", fmt(c.scalars.get("agb.analytic.rmse_percent",
                                                                 c.scalars.get("agb.montecarlo.rmse_percent")), 3))
                    + tuple(cells))
    return Table(header, tuple(body))


def margin_table(result) -> Table | None:
    """Level margins both ways: from the residual after calibration and from the stated specification."""
    levels = list(dict.fromkeys(k[: -len(".limit_db")] for c in result.cases for v in c.verdicts
                                for k in v.details if k.endswith(".limit_db")))
    if not levels:
        return None
    header = ("case", "requirement", "error level", "limit (dB)", "specification (dB)",
              "margin to the specification (dB)", "residual after calibration (dB)", "margin to the residual (dB)")
    rows = []
    for c in result.cases:
        for v in c.verdicts:
            d = v.details
            for level in levels:
                if f"{level}.limit_db" not in d:
                    continue
                rows.append((f"{c.index}: {c.label}", v.name, LEVEL_NAMES.get(level, level.replace("_", " ")),
                             fmt(d.get(f"{level}.limit_db"), 4), fmt(d.get(f"{level}.spec_db"), 4),
                             fmt(d.get(f"{level}.spec_margin_db"), 3), fmt(d.get(f"{level}.residual_db"), 4),
                             fmt(d.get(f"{level}.margin_db"), 3)))
    return Table(header, tuple(rows))


def case_table(result) -> Table:
    cols = [("σ_hv (m²/m²)", "scene.sigma_hv", 4),
            ("bias, systematic (analytic, m²/m²)", "analytic.mean", 4),
            ("SD, systematic (analytic, m²/m²)", "analytic.sd", 4),
            ("bias, systematic (MC, m²/m²)", "montecarlo.mean", 4), ("SD, systematic (MC, m²/m²)", "montecarlo.sd", 4),
            ("AGB error 0.135 %, computed sources (%)", "agb.analytic.q00135_percent", 3),
            ("AGB error 99.865 %, computed sources (%)", "agb.analytic.q99865_percent", 3),
            ("AGB error 99.865 %, computed sources (MC, %)", "agb.montecarlo.q99865_percent", 3)]
    present = [c for c in cols if any(c[1] in case.scalars for case in result.cases)]
    header = ("case", "inputs") + tuple(c[0] for c in present) + tuple(result.requirement_names)
    rows = []
    for case in result.cases:
        cells = [str(case.index), case.label] + [
            with_standard_error(case.scalars.get(k), case.scalars.get(k.replace("_percent", "_standard_error_percent")),
                                d) for _, k, d in present]
        cells += [verdict_cell(v) for v in case.verdicts]
        rows.append(tuple(cells))
    return Table(header, tuple(rows))


def verdict_cell(v):
    dominant = f"; {source_name(v.dominant)}" if v.dominant else ""
    note = f"; not applicable: {v.reason}" if v.status == "not_applicable" else ""
    value = with_standard_error(v.value, v.details.get("value_standard_error"))
    return status_badge(v.status, f"({value} {v.unit}{dominant}{note})")


COMPARISON = ("comparison.bias_rel_diff", "comparison.bias_rel_se", "comparison.var_rel_diff", "comparison.var_rel_se")


def comparison_table(result) -> Table | None:
    cases = [c for c in result.cases if all(k in c.scalars for k in COMPARISON)]  # a resumed journal may lack some
    if not cases:
        return None
    rows = []
    for c in cases:
        s = c.scalars
        zb = _z(s["comparison.bias_rel_diff"], s["comparison.bias_rel_se"])
        zv = _z(s["comparison.var_rel_diff"], s["comparison.var_rel_se"])
        rows.append((str(c.index), c.label,
                     f"{100 * s['comparison.bias_rel_diff']:.2f} % ± {100 * s['comparison.bias_rel_se']:.2f} %",
                     f"{zb:.2f}",
                     f"{100 * s['comparison.var_rel_diff']:.2f} % ± {100 * s['comparison.var_rel_se']:.2f} %",
                     f"{zv:.2f}"))
    return Table(("case", "inputs", "bias rel. diff.", "z", "variance rel. diff.", "z"), tuple(rows))


def _z(difference: float, standard_error: float) -> float:
    """The difference in standard errors (NaN without a standard error)."""
    return difference / standard_error if standard_error else float("nan")


def contribution_key(verdict, source: str) -> str:
    return f"contribution.{source}_{unit_key(verdict.unit)}"


__all__ = [
    "agb_budget_table",
    "allocation_table",
    "budget_table",
    "case_table",
    "comparison_table",
    "margin_table",
    "verdict_table",
]
