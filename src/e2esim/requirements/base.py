"""What every requirement shares: the AGB error it checks, its basis, and the requirement base class."""

from __future__ import annotations

from abc import abstractmethod
from typing import ClassVar

import numpy as np

from e2esim.case_values import plain  # noqa: F401  (the Shapley split imports it from here)
from e2esim.module import Module, fail
from e2esim.params import Param, ParamGroup
from e2esim.requirements.allocation import check_allocation
from e2esim.requirements.checked_model import agb_error_of
from e2esim.requirements.coverage import assumed_contributions
from e2esim.requirements.verdict import RequirementVerdict
from e2esim.retrieval.agb_error import AGBError

BASES = ("auto", "analytic", "montecarlo")
SOURCE_CHOICES = ("computed", "all", "systematic")
PERCENT = 100.0


def largest(values: list):
    """The largest of per-side values: ``max`` for one case, element-wise for a block."""
    return max(values) if all(np.ndim(v) == 0 for v in values) else np.maximum.reduce(values)


def truth(x):
    """A bool for one case, a bool array for a block."""
    return bool(x) if np.ndim(x) == 0 else np.asarray(x, dtype=bool)

SOURCES_PARAM = Param(
    "sources", "str", "error sources checked: computed (every source the chain computes: system, Faraday rotation, "
    "noise, error budget, regression, model; the verdict's coverage names them), all (the same, and e2esim "
    "validate refuses a chain without a speckle term and a regression or retrieval-model term unless they are "
    "stated under assumed) or systematic (system distortions, Faraday rotation and noise only: the criterion of "
    "Men et al. 2021)", default="computed", choices=SOURCE_CHOICES)
ASSUMED_PARAM = ParamGroup("assumed", "error terms the chain does not compute, stated as assumed values (1 sigma, "
                           "zero mean, independent of every other term) so that sources: all can be checked; they "
                           "enter the checked value analytically and the coverage says they are assumed", (
    Param("random_percent", "float", "relative error of the backscatter from speckle and the other random terms of "
          "the product (Ahmed et al. 2014, eq. 20), together", default=None, unit="%", exclusive_minimum=0.0,
          maximum=1000.0, nullable=True),
    Param("retrieval_agb_percent", "float", "relative AGB error of the retrieval model (regression and model "
          "uncertainty), entered through the local exponent of the AGB error", default=None, unit="%",
          exclusive_minimum=0.0, maximum=1000.0, nullable=True),
))
SCOPE_SUFFIXES = {"computed": " (computed sources)", "all": " (all sources)", "systematic": " (system errors)"}
ASSUMED_SHORT = {"random_percent": "random", "retrieval_agb_percent": "retrieval model"}


def scope_suffix(config: dict) -> str:
    """The end of a generated requirement label: which sources it checks, and which of them are assumed."""
    assumed = [ASSUMED_SHORT[k] for k, v in (config.get("assumed") or {}).items() if v is not None]
    if config["sources"] == "all" and assumed:
        return f" (all sources, {' and '.join(assumed)} assumed)"
    return SCOPE_SUFFIXES[config["sources"]]


NAME_PARAM = Param("name", "str", "label in reports (null: generated)", default=None, nullable=True)
BASIS_PARAM = Param("basis", "str", "analytic Gaussian model or Monte Carlo samples (auto: analytic when computed)",
                    default="auto", choices=BASES)


def agb_requirement_params(*own, after: tuple = ()) -> tuple:
    """The parameters of an AGB requirement: its name, its own ``own`` (its limit), the basis, the sources checked
    and the assumed terms every AGB requirement takes, then ``after``."""
    return (NAME_PARAM, *own, BASIS_PARAM, SOURCES_PARAM, ASSUMED_PARAM, *after)


class Requirement(Module):
    """A mission requirement on the AGB error: ``evaluate`` gives the verdict of one case.

    Requirements are not stages themselves: the scenario's ``requirements`` list is one stage
    (``e2esim.requirements.stage.RequirementSet``) that evaluates them in order and provides ``verdicts``.
    ``needs`` and ``uses`` name the products a requirement reads.
    """

    kind = "requirement"
    needs: ClassVar[tuple] = ("agb.error", "backscatter.error")
    uses: ClassVar[tuple] = ("instrument",)
    batched: ClassVar[bool] = False
    """``evaluate`` also takes a block of cases (``e2esim.block.Block``: the AGB error and the error model with
    their case axis, other products read with ``case.column`` or ``case.common``; element-wise numpy operations
    throughout, no ``float()`` of what it reads): the requirement set then evaluates whole blocks."""

    def setup(self):
        check_allocation(self)

    @property
    @abstractmethod
    def label(self) -> str:
        """The requirement's name in reports."""

    @abstractmethod
    def evaluate(self, case) -> RequirementVerdict:
        """The verdict of this requirement on ``case``."""


def checked_error(requirement: Requirement, case) -> AGBError:
    """The AGB error a requirement checks: from every source the chain computes (``computed``, ``all``; with the
    requirement's assumed terms, ``with_assumed``), or only from the systematic error of the propagation's error
    model, system distortions, Faraday rotation and noise (``systematic``, the criterion of Men et al. 2021),
    leaving out the random-error budget, the regression uncertainty and the model term (the uncertainty of
    the retrieval's exponents and coefficients): ``AGBError.systematic``."""
    agb = agb_error_of(case)
    if requirement.si["sources"] == "systematic":
        return agb.systematic()
    return with_assumed(requirement, agb)


def with_assumed(requirement: Requirement, agb: AGBError) -> AGBError:
    """``agb`` with the requirement's assumed terms (``e2esim.requirements.coverage.assumed_contributions``) added
    (``AGBError.with_terms``); analytic only: the Monte Carlo samples are left out (a verdict note says so)."""
    extra = assumed_contributions(requirement, agb)
    if not extra:
        return agb
    if agb.error_mean is None:
        raise fail(requirement, "the assumed terms are combined with the analytic AGB error, which this simulation "
                   "mode does not compute", "use simulation mode analytic or both", key="assumed")
    return agb.with_terms(extra)


def basis_of(requirement: Requirement, case, agb: AGBError) -> str:
    """The basis a verdict uses: the configured one, or analytic when computed (``auto``)."""
    basis = requirement.si["basis"]
    if basis == "auto":
        return "analytic" if agb.has("analytic") else "montecarlo"
    if not agb.has(basis):
        raise fail(requirement, f"{basis!r} results are not computed in simulation mode {case.settings.mode!r}",
                   "use basis: auto, or a simulation mode that computes them", key="basis")
    return basis
