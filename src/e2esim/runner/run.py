"""Run every sweep case of a resolved scenario through its chain of stages.

Each case gets its own generator, ``numpy.random.Generator(PCG64(SeedSequence(seed, spawn_key=(i,))))``,
so its numbers depend only on the seed and its index, not on the order in which cases run or how many
run at once (numpy's parallel random-number guide; Scientific Python SPEC 7).
"""

from __future__ import annotations

import platform
import sys
from dataclasses import dataclass, field
from datetime import datetime, timezone

import numpy as np
from tqdm.auto import tqdm

import e2esim
from e2esim.case import Case, Products, Services
from e2esim.io.array_cache import open_cache
from e2esim.runner.executors import iter_results
from e2esim.runner.records import case_scalars
from e2esim.runner.scenario import CaseSpec, ResolvedScenario


@dataclass
class CaseResult:
    """Outcome of one case: its inputs, the products its stages made and the flattened scalars
    (``e2esim.runner.records``)."""

    index: int
    inputs: dict
    label: str
    products: Products
    scalars: dict

    def get(self, name: str, default=None):
        """The product ``name`` of this case, or ``default``."""
        return self.products.get(name, default)

    @property
    def verdicts(self) -> tuple:
        """The requirement verdicts, in scenario order (empty without requirements)."""
        verdicts = self.products.get("verdicts")
        return tuple(verdicts) if verdicts is not None else ()

    @property
    def notes(self) -> tuple:
        """Remarks of the propagation's error model (e.g. why the analytic model was not used)."""
        model = self.products.get("backscatter.error")
        return tuple(getattr(model, "notes", ())) if model is not None else ()


@dataclass
class ScenarioResult:
    """All cases of a run, with provenance (package version, seed, time, resolved scenario)."""

    scenario: ResolvedScenario
    cases: list
    provenance: dict = field(default_factory=dict)

    @property
    def requirement_names(self) -> list:
        return self.scenario.requirement_names


def case_generator(seed: int, index: int) -> np.random.Generator:
    """The random generator of case ``index`` for root ``seed``."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(index,))))


def default_services(progress: bool = False) -> Services:
    """What the runner hands to stages: the array cache of a module's setting, and a progress bar for long
    kernels on the command line."""
    return Services(cache=open_cache, progress=_progress_bar if progress else None)


def _progress_bar(iterable, total=None, description=""):
    return tqdm(iterable, total=total, desc=description, leave=False)


def run_case(spec: CaseSpec, services: Services | None = None) -> CaseResult:
    """Pass one case through its chain of stages (``e2esim.module.Stage``): each stage reads the products it
    needs and returns its own, which are added to the case (never overwritten)."""
    case = Case(index=spec.index, inputs=spec.inputs, settings=spec.settings,
                rng=case_generator(spec.settings.seed, spec.index), services=services or default_services())
    for stage in spec.chain:
        case = case.adding(checked_products(stage, stage.forward(case)))
    declared = {p.name: p for stage in spec.chain for p in stage.provides}  # plug-in products included
    return CaseResult(spec.index, spec.inputs, spec.label, case.products, case_scalars(case.products, declared))


def checked_products(stage, new) -> dict:
    """``new`` if it holds exactly the products ``stage`` declares, each of its declared type."""
    declared = {p.name: p for p in stage.provides}
    if not isinstance(new, dict) or set(new) != set(declared):
        got = ", ".join(new) if isinstance(new, dict) else type(new).__name__
        raise TypeError(f"{stage.identity} returned {got or 'nothing'}; it declares {', '.join(declared) or 'nothing'}")
    for name, value in new.items():
        declared[name].check(value, stage.identity)
    return new


def run_scenario(
    resolved: ResolvedScenario,
    progress: bool = True,
    command: str | None = None,
    workers: int = 1,
    scheduler: str | None = None,
    journal=None,
    finished: dict | None = None,
) -> ScenarioResult:
    """Run every case (serially, on ``workers`` local processes or on the dask cluster at ``scheduler``)
    with a progress bar; return the results in case order with their provenance.

    journal : a ``Journal`` that records each case as it finishes; finished : cases already done
        ({index: CaseResult}, from an interrupted run) that are not run again.
    """
    done = dict(finished or {})
    todo = [spec for spec in resolved.cases if spec.index not in done]
    bar = tqdm(total=len(resolved.cases), initial=len(done), desc=resolved.name, unit="case",
               disable=not progress, leave=False)
    try:
        for result, data in iter_results(todo, workers, scheduler):
            done[result.index] = result
            if journal is not None:
                journal.record(result, data)
            bar.update(1)
    finally:
        bar.close()
    results = [done[spec.index] for spec in resolved.cases]
    seeds = sorted({c.settings.seed for c in resolved.cases})
    provenance = {
        "e2esim_version": e2esim.__version__,
        "created_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "seed": seeds[0] if len(seeds) == 1 else seeds,
        "scenario_file": resolved.source,
        "command": command or " ".join(sys.argv),
        "python": platform.python_version(),
        "numpy": np.__version__,
    }
    if workers > 1 or scheduler:
        provenance["executor"] = f"dask {scheduler}" if scheduler else f"{workers} local processes"
    if finished:
        provenance["resumed_cases"] = len(finished)
    return ScenarioResult(resolved, results, provenance)
