"""What every requirement shares: the AGB error it checks, its basis, and the requirement base class."""

from __future__ import annotations

import dataclasses
from abc import abstractmethod
from typing import ClassVar

import numpy as np

from e2esim.module import Module, fail
from e2esim.params import Param
from e2esim.requirements.verdict import RequirementVerdict
from e2esim.retrieval.agb_error import AGBError

BASES = ("auto", "analytic", "montecarlo")
SOURCE_CHOICES = ("all", "systematic")
PERCENT = 100.0


def plain(x):
    """A float for one case, the array for a block of cases (requirements are evaluated on either)."""
    return float(x) if np.ndim(x) == 0 else np.asarray(x, dtype=float)


def largest(values: list):
    """The largest of per-side values: ``max`` for one case, element-wise for a block."""
    return max(values) if all(np.ndim(v) == 0 for v in values) else np.maximum.reduce(values)


def truth(x):
    """A bool for one case, a bool array for a block."""
    return bool(x) if np.ndim(x) == 0 else np.asarray(x, dtype=bool)

SOURCES_PARAM = Param(
    "sources", "str", "error sources checked: all (system, Faraday rotation, noise, error budget, regression, model) "
    "or systematic (system distortions, Faraday rotation and noise only: the criterion of Men et al. 2021)",
    default="all", choices=SOURCE_CHOICES)
BASIS_PARAM = Param("basis", "str", "analytic Gaussian model or Monte Carlo samples (auto: analytic when computed)",
                    default="auto", choices=BASES)


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
    """``evaluate`` also takes a block of cases read through ``e2esim.block.BlockView`` (element-wise numpy
    operations throughout, no ``float()`` of what it reads): the requirement set then evaluates whole blocks."""

    @property
    @abstractmethod
    def label(self) -> str:
        """The requirement's name in reports."""

    @abstractmethod
    def evaluate(self, case) -> RequirementVerdict:
        """The verdict of this requirement on ``case``."""


def error_model_of(case):
    """The single-channel error model the case's AGB error maps: the one the retrieval names (a channel or a
    channel combination of a multi-channel model), else ``backscatter.error``."""
    model = getattr(case["agb.error"], "error_model", None)
    return model if model is not None else case["backscatter.error"]


def checked_error(requirement: Requirement, case) -> AGBError:
    """The AGB error a requirement checks: from every source (``all``), or only from the systematic error of
    the propagation's error model, system distortions, Faraday rotation and noise (``systematic``, the
    criterion of Men et al. 2021), leaving out the random-error budget, the regression uncertainty and the model term
    (the uncertainty of the retrieval's exponents and coefficients)."""
    agb = case["agb.error"]
    if requirement.si["sources"] == "all" or not agb.contributions:
        return agb
    model = error_model_of(case)
    m = model.current() if model.unavailable is None else None
    if np.ndim(agb.exponent):  # a block of cases (e2esim.retrieval.agb_error_block): analytic only
        return dataclasses.replace(agb, sigma_hv=np.asarray(model.value, dtype=float), error_mean=np.asarray(m.mean),
                                   error_sd=np.asarray(m.sd), contributions=(), saturated_fraction=())
    return AGBError.from_sigma_errors(
        agb.exponent, model.value, None if m is None else float(m.mean), None if m is None else float(m.sd),
        model.relative_samples(), agb.mapping, error_model=agb.error_model,
    )


def basis_of(requirement: Requirement, case, agb: AGBError) -> str:
    """The basis a verdict uses: the configured one, or analytic when computed (``auto``)."""
    basis = requirement.si["basis"]
    if basis == "auto":
        return "analytic" if agb.has("analytic") else "montecarlo"
    if not agb.has(basis):
        raise fail(requirement, f"{basis!r} results are not computed in simulation mode {case.settings.mode!r}",
                   "use basis: auto, or a simulation mode that computes them", key="basis")
    return basis
