"""Settings that change nothing: a swept or overridden key that changes no result of its cases is reported, with
the stage that ignores it (issue 21; docs/user-guide.md, "Settings that change nothing").

**Sweeps** (``sweep_findings``), from the run's columns: for every sweep group (keys varied together), the cases
that differ only in that group (``variation.Contexts``) are compared on every deterministic output of the stages
after the stage the key sets (on that stage's own outputs when no stage follows), verdicts included
(``variation.Contexts.varies``). Where none varies the key changes no result there. Only cases whose results are
deterministic take part: where a verdict rests on Monte Carlo samples (``basis: montecarlo``, or a case the
analytic model cannot describe), which differ between any two cases, the check cannot tell and says nothing. So
a key that changes nothing but the random stream is reported, in the cases where an analytic result decides; the
settings of the sampling itself (``SAMPLING_SETTINGS``) are compared on the samples too, so they are reported only
where no Monte Carlo runs. A key that acts in some cases and not in others is reported for the others only, named
by the other keys' values when one group tells them apart.

The stage that ignores it: the key's own stage when its outputs do not vary either (outputs that repeat the key's
value, named as it is, do not count); else the first later stage that reads the products of the key's stage, with
the physics it gives (``Stage.insensitivity``).

**Overrides** (``override_findings``; ``--set``, ``e2esim.run(..., **overrides)``), for one run there is no case
to compare with, so they are reported when it is certain: the value is the one the scenario (or the parameter's
default) already had; the module never read the parameter in this run (``Module.params_read``, where no case was
run before a resume: worker processes report what they read); or every later stage that reads the products of the
key's stage says it cannot depend on it (``Stage.insensitivity``). An override that is read but whose effect
vanishes further down is not found: sweep it to check (``--set sweep.parameters.KEY=[old, new]``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from e2esim.distinct import distinct_rows
from e2esim.params import Param, find_param
from e2esim.runner.overrides import override_path, value_at
from e2esim.runner.variation import Contexts, column_products, is_sampled

SAMPLING_SETTINGS = ("simulation.seed", "simulation.stream", "simulation.realisations", "simulation.noise_realisations")
"""Settings whose purpose is the Monte Carlo draws: compared on the sampled outputs too."""
MONTE_CARLO_NOTE = "its Monte Carlo results, drawn anew in every case, were compared by presence only"
_SHOW = 3  # outputs named in a message


@dataclass(frozen=True)
class NoEffect:
    """A setting that changes nothing. key : the swept group's keys (joined) or the overridden key. source :
    "sweep" or "--set". stage : the stage that ignores it. where : the cases concerned ("every case", "the cases
    with k=v (n of m cases)"). reason : why (the stage's physics, or what was found). changed : outputs of the key's
    own stage that do vary, if any."""

    key: str
    source: str
    stage: str
    where: str
    reason: str = ""
    changed: tuple = ()
    note: str = ""

    def message(self) -> str:
        head = (f"swept {self.key} changes no result in {self.where}" if self.source == "sweep"
                else f"--set {self.key} changes nothing" if self.source == "--set"
                else f"{self.key} changes nothing")
        text = f"{head}: {self.stage} ignores it" if self.stage else head
        if self.reason:
            text += f" ({self.reason})"
        if self.changed:
            more = ", ..." if len(self.changed) > _SHOW else ""
            text += f"; it changes only {', '.join(self.changed[:_SHOW])}{more}"
        return text + (f"; {self.note}" if self.note else "")

    def as_dict(self) -> dict:
        return {**asdict(self), "changed": list(self.changed), "message": self.message()}


def no_effect(result) -> list:
    """The ``NoEffect`` findings of a run (``ScenarioResult``): computed once and kept with it
    (``ScenarioResult.no_effect``, a ``cached_property`` made by ``findings``)."""
    return result.no_effect


def findings(result) -> list:
    """The ``NoEffect`` findings of a run (``ScenarioResult``), computed afresh: sweeps, overrides, then the settings
    the scenario file gives."""
    return sweep_findings(result) + override_findings(result) + given_findings(result)


# Sweeps ------------------------------------------------------------------------------------------------------------
def sweep_findings(result) -> list:
    plan = result.scenario.plan
    table = plan.table if plan is not None else None
    if table is None or table.layout == "none" or result.table.n < 2:
        return []
    codes = table.codes(np.arange(table.n))
    rt = result.table
    chain = plan.chain(0)
    names = list(rt.scalars) + [f"requirement{j}.details.{k}" for j, r in enumerate(rt.requirements) for k in r.details]
    products = column_products(names, chain)
    rank = {p.name: i for i, stage in enumerate(chain) for p in stage.provides}
    column_rank = {name: rank.get(products[name], len(chain)) for name in names}
    decidable = _decidable(rt)
    findings = []
    for g, group in enumerate(table.groups):
        if group.size < 2:
            continue
        owner = _owner(plan, chain, group.keys)
        sampling = all(k in SAMPLING_SETTINGS for k in group.keys)
        cases = np.arange(table.n) if sampling else np.flatnonzero(decidable)
        if len(cases) < 2:
            continue
        contexts = Contexts.of(codes, cases, g)
        after = [n for n in names if column_rank[n] > owner]
        columns = after or [n for n in names if column_rank[n] == owner]
        changed = _changed(rt, contexts, _by_relevance(columns), sampling, contexts.evidence)
        quiet = contexts.evidence & ~changed
        if quiet.any():
            finding = _sweep_finding(result, plan, group, g, contexts, quiet, changed,
                                     [n for n in names if column_rank[n] == owner] if after else [])
            if not sampling and any(is_sampled(n) for n in columns):
                finding = replace(finding, note=MONTE_CARLO_NOTE)
            findings.append(finding)
    return findings


def _decidable(rt) -> np.ndarray:
    """Cases whose results an analytic (deterministic) evaluation decides."""
    ok = np.ones(rt.n, dtype=bool)
    for r in rt.requirements:
        basis = r.basis
        montecarlo = np.array([b == "montecarlo" for b in basis.values], dtype=bool)
        ok &= ~montecarlo[basis.index]
    if not rt.requirements:
        analytic = [name for name in rt.scalars if "analytic" in name.split(".")]
        ok &= np.any([rt.has(name) for name in analytic], axis=0) if analytic else False
    return ok


def _by_relevance(names: list) -> list:
    """Verdicts first, then the AGB error, then the rest: a key that acts shows it soonest there."""
    return sorted(names, key=lambda n: 0 if n.startswith("requirement") else 1 if n.startswith("agb.") else 2)


def _column(rt, name: str) -> tuple:
    if ".details." in name and name.startswith("requirement"):
        head, _, key = name.partition(".details.")
        column = rt.requirements[int(head[len("requirement"):])].details[key]
        present = np.ones(rt.n, dtype=bool) if column.present is None else column.present
        return column.values, present
    return rt.scalar(name), rt.has(name)


def _changed(rt, contexts: Contexts, names: list, sampling: bool, evidence: np.ndarray) -> np.ndarray:
    """Contexts where any of ``names`` varies; stops when every context with evidence has."""
    changed = np.zeros(len(contexts.starts), dtype=bool)
    for name in names:
        if changed[evidence].all():
            break
        values, present = _column(rt, name)
        changed |= contexts.varies(values, present, is_sampled(name) and not sampling)
    return changed


def _owner(plan, chain: list, keys: tuple) -> int:
    """Position in ``chain`` of the earliest stage a key of ``keys`` sets; -1 for the simulation settings."""
    positions = []
    for key in keys:
        stage = _stage_of(plan, chain, override_path(key))
        positions.append(-1 if stage is None else chain.index(stage))
    return min(positions)


def _stage_of(plan, chain: list, path: tuple):
    """The stage of ``chain`` whose module the key path ``path`` sets, or None."""
    for slot in plan.module_slots:
        if tuple(path[:len(slot.path)]) == tuple(slot.path):
            for stage in chain:
                members = getattr(stage, "modules", None)
                if stage in slot.objects or (members is not None and any(m in slot.objects for m in members)):
                    return stage
    return None


def _echoes(name: str, keys: tuple) -> bool:
    """Whether output ``name`` repeats a key's value (``estimator.system_error_correlation`` for
    ``propagation.0.system_error_correlation``): it tells nothing of the key's effect."""
    last = name.rsplit(".", 1)[-1]
    return any(str(key).rsplit(".", 1)[-1] == last for key in keys)


def _sweep_finding(result, plan, group, g, contexts, quiet, changed, own_columns) -> NoEffect:
    rt = result.table
    key = ", ".join(group.keys)
    chain = plan.chain(int(contexts.first_cases()[np.flatnonzero(quiet)[0]]))  # a case it changes nothing in
    owner = _owner(plan, chain, group.keys)
    own = [name for name in own_columns if not is_sampled(name) and not _echoes(name, group.keys)]
    varied = []
    for name in own:  # the owner's outputs that do vary where the key changes no result
        values, present = _column(rt, name)
        if (contexts.varies(values, present, False) & quiet).any():
            varied.append(name)
            if len(varied) > _SHOW:
                break
    if owner < 0:
        stage, reason = "", "no stage uses it here"
    elif varied:
        ignoring = _reader(chain, owner)
        stage = _describe(ignoring) if ignoring is not None else "no later stage"
        reason = next((r for k in group.keys for r in [getattr(ignoring, "insensitivity", _none)(chain[owner], k)]
                       if r), "") if ignoring is not None else ""
    else:
        stage, reason = _describe(chain[owner]), ""
    return NoEffect(key, "sweep", stage, _where(result, plan.table, g, contexts, quiet, changed), reason,
                    tuple(varied))


def _none(*_):
    return None


def _reader(chain: list, owner: int):
    """The first stage after ``chain[owner]`` that reads one of its products, else the next stage."""
    made = {p.name for p in chain[owner].provides}
    later = chain[owner + 1:]
    return next((s for s in later if made & (set(s.needs) | set(s.uses))), later[0] if later else None)


def _describe(stage) -> str:
    section = ".".join(str(p) for p in getattr(stage.location, "key_path", ()))
    return f"{stage.identity} ({section})" if section and section not in stage.identity else stage.identity


def _where(result, table, g, contexts: Contexts, quiet, changed) -> str:
    """The cases of the quiet contexts, in words."""
    loud = contexts.evidence & changed
    count = int(contexts.sizes[quiet].sum())
    total = int(contexts.sizes[contexts.evidence].sum())
    if not loud.any():
        return "any case" if count == table.n else f"any case that could be compared ({count} of {table.n})"
    first = contexts.first_cases()
    codes = table.codes(first)
    best = None
    for h in range(len(table.groups)):
        if h == g:
            continue
        calm, noisy = set(codes[quiet, h]), set(codes[loud, h])
        if calm.isdisjoint(noisy) and (best is None or len(calm) < len(best[1])):
            best = (h, calm)
    if best is None:
        label = result.labels[int(first[np.flatnonzero(quiet)[0]])]
        return f"{count} of {total} cases (e.g. {label})"
    h, calm = best
    other = table.groups[h]
    values = [", ".join(f"{k}={_text(v)}" for k, v in zip(other.keys, other.values[p])) for p in sorted(calm)]
    return f"the cases with {' or '.join(values)} ({count} of {total} cases)"


def _text(value) -> str:
    return "null" if value is None else str(value)


# Overrides ---------------------------------------------------------------------------------------------------------
def override_findings(result) -> list:
    resolved = result.scenario
    plan = resolved.plan
    if plan is None or not getattr(resolved, "overrides", ()):
        return []
    chain = plan.chain(0)
    in_process = "resumed_cases" not in result.provenance  # workers report their reads (executors.note_worker_reads)
    findings, cache = [], {}
    for key, path, given, previous in resolved.overrides:
        if path[0] in ("sweep", "output", "name", "description", "plugins"):
            continue
        value = value_at(resolved.raw, path)
        finding = _unchanged(key, path, given, previous, value, plan, chain) or \
            _simulation(key, path, plan) or _unread(key, path, plan, chain, in_process) or \
            _ignored(key, path, plan, cache)
        if finding is not None:
            findings.append(finding)
    return findings


def _same(a, b) -> bool:
    return isinstance(a, bool) == isinstance(b, bool) and a == b


def _unchanged(key, path, given, previous, value, plan, chain) -> NoEffect | None:
    if given and _same(previous, value):
        return NoEffect(key, "--set", "", "every case", f"the scenario already sets {_text(value)}")
    if given:
        return None
    slot, rest = _slot(plan, path)
    if slot is None or not rest:
        return None
    params = [find_param(m.params, ".".join(str(p) for p in rest)) for m in slot.objects]
    if all(isinstance(p, Param) and _same(p.default, value) for p in params):
        return NoEffect(key, "--set", "", "every case", f"{_text(value)} is its default")
    return None


def _simulation(key, path, plan) -> NoEffect | None:
    if path[0] != "simulation" or key not in SAMPLING_SETTINGS[1:]:
        return None
    if any(getattr(s, "montecarlo", False) for s in plan.settings_slot.objects):
        return None
    modes = sorted({s.mode for s in plan.settings_slot.objects})
    return NoEffect(key, "--set", "", "every case", f"simulation mode {', '.join(modes)} runs no Monte Carlo")


def _slot(plan, path: tuple) -> tuple:
    for slot in plan.module_slots:
        if tuple(path[:len(slot.path)]) == tuple(slot.path):
            return slot, tuple(path[len(slot.path):])
    return None, ()


def _unread(key, path, plan, chain, in_process: bool) -> NoEffect | None:
    """The module of the key never read the parameter (every case ran in this run)."""
    slot, rest = _slot(plan, path)
    if not in_process or slot is None or not rest or rest[0] == "type":
        return None
    name = rest[0]
    for module in slot.objects:
        read = module.params_read()
        if read is None or name in read:
            return None
    stage = _stage_of(plan, chain, path)
    module = slot.objects[0]
    where = _describe(module) if stage is None or stage is module else f"{_describe(module)} in {_describe(stage)}"
    return NoEffect(key, "--set", where, "every case", f"it never reads {name} in this run")


MAX_CHAINS = 1000
"""Distinct chains an override is checked in (``_ignored``); beyond, it is not checked."""


def _chains(plan, cache: dict) -> list | None:
    """Every distinct chain of the run (its stage objects), or None beyond ``MAX_CHAINS``; made once per ``cache``."""
    if "chains" not in cache:
        rows, first, _ = distinct_rows(plan.object_codes(np.arange(plan.n)))
        cache["chains"] = None if len(rows) > MAX_CHAINS else [
            [plan.stage(step, objects) for step in plan.templates[int(plan.template[int(case)])].steps]
            for objects, case in zip(rows, first)]
    return cache["chains"]


def _ignored(key, path, plan, cache: dict) -> NoEffect | None:
    """In every distinct chain of the run, every later stage that reads the products of the key's stage says it
    cannot depend on the key."""
    chains = _chains(plan, cache)
    if chains is None:
        return None
    named, reason = [], ""
    for chain in chains:
        stage = _stage_of(plan, chain, path)
        if stage is None:
            return None
        owner = chain.index(stage)
        made = {p.name for p in stage.provides}
        readers = [s for s in chain[owner + 1:] if made & (set(s.needs) | set(s.uses))]
        reasons = [getattr(s, "insensitivity", _none)(stage, key) for s in readers]
        if not readers or not all(reasons):
            return None
        named += [d for d in map(_describe, readers) if d not in named]
        reason = reason or reasons[0]
    return NoEffect(key, "--set", " and ".join(named), "every case", reason)


# Settings the scenario file gives ------------------------------------------------------------------------------------
def given_findings(result) -> list:
    """A module setting the scenario file gives (neither swept nor overridden: those are checked above) that its
    module never read in this run (``Module.params_read``; worker processes report theirs), no case taken from a
    journal: e.g. the ``sd_deg`` of ``biomass_product_faraday`` where the product's own SD layer holds values at
    every pixel read."""
    resolved = result.scenario
    plan = resolved.plan
    if plan is None or "resumed_cases" in result.provenance:
        return []
    overridden = {tuple(path) for _, path, _, _ in getattr(resolved, "overrides", ())}
    findings = []
    for slot in plan.module_slots:
        section = value_at(resolved.raw, slot.path)
        if slot.kind == "simulation" or not isinstance(section, dict):
            continue
        swept = {override_path(k)[len(slot.path)] for k in slot.keys if len(override_path(k)) > len(slot.path)}
        reads = [getattr(m, "params_read", _none)() for m in slot.objects]
        if any(read is None for read in reads):
            continue
        for name in section:
            path = (*slot.path, name)
            if name == "type" or name in swept or path in overridden or any(name in read for read in reads):
                continue
            key = ".".join(str(p) for p in path)
            findings.append(NoEffect(key, "scenario", _describe(slot.objects[0]), "every case",
                                     f"it never reads {name} in this run"))
    return findings


__all__ = [
    "SAMPLING_SETTINGS", "NoEffect", "findings", "given_findings", "no_effect", "override_findings", "sweep_findings",
]
