"""The Python API: run a scenario and read results back, without the command line.

    import e2esim
    results = e2esim.run("scenarios/biomass_default.yaml", **{"simulation.realisations": 500})
    df = results.to_dataframe()                     # one row per case
    ds = results.to_xarray()                        # sweep keys as coordinates
    again = e2esim.open_results("runs/biomass_default")   # a results.h5 read back: the same interface

Overrides are dotted keys, as ``--set`` on the command line takes them, and go through the same rule
(``Scenario.override``); their values are Python values.
"""

from __future__ import annotations

import copy
import json
import warnings
from pathlib import Path

from e2esim.allocator import keep_freed_memory
from e2esim.results import Results
from e2esim.runner.folder_run import run_into_folder


class NoEffectWarning(UserWarning):
    """A swept, overridden or given setting that changes no result (``Results.settings_without_effect``)."""


def run(scenario, set: dict | None = None, output=None, force: bool = False, progress: bool = False,
        workers: int | str = "auto", engine: str = "batched", resume: bool = False, scheduler: str | None = None,
        **overrides) -> Results:
    """Run every case of ``scenario`` and return its ``Results``; write no file unless ``output`` names a
    folder. With a folder the run takes the path of ``e2esim run -o`` (``e2esim.runner.folder_run``): the folder
    is locked while the scenario runs and its outputs are written (a second run into it meanwhile is refused),
    an existing non-empty folder needs ``force`` (the earlier outputs are set aside until the new ones are
    complete), every finished block is kept in the resume journal, and results.h5, summary.json, the report and
    its plots are written atomically. A run stopped by Ctrl-C raises ``KeyboardInterrupt`` (a
    ``RunInterrupted`` saying how many cases were kept); ``resume`` continues it without recomputing them.

    scenario : a scenario file (path), a scenario as a dict (the YAML's content), or a ``Scenario``.
    set, overrides : dotted key -> value, e.g. ``set={"instrument.crosstalk.level_db": -28}`` or
        ``**{"simulation.realisations": 500}``; both may be given.
    engine : "batched" (blocks of cases at once) or "per_case" (one case at a time, the reference); the
        same numbers either way.
    workers, scheduler : run the cases on that many local processes ("auto": on as many as the machine gives this
        process, when the rest of the run is estimated above 2 s; ``e2esim.runner.auto_workers``), or on the
        dask.distributed cluster at that address (as ``--workers`` and ``--scheduler``); the same numbers either way.
    """
    keep_freed_memory()  # as e2esim run: the kernels keep the memory they free (e2esim.allocator)
    assignments = {**(set or {}), **overrides}
    resolved = load_scenario(scenario, assignments).resolve()
    result = run_into_folder(resolved, Path(output) if output is not None else None, force, resume,
                             progress=progress, command=f"e2esim.run({_describe(scenario)})", workers=workers,
                             scheduler=scheduler, engine=engine)
    results = Results.from_run(result)  # the facade, made once here: it holds the run (``results.run``)
    for message in results.settings_without_effect:
        warnings.warn(message, NoEffectWarning, stacklevel=2)
    return results


def load_scenario(scenario, assignments: dict | None = None):
    """A ``Scenario`` from a path, a dict or a ``Scenario`` (copied), with ``assignments`` applied."""
    from e2esim.errors import UserError
    from e2esim.runner.scenario import Scenario

    if isinstance(scenario, Scenario):
        loaded = Scenario(copy.deepcopy(scenario.raw), scenario.source, scenario.lines)
    elif isinstance(scenario, dict):
        loaded = Scenario(copy.deepcopy(scenario), "<scenario dict>")
    elif isinstance(scenario, (str, Path)):
        loaded = Scenario.load(scenario)
    else:
        raise UserError(f"e2esim.run: {type(scenario).__name__} is not a scenario; give a path, a dict or a Scenario")
    for key, value in (assignments or {}).items():
        loaded.override(f"{key}={json.dumps(value)}")  # JSON is YAML: the value arrives as given
    return loaded


def open_results(path) -> Results:
    """The ``Results`` of a run folder or its results.h5 file."""
    from e2esim.io.results_reader import read_results

    return read_results(path, Results)


def _describe(scenario) -> str:
    return repr(str(scenario)) if isinstance(scenario, (str, Path)) else type(scenario).__name__
