"""The calibration campaign's schedule search decided by the AGB requirement itself (issue 25, item 6).

``Campaign``'s own search (``e2esim.campaign.campaign.search_schedules``) reaches the requirement only through
stated residual limits (``limit_*_db``). ``chain_schedule_search`` asks the requirement: for every schedule it
takes the dates after commissioning that could be the worst epoch (``worst_candidates``: the dates whose residual
crosstalk, imbalance and gain variances no other date exceeds in all three; the AGB error grows with each), states
their residuals to the scenario's own chain in place of the campaign (``residual_system`` with the same levels
and convention: the step the campaign itself hands the chain), and runs them as one batched analytic run
(``verdicts_only``, as ``e2esim solve`` evaluates). A schedule's AGB margin is the smallest margin of every
requirement in every case of the scenario's other sweep keys at its candidate dates; the answer is the cheapest
schedule whose AGB margin is >= 0 (ties: the larger margin), optionally also within the stated limits.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, replace

import numpy as np

from e2esim.campaign.campaign import cheapest, schedule_cost, schedule_grid, schedule_residuals, worst_candidates
from e2esim.campaign.sites import PARAMETERS
from e2esim.errors import UserError
from e2esim.io.campaign_h5 import campaign_outcome
from e2esim.requirements.attribution import verdicts_only
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario
from e2esim.units import level_db_from_variance


@dataclass(frozen=True)
class ChainScheduleSearch:
    """Every schedule tried: per_year (S,), opportunity (tuple of name tuples), cost (S,), agb_margin (S,): the
    requirements' smallest margin at the schedule's worst epoch (the requirement's unit, > 0 passes), worst_day
    (S,): that epoch (mission day), limits_margin_db (S,): the stated limits' margin (the campaign's own search);
    best: the answer's index or None; use_limits: whether the stated limits also had to hold; rows: chain rows."""

    per_year: np.ndarray
    opportunity: tuple
    cost: np.ndarray
    agb_margin: np.ndarray
    worst_day: np.ndarray
    limits_margin_db: np.ndarray
    best: int | None
    use_limits: bool
    rows: int
    unit: str = ""


def _campaign_index(raw: dict, source) -> int:
    steps = raw.get("calibration")
    steps = steps if isinstance(steps, list) else [steps]
    found = [i for i, s in enumerate(steps) if isinstance(s, dict) and s.get("type") == "campaign"]
    if not found:
        raise UserError(f"{source}: no calibration step of type campaign: nothing to plan")
    return found[0]


def _run(raw: dict, source, keep_products: bool = False):
    resolved = Scenario(raw, source).resolve()
    with verdicts_only():
        return run_scenario(resolved, progress=False, keep_products=keep_products, spill=False)


def chain_schedule_search(scenario: Scenario, use_limits: bool = False) -> ChainScheduleSearch:
    """The cheapest visit schedule that keeps the scenario's requirements met at every date after commissioning,
    checked through the scenario's chain (module docstring)."""
    raw = copy.deepcopy(scenario.raw)
    for section in ("solve", "allocate"):
        raw.pop(section, None)
    raw.setdefault("simulation", {})["mode"] = "analytic"
    if isinstance(raw.get("output"), dict):
        raw["output"]["sensitivity"] = False
    if not isinstance(raw.get("calibration"), list):
        raw["calibration"] = [raw.get("calibration")]
    j = _campaign_index(raw, scenario.source)
    own = f"calibration.{j}."
    sweep = raw.get("sweep") if isinstance(raw.get("sweep"), dict) else {}
    others = {k: v for k, v in sweep.get("parameters", {}).items() if not k.startswith(own)}
    # one run of the campaign at its worst epoch: the orbit and every acquisition over the sites
    first = copy.deepcopy(raw)
    first["calibration"][j]["epoch_day"] = None
    first["sweep"] = {"mode": "grid", "parameters": others} if others else {}
    if not others:
        first.pop("sweep")
    ran = _run(first, scenario.source, keep_products=True)
    outcome = campaign_outcome(ran.cases)
    setup, acq = outcome.setup, outcome.result.acquisitions
    grid, used = schedule_grid(setup, int(outcome.search.per_year.max()), acq)
    variance = schedule_residuals(setup, used, acq)
    days = outcome.result.days
    after = np.flatnonzero(days >= setup.commissioning_days)
    limits = outcome.search.margin_db
    rows, owner = [], []
    for s in range(len(grid)):
        for d in after[worst_candidates(np.stack([variance[p][s, after] for p in PARAMETERS]))]:
            rows.append((float(days[d]), *(float(variance[p][s, d]) for p in PARAMETERS)))
            owner.append(s)
    rows, owner = np.array(rows), np.array(owner)
    levels = np.column_stack([level_db_from_variance(rows[:, 2], outcome.convention),
                              level_db_from_variance(rows[:, 3], outcome.convention), np.sqrt(rows[:, 1])])
    levels = np.clip(levels, [-200.0, -200.0, 0.0], [0.0, 0.0, 20.0])
    distinct, which = np.unique(levels, axis=0, return_inverse=True)
    chain = copy.deepcopy(raw)
    chain["calibration"][j] = {"type": "residual_system", "convention": outcome.convention}
    keys = f"{own}crosstalk_db, {own}channel_imbalance_db, {own}gain_sd_db"
    chain["sweep"] = {"mode": "grid", "parameters": {**others, keys: [[float(x) for x in r] for r in distinct]}}
    table = _run(chain, scenario.source).table
    units = sorted({str(r.unit[0]) if len(r.unit) else "" for r in table.requirements})
    margin = np.array([np.asarray(r.margin, float) for r in table.requirements])
    margin = np.nanmin(margin.reshape(len(table.requirements), -1, len(distinct)), axis=(0, 1))[which.ravel()]
    agb = np.full(len(grid), np.inf)
    worst_day = np.full(len(grid), np.nan)
    for s in range(len(grid)):
        mine = np.flatnonzero(owner == s)
        k = mine[np.argmin(margin[mine])]
        agb[s], worst_day[s] = margin[k], rows[k, 0]
    cost = schedule_cost(grid)
    decide = np.where(use_limits & (limits < 0), -np.inf, agb)
    return ChainScheduleSearch(np.array([n for n, _ in grid]), tuple(c for _, c in grid), cost, agb, worst_day,
                               limits, cheapest(cost, decide), use_limits, len(distinct), ", ".join(units))


def _schedule(search: ChainScheduleSearch, i: int) -> str:
    sites = ", ".join(search.opportunity[i]) or "no target of opportunity"
    return f"{int(search.per_year[i])} transponder passes per year and {sites} (cost {search.cost[i]:g})"


def campaign_answer_lines(name: str, search: ChainScheduleSearch) -> list:
    """The answer as sentences: the cheapest schedule, its worst epoch, the cheaper ones that fail, the trade-off."""
    unit = f" {search.unit}" if search.unit else ""
    what = "every requirement" + (" and the stated residual limits" if search.use_limits else "")
    if search.best is None:
        i = int(np.argmax(search.agb_margin))
        lines = [f"{name}: no schedule tried keeps {what} met after commissioning; the best, "
                 f"{_schedule(search, i)}, leaves a margin of {search.agb_margin[i]:.4g}{unit} at day "
                 f"{search.worst_day[i]:g}."]
    else:
        b = search.best
        lines = [f"{name}: the cheapest schedule that keeps {what} met at every date after commissioning, checked "
                 f"through the chain, is {_schedule(search, b)}; its worst epoch is day {search.worst_day[b]:g}, "
                 f"margin {search.agb_margin[b]:.4g}{unit}."]
        cheaper = np.flatnonzero(search.cost < search.cost[b])
        if cheaper.size:
            c = int(cheaper[np.argmax(search.agb_margin[cheaper])])
            lines.append(f"The best cheaper schedule, {_schedule(search, c)}, fails at day {search.worst_day[c]:g} "
                         f"(margin {search.agb_margin[c]:.4g}{unit}).")
    trade = [f"{n}: {np.max(search.agb_margin[search.per_year == n]):.3g}" for n in np.unique(search.per_year)]
    lines.append(f"Trade-off, transponder passes per year: best requirement margin{unit} over the targets of "
                 "opportunity: " + "; ".join(trade) + ".")
    return lines


def campaign_json(search: ChainScheduleSearch) -> dict:
    """The search as plain data (summary.json's and results.h5's ``answer``)."""
    best = None if search.best is None else int(search.best)
    return {"best": best, "use_limits": search.use_limits, "unit": search.unit, "chain_rows": search.rows,
            "schedules": [{"transponder_per_year": int(n), "opportunity": list(o), "cost": float(c),
                           "requirement_margin": float(m), "worst_epoch_day": float(d),
                           "limits_margin_db": float(lm)}
                          for n, o, c, m, d, lm in zip(search.per_year, search.opportunity, search.cost,
                                                       search.agb_margin, search.worst_day,
                                                       search.limits_margin_db)]}


def has_campaign(raw: dict) -> bool:
    steps = raw.get("calibration")
    steps = steps if isinstance(steps, list) else [steps]
    return any(isinstance(s, dict) and s.get("type") == "campaign" for s in steps)


def campaign_answer(resolved) -> dict:
    """``e2esim run``'s answer for a campaign scenario: the schedule search through the chain, and the same search
    with the stated limits also required (``e2esim.flowdown.answer``)."""
    scenario = Scenario(resolved.raw, resolved.source)
    search = chain_schedule_search(scenario)
    both = replace(search, use_limits=True, best=cheapest(search.cost, np.where(search.limits_margin_db < 0, -np.inf,
                                                                                 search.agb_margin)))
    lines = campaign_answer_lines(resolved.name, search)
    if both.best != search.best:
        lines.append("With the stated residual limits (limit_*_db) also required: "
                     + ("no schedule tried keeps both." if both.best is None else _schedule(both, both.best) + "."))
    return {"question": "campaign_schedule", "lines": lines,
            "result": {**campaign_json(search),
                       "best_with_limits": None if both.best is None else int(both.best)}}
