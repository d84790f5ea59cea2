"""The verdict of a requirement on one case, and the verdicts of all requirements of a case."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class RequirementVerdict:
    """Verdict of one requirement for one case.

    name : label of the requirement. passed : verdict. value : the quantity checked, limit : its bound,
    margin : how far inside the bound (positive passes), all in ``unit``. basis : "analytic" or
    "montecarlo". details : further numbers (exceedance probabilities, cross-checks, level margins in dB).
    curves : trade-off curves and other arrays (name -> ndarray), possibly empty.
    dominant : the error source whose removal would reduce ``value`` most ("" if not attributed).
    notes : remarks for the report, e.g. why margins or attribution are not available for this case.
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


@dataclass(frozen=True)
class RequirementVerdicts:
    """The verdicts of a case, in the order of the scenario's ``requirements`` (product ``verdicts``)."""

    verdicts: tuple = ()

    def __iter__(self):
        return iter(self.verdicts)

    def __len__(self) -> int:
        return len(self.verdicts)

    def __getitem__(self, i) -> RequirementVerdict:
        return self.verdicts[i]

    def scalars(self) -> dict:
        """``requirement<i>.passed`` (1 or 0), ``.value`` and ``.margin`` in each requirement's unit."""
        out = {}
        for i, v in enumerate(self.verdicts):
            out[f"requirement{i}.passed"] = float(v.passed)
            out[f"requirement{i}.value"] = v.value
            out[f"requirement{i}.margin"] = v.margin
        return out
