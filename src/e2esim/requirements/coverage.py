"""What a verdict covers: the error sources its checked value contains, derived from what the chain computed.

A requirement's ``sources`` setting chooses which part of the case's AGB error it checks
(``e2esim.requirements.base.checked_error``); this module says which error sources that part actually holds, so
that no label, table or file claims a source the chain did not compute:

* the **systematic** sources are those of the error model the checked AGB error maps (``ErrorModel.sources``:
  crosstalk, channel imbalance, noise, Faraday rotation, gain for the HV model of Men et al. 2021; a plug-in's
  model adds its own, e.g. ``scintillation``), with ``speckle`` when the model simulates a new scene per
  realisation (``includes_speckle``, population reference) without naming it as a source;
* every other source is a named contribution of the case's AGB error (``AGBError.contributions``) whose group is
  not "systematic": the random-error budget's terms (group "random": ``speckle_noise``, ``temporal``,
  ``calibration``, ``area_projection``; Ahmed et al. 2014, eq. 20), the regression uncertainty (group
  "regression"), a retrieval-model term, or any group a plug-in adds;
* terms the scenario states as assumed values (the requirement's ``assumed`` section) are named
  ``assumed_<term>``, group "assumed".

``sources: systematic`` covers the first group only; ``computed`` and ``all`` every group the chain computed
(``all`` is refused at ``e2esim validate`` when the chain cannot supply a speckle term and a regression or
retrieval-model term, ``e2esim.requirements.source_check``).
"""

from __future__ import annotations

import numpy as np

from e2esim.requirements.checked_model import agb_error_of
from e2esim.requirements.source_names import source_name

SYSTEMATIC = "systematic"
ASSUMED = "assumed"
ASSUMED_TERMS = {
    "random_percent": ("assumed_random", "random terms (speckle, temporal, calibration), assumed {:g} % of σ"),
    "retrieval_agb_percent": ("assumed_retrieval", "regression and retrieval model, assumed {:g} % of AGB"),
}
"""The requirement's ``assumed`` keys: (source name, words with the stated 1-sigma value)."""

GROUP_WORDS = {"random": "random", "regression": "regression", "model": "retrieval model", ASSUMED: "assumed"}
SPECKLE = ("speckle", "speckle_noise", "assumed_random")
TEMPORAL = ("temporal", "assumed_random")
RETRIEVAL_GROUPS = ("regression", "model")
"""Sources that answer for speckle and temporal variability; groups that answer for the retrieval model."""


def setting(requirement) -> str:
    """The requirement's ``sources`` setting ("computed" for a requirement without one: it checks what it reads)."""
    return getattr(requirement, "config", {}).get("sources", "computed")


def assumed_values(requirement) -> dict:
    """{assumed key: stated value in percent} of the requirement's ``assumed`` section (none given: {})."""
    section = getattr(requirement, "config", {}).get("assumed") or {}
    return {k: float(v) for k, v in section.items() if v is not None}


def systematic_sources(model) -> tuple:
    """The error model's sources, with ``speckle`` when it simulates speckle without naming it as a source."""
    sources = tuple(model.sources)
    if getattr(model, "includes_speckle", False) and "speckle" not in sources:
        sources += ("speckle",)
    return sources


def chain_terms(case, model) -> list:
    """[(source, group)] of every error source the case's chain computed: the error model's, then the other named
    contributions of its AGB error."""
    out = [(s, SYSTEMATIC) for s in systematic_sources(model)]
    agb = case.get("agb.error")
    out += [(c.name, c.group) for c in getattr(agb, "contributions", ()) if c.group != SYSTEMATIC]
    return out


def verdict_coverage(requirement, case) -> tuple:
    """(coverage, coverage_text, missing) of ``requirement`` on ``case`` (one case, or a block,
    ``e2esim.block.Block``: then the sources are those of every case of the block); ``missing``: the groups
    that ``sources: all`` needs and the coverage lacks (``missing_terms``)."""
    terms = chain_terms(case, agb_error_of(case).error_model)
    which = setting(requirement)
    assumed = assumed_values(requirement)
    covered = [t for t in terms if t[1] == SYSTEMATIC] if which == SYSTEMATIC else list(terms)
    covered += [(ASSUMED_TERMS[k][0], ASSUMED) for k in assumed]
    left_out = [t for t in terms if t not in covered]
    missing = missing_terms(covered)
    return (tuple(s for s, _ in covered), coverage_text(covered, left_out, which, assumed),
            tuple(word for word in missing if word != "temporal"))


def missing_terms(covered: list) -> list:
    """Which of speckle, temporal variability and a regression or retrieval-model term ``covered`` [(source,
    group)] lacks (``sources: all`` needs speckle and the retrieval term; temporal is named when absent)."""
    names = [s for s, _ in covered]
    return [word for word, present in (
        ("speckle", any(s in SPECKLE for s in names)),
        ("temporal", any(s in TEMPORAL for s in names)),
        ("regression/retrieval-model", any(g in RETRIEVAL_GROUPS for _, g in covered)
         or "assumed_retrieval" in names),
    ) if not present]


def coverage_text(covered: list, left_out: list, which: str, assumed: dict | None = None) -> str:
    """The covered sources in words, by group, and what is missing: "systematic (crosstalk, ...) + random (speckle
    and noise, ...); no regression or retrieval-model term in this chain"."""
    text = " + ".join(_group_words(covered, assumed)) or "no error source"
    if which == SYSTEMATIC and left_out:
        text += "; left out (sources: systematic): the chain's " + " + ".join(_group_words(left_out))
    missing = missing_terms(covered + left_out)
    if missing:
        text += "; no " + _either(missing) + " term in this chain"
    return text


def _group_words(pairs: list, assumed: dict | None = None) -> list:
    """One phrase per group of [(source, group)]: "random (speckle and noise, temporal variability)"."""
    groups: dict = {}
    for source, group in pairs:
        groups.setdefault(group, []).append(source)
    parts = []
    for group, sources in groups.items():
        if group == ASSUMED:
            words = [ASSUMED_TERMS[k][1].format(v) for k, v in (assumed or {}).items()]
            parts.append(" + ".join(words) if words else "assumed (" + ", ".join(sources) + ")")
        elif group in ("regression", "model") and sources == [group]:
            parts.append(GROUP_WORDS[group])
        else:
            parts.append(f"{GROUP_WORDS.get(group, group)} ({', '.join(source_name(s) for s in sources)})")
    return parts


def _either(words: list) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def assumed_contributions(requirement, agb) -> tuple:
    """The requirement's assumed terms as ``AGBContribution``s of relative sigma errors (zero mean, independent):
    ``random_percent`` as stated (a relative error of the backscatter, as the terms of eq. 20 of Ahmed et al.
    2014), ``retrieval_agb_percent`` divided by the AGB error's local exponent p (q = (1 + x)^p - 1 ~ p x to first
    order, Men et al. 2021, eq. 16)."""
    from e2esim.retrieval.agb_error import AGBContribution

    out = []
    for key, value in assumed_values(requirement).items():
        name, words = ASSUMED_TERMS[key]
        x = value / 100.0 if key == "random_percent" else value / 100.0 / np.asarray(agb.exponent, dtype=float)
        variance = np.square(x)
        if np.ndim(variance) == 0:
            out.append(AGBContribution(name, ASSUMED, 0.0, float(variance), words.format(value)))
        else:  # a block of cases
            out.append(AGBContribution(name, ASSUMED, np.zeros_like(variance), variance, words.format(value)))
    return tuple(out)


__all__ = ["ASSUMED_TERMS", "assumed_contributions", "assumed_values", "chain_terms", "coverage_text",
           "missing_terms", "setting", "systematic_sources", "verdict_coverage"]
