"""Running cases: one case through its chain (``run_case``, the reference path) and a block of cases of one chain
template (``run_block``, batched or case by case), with the services the runner hands to stages."""

from __future__ import annotations

import numpy as np

from e2esim.allocator import collector_paused
from e2esim.case import Case, Products, Services, process_memo
from e2esim.requirements.attribution import VERDICTS_ONLY
from e2esim.runner.blocks import BlockRun
from e2esim.runner.case_results import BlockResult, CaseResult
from e2esim.runner.columns import case_notes, requirement_columns, scalar_columns, source_group_column
from e2esim.runner.progress import tqdm
from e2esim.runner.records import case_scalars
from e2esim.runner.scenario import ResolvedScenario
from e2esim.runner.stage_products import checked_products


def case_generator(seed: int, index: int) -> np.random.Generator:
    """The random generator of case ``index`` for root ``seed``."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(index,))))


def default_services(progress: bool = False, cache=None, memo=None) -> Services:
    """What the runner hands to stages: the array cache of a module's setting (``cache(setting)``, handed in by
    whoever runs the scenario: the front doors give ``e2esim.io.array_cache.open_cache``; None: no cache), a
    progress bar for long kernels on the command line, and the kernel memo (``memo``, a ``KernelMemo`` handed in
    by whoever runs several scenarios of one geometry, e.g. a solve's engine runs; None: the process's own,
    ``process_memo``)."""
    return Services(cache=cache, progress=_progress_bar if progress else None,
                    memo=process_memo() if memo is None else memo)


def _progress_bar(iterable, total=None, description=""):
    return tqdm(iterable, total=total, desc=description, leave=False)


def run_case(spec, services: Services | None = None) -> CaseResult:
    """Pass one case through its chain of stages (``e2esim.module.Stage``): each stage reads the products it
    needs and returns its own, which are added to the case (never overwritten)."""
    case = Case(index=spec.index, inputs=spec.inputs, settings=spec.settings,
                rng=case_generator(spec.settings.seed, spec.settings.stream_of(spec.index)),
                services=services or default_services())
    for stage in spec.chain:
        case = case.adding(checked_products(stage, stage.forward(case)))
    declared = {p.name: p for stage in spec.chain for p in stage.provides}  # plug-in products included
    return CaseResult(spec.index, spec.inputs, spec.label, case.products, case_scalars(case.products, declared))


def run_block(resolved: ResolvedScenario, indices, engine: str = "batched", keep_products: bool = False,
              services: Services | None = None, memo=None) -> BlockResult:
    """The results of the cases ``indices`` (one chain template) of ``resolved``."""
    services = services or default_services()
    if engine == "per_case":
        result = BlockResult.from_cases([run_case(resolved.cases[int(i)], services) for i in indices])
        return result if keep_products else result.without_products()
    run = BlockRun(resolved.plan, indices, services, memo)
    products = run.run()
    n = len(run.indices)
    declared = {p.name: p for step in run.template.steps
                for p in resolved.plan.stage(step, run.objects[0]).provides}
    kept = None
    if keep_products:
        with collector_paused():  # tens of thousands of objects (the 10 deg scintillation/RFI map: 77,000)
            kept = [Products({name: value.item(k) for name, value in products.items()}) for k in range(n)]
    # the inverse solve reads the margins alone (verdicts_only): no output scalars, some of which (the stack's
    # cancellation residual) cost as much as the case's moments
    columns = {} if VERDICTS_ONLY.get() else scalar_columns(products, n, declared)
    return BlockResult(run.indices, columns,
                       requirement_columns(products.get("verdicts"), n),
                       case_notes(products.get("backscatter.error"), n),
                       source_group_column(products.get("agb.error"), n), kept)
