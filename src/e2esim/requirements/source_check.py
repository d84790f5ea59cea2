"""``sources: all`` is a claim: ``e2esim validate`` refuses it where the chain cannot supply every group of error
sources, before anything runs.

"All sources" means the systematic error of the propagation's error model, a random-error budget that holds speckle
(Ahmed et al. 2014, eq. 20, or an error model that simulates speckle), and the uncertainty of the retrieval model
(a regression campaign, Ahmed et al. 2014, eqs. 3-7, or a retrieval-model term). What a stage contributes is known
from its settings before any case runs (``declared_terms``): a stage may say it with a method
``agb_error_terms()`` returning term names (``TERMS``); without one the terms follow from what it provides and
its usual parameters (``reference: population``, a budget's ``include``, a retrieval's ``regression.mode`` and
``model_uncertainty.mode``). A scenario may state a missing group as an assumed value instead (the requirement's
``assumed`` section), which then must not duplicate a group the chain computes.

Every distinct combination of the modules that matter (requirements, the stages that contribute terms, the
simulation settings) is checked once, so a sweep over a million cases costs what its distinct chains cost. What a
verdict finally covers is derived from what the case computed (``e2esim.requirements.coverage``); this check
makes the claim impossible where the chain cannot back it.
"""

from __future__ import annotations

import numpy as np

from e2esim.distinct import distinct_rows
from e2esim.errors import ConfigError
from e2esim.requirements.coverage import assumed_values, setting

TERMS = ("systematic", "speckle", "temporal", "random", "regression", "model")
"""Term names a stage may declare (``agb_error_terms``)."""

NEEDED = {
    "speckle": ("speckle", "random_percent",
                "a random-error budget with speckle_noise in its include (propagation: backscatter_error_budget, "
                "or stack_error_budget after stack_backscatter_error), or an error model with reference: population"),
    "regression/retrieval-model": (("regression", "model"), "retrieval_agb_percent",
                                      "a regression or retrieval-model term (retrieval: regression.mode confidence "
                                      "or prediction)"),
}
"""What ``sources: all`` needs beyond the systematic error: (the terms that supply it, the assumed key that may
state it instead, how to add it)."""

_CHUNK = 1 << 20


def declared_terms(stage) -> set:
    """The terms of the AGB error ``stage`` contributes, from its ``agb_error_terms()`` or its declarations."""
    own = getattr(stage, "agb_error_terms", None)
    if callable(own):
        return set(own())
    provides = _provided(stage)
    si = getattr(stage, "si", None) or {}
    out = set()
    if "backscatter.error" in provides:
        out.add("systematic")
        if si.get("reference") == "population":
            out.add("speckle")
    if "backscatter.budget" in provides:
        include = tuple(si.get("include", ()))
        out.add("random")
        out.update(term for term, name in (("speckle", "speckle_noise"), ("temporal", "temporal")) if name in include)
    if "agb.error" in provides and (si.get("regression") or {}).get("mode", "none") != "none":
        out.add("regression")
    if "agb.error" in provides and (si.get("model_uncertainty") or {}).get("mode", "none") != "none":
        out.add("model")  # the retrieval's exponents and coefficients (e2esim.retrieval.model_error)
    return out


def chain_terms(stages) -> set:
    """The terms a chain's stages contribute; a budget's only when the retrieval reads the budget."""
    reads_budget = any("backscatter.budget" in (*getattr(s, "needs", ()), *getattr(s, "uses", ()))
                       for s in stages if "agb.error" in _provided(s))
    terms = set()
    for stage in stages:
        if reads_budget or "backscatter.budget" not in _provided(stage):
            terms |= declared_terms(stage)
    return terms


def _provided(stage) -> set:
    return {getattr(p, "name", p) for p in getattr(stage, "provides", ())}


def check_error_sources(plan) -> None:
    """Check every requirement's ``sources`` and ``assumed`` against the chain of every case (``ConfigError``)."""
    slots = plan.module_slots
    requirements = [j for j, s in enumerate(slots) if s.kind == "requirement"]
    if not any(setting(m) == "all" or assumed_values(m) for j in requirements for m in slots[j].objects):
        return
    contributing = [j for j, s in enumerate(slots) if s.kind != "requirement"
                    and any(declared_terms(m) or "agb.error" in _provided(m) for m in s.objects)]
    columns = requirements + contributing + [len(plan.slots) - 1]
    seen: set = set()
    for start in range(0, plan.n, _CHUNK):
        indices = np.arange(start, min(start + _CHUNK, plan.n))
        objects = plan.object_codes(indices)
        rows, first, _ = distinct_rows(objects[:, columns])
        for row, i in zip(map(tuple, rows), first):
            if row not in seen:
                seen.add(row)
                case = int(indices[i])
                _check_case(plan.modules_of(objects[i]), plan.settings_of(objects[i]), case, plan.n)


def _check_case(modules, settings, case: int, n: int) -> None:
    terms = chain_terms([m for m in modules if m.kind != "requirement"])
    where = f" (case {case} of the sweep)" if n > 1 else ""
    for m in (m for m in modules if m.kind == "requirement"):
        which, assumed = setting(m), assumed_values(m)
        if assumed:
            _check_assumed(m, which, assumed, terms, settings, where)
        if which != "all":
            continue
        missing = [group for group, (supply, key, _) in NEEDED.items()
                   if not (set(np.atleast_1d(supply)) & terms) and key not in assumed]
        if missing:
            raise ConfigError(
                m.location.child("sources"),
                f"'all' claims every error source, but this chain computes no {' and no '.join(missing)} term{where}",
                "; ".join(f"add {NEEDED[g][2]}, or state it as assumed.{NEEDED[g][1]}" for g in missing)
                + "; or use sources: computed (every source this chain computes, named in the verdict's coverage) "
                "or systematic")


def _check_assumed(m, which: str, assumed: dict, terms: set, settings, where: str) -> None:
    if which != "all":
        raise ConfigError(m.location.child("assumed"), f"assumed terms complete sources: all, but sources is "
                          f"{which!r}", "set sources: all, or leave assumed out")
    for group, (supply, key, _) in NEEDED.items():
        if key in assumed and set(np.atleast_1d(supply)) & terms:
            raise ConfigError(m.location.child("assumed").child(key), f"this chain computes a {group} term{where}: "
                              "the assumed value would count it twice", f"leave assumed.{key} out")
    if getattr(settings, "mode", "analytic") == "montecarlo":
        raise ConfigError(m.location.child("assumed"), "assumed terms enter the analytic AGB error, which simulation "
                          "mode 'montecarlo' does not compute", "use simulation.mode analytic or both")
    if m.config.get("basis") == "montecarlo":
        raise ConfigError(m.location.child("basis"), "'montecarlo' cannot hold the assumed terms (they enter the "
                          "analytic AGB error)", "use basis: auto or analytic")


__all__ = ["NEEDED", "TERMS", "chain_terms", "check_error_sources", "declared_terms"]
