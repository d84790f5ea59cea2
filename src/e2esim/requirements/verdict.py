"""The verdict of a requirement on one case, and the verdicts of all requirements of a case."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from e2esim.block import Batched

STATUSES = ("pass", "fail", "not_applicable")
"""The three states of a verdict: the checked value meets the limit, it does not, or the requirement does not apply
to the case (outside its stated range): then there is no margin and nothing passes."""


@dataclass(frozen=True)
class RequirementVerdict:
    """Verdict of one requirement for one case.

    name : label of the requirement. passed : True only when the requirement applies and is met (``status``
    "pass"). value : the quantity checked, limit : its bound, margin : how far inside the bound (positive passes;
    NaN where the requirement does not apply), all in ``unit``. basis : "analytic" or "montecarlo". details :
    further numbers (exceedance probabilities, cross-checks, level margins in dB). curves : trade-off curves and
    other arrays (name -> ndarray), possibly empty. dominant : the error source whose removal would reduce
    ``value`` most ("" if not attributed). notes : remarks for the report, e.g. why margins or attribution are not
    available for this case. applicable : whether the requirement applies to the case; reason : why not ("" where
    it applies). coverage : the error sources the checked value contains, as the chain computed them
    (``e2esim.requirements.coverage``); coverage_text : the same in words, with what the chain leaves out.

    A verdict that does not apply is normalised on construction: ``passed`` False, ``margin`` NaN. For a block of
    cases (``RequirementVerdicts`` of a block) the numbers, ``passed`` and ``applicable`` are arrays over the cases.
    """

    name: str
    passed: bool
    value: float
    limit: float
    margin: float
    unit: str
    basis: str
    details: dict = field(default_factory=dict)
    curves: dict = field(default_factory=dict)
    dominant: str = ""
    notes: tuple = ()
    applicable: bool = True
    reason: str = ""
    coverage: tuple = ()
    coverage_text: str = ""

    def __post_init__(self):
        applicable = self.applicable
        if np.ndim(applicable) == 0:
            applicable = bool(applicable)
            object.__setattr__(self, "applicable", applicable)
            if applicable:
                object.__setattr__(self, "reason", "")
            else:
                object.__setattr__(self, "passed", False)
                object.__setattr__(self, "margin", float("nan"))
            return
        applicable = np.asarray(applicable, dtype=bool)
        object.__setattr__(self, "applicable", applicable)
        if not applicable.all():
            object.__setattr__(self, "passed", np.asarray(self.passed, dtype=bool) & applicable)
            object.__setattr__(self, "margin", np.where(applicable, self.margin, np.nan))

    @property
    def status(self):
        """"pass", "fail" or "not_applicable" (an array of them for a block)."""
        if np.ndim(self.applicable) == 0 and np.ndim(self.passed) == 0:
            return "not_applicable" if not self.applicable else "pass" if self.passed else "fail"
        return status_of(self.passed, self.applicable)


def status_of(passed, applicable) -> np.ndarray:
    """The status of every case from its ``passed`` and ``applicable`` (bool arrays)."""
    return np.where(~np.asarray(applicable, dtype=bool), "not_applicable",
                    np.where(np.asarray(passed, dtype=bool), "pass", "fail")).astype(object)


def passed_scalar(passed, applicable):
    """``requirement<i>.passed``: 1 passes, 0 fails, NaN where the requirement does not apply."""
    return np.where(applicable, np.asarray(passed, dtype=float), np.nan)


@dataclass(frozen=True)
class RequirementVerdicts(Batched):
    """The verdicts of the requirements, in the order of the scenario's ``requirements`` (product ``verdicts``).

    verdicts : one ``RequirementVerdict`` per requirement. n : the cases they answer for: 1 for a case, B for a
    block of sweep cases, whose verdicts' numbers, ``passed``, ``applicable`` and dominant sources are arrays over
    the cases (or one value for all). Iterating and indexing go over the requirements, ``len`` counts the cases
    (``e2esim.block.Batched``).
    """

    verdicts: tuple = ()
    n: int = 1

    def __iter__(self):
        return iter(self.verdicts)

    def __bool__(self) -> bool:
        return True

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, i) -> RequirementVerdict:
        return self.verdicts[i]

    def scalars(self) -> dict:
        """``requirement<i>.passed`` (1 passes, 0 fails, NaN not applicable), ``.value`` and ``.margin`` (NaN not
        applicable) in each requirement's unit, of one case."""
        out = {}
        for i, v in enumerate(self.verdicts):
            out[f"requirement{i}.passed"] = float(passed_scalar(v.passed, v.applicable))
            out[f"requirement{i}.value"] = v.value
            out[f"requirement{i}.margin"] = v.margin
        return out

    def item(self, i: int) -> RequirementVerdicts:
        return RequirementVerdicts(tuple(_verdict_at(v, i) for v in self.verdicts))

    def take(self, positions) -> RequirementVerdicts:
        positions = np.asarray(positions)
        return RequirementVerdicts(tuple(_verdict_take(v, positions) for v in self.verdicts), len(positions))

    @classmethod
    def concatenate(cls, parts: list) -> RequirementVerdicts:
        n = sum(p.n for p in parts)
        return RequirementVerdicts(tuple(_verdict_join([p.verdicts[j] for p in parts], [p.n for p in parts])
                                         for j in range(len(parts[0].verdicts))), n)

    def scalar_columns(self) -> dict:
        out = {}
        for i, v in enumerate(self.verdicts):
            out[f"requirement{i}.passed"] = np.broadcast_to(passed_scalar(v.passed, v.applicable), (self.n,))
            out[f"requirement{i}.value"] = np.broadcast_to(np.asarray(v.value, dtype=float), (self.n,))
            out[f"requirement{i}.margin"] = np.broadcast_to(np.asarray(v.margin, dtype=float), (self.n,))
        return out


def _at(x, i: int):
    return x[i] if isinstance(x, np.ndarray) and x.ndim else x


def curves_at(curves: dict, i: int) -> dict:
    """Case ``i``'s trade-off curves of a verdict whose curves carry the case axis (2-D) or are shared (1-D)."""
    return {name: (c[i] if c.ndim == 2 else c) for name, c in curves.items()}


def _verdict_at(v: RequirementVerdict, i: int) -> RequirementVerdict:
    return RequirementVerdict(
        name=v.name, passed=bool(_at(v.passed, i)), value=float(_at(v.value, i)), limit=float(_at(v.limit, i)),
        margin=float(_at(v.margin, i)), unit=v.unit, basis=v.basis,
        details={k: float(_at(x, i)) for k, x in v.details.items()}, curves=curves_at(v.curves, i),
        dominant=str(_at(v.dominant, i)), notes=v.notes, applicable=bool(_at(v.applicable, i)), reason=v.reason,
        coverage=v.coverage, coverage_text=v.coverage_text)


def _verdict_take(v: RequirementVerdict, positions) -> RequirementVerdict:
    def take(x):
        return x[positions] if isinstance(x, np.ndarray) and x.ndim else x

    return RequirementVerdict(v.name, take(v.passed), take(v.value), take(v.limit), take(v.margin), v.unit, v.basis,
                              {k: take(x) for k, x in v.details.items()},
                              {k: (c[positions] if c.ndim == 2 else c) for k, c in v.curves.items()},
                              take(v.dominant), v.notes, take(v.applicable), v.reason, v.coverage, v.coverage_text)


def _verdict_join(parts: list, sizes: list) -> RequirementVerdict:
    def join(get, dtype=None):
        values = [get(p) for p in parts]
        if all(not (isinstance(x, np.ndarray) and x.ndim) for x in values) and all(x == values[0] for x in values):
            return values[0]
        return np.concatenate([np.broadcast_to(np.asarray(x, dtype=dtype), (n,)) for x, n in zip(values, sizes)])

    first = parts[0]
    curves = {}
    for name, c in first.curves.items():
        curves[name] = np.concatenate([p.curves[name] for p in parts]) if c.ndim == 2 else c
    return RequirementVerdict(first.name, join(lambda p: p.passed, bool), join(lambda p: p.value, float),
                              join(lambda p: p.limit, float), join(lambda p: p.margin, float), first.unit, first.basis,
                              {k: join(lambda p, k=k: p.details[k], float) for k in first.details}, curves,
                              join(lambda p: p.dominant, object), first.notes, join(lambda p: p.applicable, bool),
                              first.reason, first.coverage, first.coverage_text)
