"""Run every sweep case of a resolved scenario through its chain of modules.

Each case gets its own generator, ``numpy.random.Generator(PCG64(SeedSequence(seed, spawn_key=(i,))))``,
so its numbers depend only on the seed and its index, not on the order in which cases run or how many
run at once (numpy's parallel random-number guide; Scientific Python SPEC 7).
"""

from __future__ import annotations

import platform
import sys
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone

import numpy as np
from tqdm.auto import tqdm

import e2esim
from e2esim.chain import CaseState
from e2esim.runner.executors import iter_results
from e2esim.runner.records import case_scalars
from e2esim.runner.scenario import CaseSpec, ResolvedScenario


@dataclass
class CaseResult:
    """Outcome of one case: its inputs, the final state of the chain (without its generator) and the
    flattened scalars (``e2esim.runner.records``)."""

    index: int
    inputs: dict
    label: str
    state: CaseState
    scalars: dict


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


def run_case(spec: CaseSpec) -> CaseResult:
    """Pass one case through its chain of modules."""
    state = CaseState(index=spec.index, inputs=spec.inputs, settings=spec.settings,
                      rng=case_generator(spec.settings.seed, spec.index))
    for module in spec.chain:
        state = module.forward(state)
    state = replace(state, rng=None)
    return CaseResult(spec.index, spec.inputs, spec.label, state, case_scalars(state))


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
