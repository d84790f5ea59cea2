"""The error budget of each verdict and of each case's AGB error, as rows for summary.json and the report.

Nothing physical is computed here; the rows are read from what the chain wrote:

* per verdict, from its shares (``share.<source>_<unit>``, ``e2esim.requirements.shares``): the part of the
  checked value each source accounts for, summing to it with ``share.interactions_<unit>``;
* per verdict, the split a budget line uses (``budget_split``): the Euler shares where the sources add, the Shapley
  split (``shapley.<source>_<unit>``, ``e2esim.requirements.shapley``) where they couple: where the Euler split
  leaves more than ``COUPLED`` of the checked value not attributed;
* per verdict, from its attribution (``contribution.<source>_<unit>`` in the details,
  ``e2esim.requirements.attribution``): how much the checked value falls when the source is removed, in the
  requirement's unit. A requirement on the systematic error lists only the error model's sources;
  one on every source also the random-error budget's terms, the regression uncertainty and the model term;
* per case, from the named contributions of the AGB error (``AGBError.contribution_stats``, written as the
  ``agb.contribution.<source>.*`` scalars): the relative AGB error each source causes on its own (mean, SD,
  RMSE in percent) and its share of the variance of the relative sigma error.
"""

from __future__ import annotations

from e2esim.requirements.shares import INTERACTIONS
from e2esim.requirements.source_names import source_name

SYSTEMATIC = "systematic"
GROUP_ORDER = ("systematic", "random", "regression", "model", "assumed")
UNIT_KEYS = {"%": "percent", "t/ha": "t_ha"}
"""The ending of a contribution key for a requirement unit (``e2esim.requirements.attribution``)."""

AGB_STATS = ("mean_percent", "sd_percent", "rmse_percent", "variance_share")
COUPLED = 0.01
"""The fraction of a checked value the Euler split may leave not attributed before a budget line takes the Shapley
split instead: below it the sources add (docs/theory/error-budget.md, Section 3)."""
EULER, SHAPLEY = "euler", "shapley"


def unit_key(unit: str) -> str:
    return UNIT_KEYS.get(unit, unit.replace("/", "_").replace(" ", "_"))


def source_groups(case) -> dict:
    """{source: group} of the case's AGB contributions; the error model's sources are systematic."""
    agb = case.get("agb.error")
    return {c.name: c.group for c in getattr(agb, "contributions", ())}


def budget_split(verdict) -> str | None:
    """Which split a verdict's budget line uses: ``"shapley"`` where its sources couple (the Euler split leaves more
    than ``COUPLED`` of the checked value not attributed) and it has the Shapley split, else ``"euler"``; None where
    it has no shares."""
    has_shapley = f"shapley.no_source_{unit_key(verdict.unit)}" in verdict.details
    return _split_of(interactions_share(verdict), verdict.value, has_shapley)


def _split_of(rest, value, has_shapley: bool) -> str | None:
    """The split of a budget line whose Euler remainder is ``rest`` (None: no shares) and checked value ``value``
    (``budget_split``)."""
    if rest is None:
        return None
    return SHAPLEY if has_shapley and abs(rest) > COUPLED * abs(value) else EULER


def verdict_budget(verdict, groups: dict) -> list:
    """[{source, group, contribution, share, shapley, split, part, unit}] of one verdict, largest first within each
    group: ``share`` is the source's Euler part of the checked value (``share.<source>_<unit>``, the parts and
    ``interactions_share`` sum to it), ``shapley`` its Shapley part (``shapley.<source>_<unit>``: the parts and
    ``shapley.no_source_<unit>`` sum to it), ``split`` the one the line uses (``budget_split``) and ``part`` that
    one's (None where the verdict has no shares)."""
    suffix = "_" + unit_key(verdict.unit)
    split = budget_split(verdict)
    rows = []
    for key, value in verdict.details.items():
        if key.startswith("contribution.") and key.endswith(suffix):
            source = key[len("contribution."):-len(suffix)]
            share = verdict.details.get(f"share.{source}{suffix}")
            shapley = verdict.details.get(f"shapley.{source}{suffix}")
            rows.append({"source": source, "group": groups.get(source, SYSTEMATIC), "contribution": value,
                         "share": share, "shapley": shapley, "split": split,
                         "part": shapley if split == SHAPLEY else share, "unit": verdict.unit})
    return sorted(rows, key=lambda r: (_group_rank(r["group"]), -abs(r["contribution"])))


def interactions_share(verdict):
    """The part of a verdict's checked value no single source accounts for (``share.interactions_<unit>``:
    where the error model couples its sources), or None where the verdict has no shares."""
    return verdict.details.get(f"share.{INTERACTIONS}_{unit_key(verdict.unit)}")


def unattributed(verdict):
    """The part of a verdict's checked value its budget line leaves to no source: the Euler remainder
    (``interactions_share``), or for a Shapley line what the error model keeps with every source taken away
    (``shapley.no_source_<unit>``, zero for the built-in models); None where the verdict has no shares."""
    if budget_split(verdict) == SHAPLEY:
        return verdict.details[f"shapley.no_source_{unit_key(verdict.unit)}"]
    return interactions_share(verdict)


def agb_budget(scalars: dict, groups: dict) -> list:
    """[{source, group, mean_percent, sd_percent, rmse_percent, variance_share}] of a case's AGB
    contributions, from its ``agb.contribution.<source>.*`` scalars."""
    rows = []
    for source, group in groups.items():
        prefix = f"agb.contribution.{source}."
        if prefix + "rmse_percent" in scalars:
            rows.append({"source": source, "group": group, **{k: scalars.get(prefix + k) for k in AGB_STATS}})
    return sorted(rows, key=lambda r: (_group_rank(r["group"]), -(r["rmse_percent"] or 0.0)))


def _group_rank(group: str) -> int:
    return GROUP_ORDER.index(group) if group in GROUP_ORDER else len(GROUP_ORDER)


def corrects_faraday(case) -> bool:
    """Whether the case's calibration corrects Faraday rotation (a step named ``*faraday*``): its error model then
    carries the residual rotation after correction (``faraday.residual``), not the geophysical one."""
    record = case.get("calibration")
    return any("faraday" in str(name) for name in getattr(record, "names", ()))


def budget_source_name(source: str, cases) -> str:
    """A source's words in a budget of ``cases``: Faraday rotation says whether it is the residual after correction
    (in every case, some of them, or none)."""
    words = source_name(source)
    if source != "faraday_rotation":
        return words
    corrected = [corrects_faraday(c) for c in cases]
    if corrected and all(corrected):
        return f"{words} (residual after correction)"
    return f"{words} (residual after correction where corrected)" if any(corrected) else words


def verdict_budgets(unit: str, values: list, details: dict, written: dict, groups: list) -> list:
    """``verdict_budget`` of every case of a block whose verdicts share ``unit`` and have every detail: ``values``
    the checked value per case, ``details`` {key: value per case}, ``written`` the same with the numbers as the
    rows are to hold them (summary.json's None for non-finite); the order and split are decided on ``details``.
    One list of rows per case, equal to ``verdict_budget`` of the case's verdict with ``written`` numbers."""
    suffix = "_" + unit_key(unit)
    sources = [key[len("contribution."):-len(suffix)] for key in details
               if key.startswith("contribution.") and key.endswith(suffix)]
    n = len(values)
    rest = details.get(f"share.{INTERACTIONS}{suffix}")
    has_shapley = f"shapley.no_source{suffix}" in details
    splits = [None] * n if rest is None else [_split_of(r, v, has_shapley) for r, v in zip(rest, values)]
    none = [None] * n
    columns = [(s, details[f"contribution.{s}{suffix}"], written[f"contribution.{s}{suffix}"],
                written.get(f"share.{s}{suffix}", none), written.get(f"shapley.{s}{suffix}", none)) for s in sources]
    out, ranks = [], {}
    for k in range(n):
        split = splits[k]
        rows = []
        for source, contribution, contribution_written, share, shapley in columns:
            group = groups[k].get(source, SYSTEMATIC)
            rank = ranks.get(group)
            if rank is None:
                rank = ranks[group] = _group_rank(group)
            rows.append(((rank, -abs(contribution[k])), {
                "source": source, "group": group, "contribution": contribution_written[k], "share": share[k],
                "shapley": shapley[k], "split": split, "part": shapley[k] if split == SHAPLEY else share[k],
                "unit": unit}))
        out.append([row for _, row in sorted(rows, key=lambda r: r[0])])
    return out
