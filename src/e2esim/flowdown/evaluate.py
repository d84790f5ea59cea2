"""The requirements' margins of a scenario's cases at other values of one or two keys, through the engine.

Every call runs the scenario's chain with the batched engine (``e2esim.runner.run.run_scenario``) over *rows*: a
row is one case of the scenario with its own values of the solved keys. The rows become one zipped sweep group of
the case's sweep inputs and the keys' values, so that a row reads exactly what its case reads and the engine builds
each distinct configuration once. The margin is the verdict's (positive passes; NaN where the requirement does
not apply). The chain runs its analytic model (``simulation.mode: analytic``; a scenario that asks for the Monte
Carlo only is refused: its margins are noisy in the row's random stream) without the level margins and trade-off
curves of the requirements and the shares of the error sources (``verdicts_only``), which do not change a verdict.
"""

from __future__ import annotations

import copy

import numpy as np

from e2esim.case import KernelMemo
from e2esim.errors import UserError
from e2esim.io.array_cache import open_cache
from e2esim.key_paths import override_path
from e2esim.requirements.attribution import verdicts_only
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario

MEMO_BYTES = 256 * 2**20
"""The bound of the kernel memo the runs of a search share: the residual coefficients of a 3-pass stack at 119
rotation nodes are about 10 MB per geometry (each case, each Faraday-rotation difference, the ground-only scene)."""

EXTRAS = ("level_margins", "tradeoff_curve")
"""Requirement settings that add details to a verdict but never change it: off while solving."""


def _set(raw: dict, path: tuple, value) -> None:
    node = raw
    for part in path[:-1]:
        node = node.setdefault(part, {}) if isinstance(node, dict) else node[part]
    node[path[-1]] = value


class Evaluator:
    """Margins of every requirement in chosen cases at chosen values of ``keys`` (``SolveKey``s).

    scenario : the ``Scenario`` (its ``raw`` is copied). resolved : its ``ResolvedScenario``. workers : processes
    each run's blocks are spread over (``--workers``; the margins are the same as with one, block by block).
    The runs share one ``KernelMemo`` (``memo``, up to ``MEMO_BYTES``) where their blocks run in this process: a
    kernel whose work does not depend on the solved keys (the stack's coefficients in the residual rotation,
    ``e2esim.stack.residual_fourier``) is computed once for the whole search; a value found there is the kernel's
    own result. They read the array cache of the front doors (``e2esim.io.array_cache.open_cache``), as ``e2esim
    run`` does: a climatology's table is built once, not in every run; the memo keeps such a kernel's work there
    too (``KernelMemo.store``), so that a later solve of the same geometry finds it.
    """

    def __init__(self, scenario: Scenario, resolved, keys: tuple, workers: int = 1):
        raw = copy.deepcopy(scenario.raw)
        for section in ("solve", "allocate"):
            raw.pop(section, None)
        mode = resolved.cases[0].settings.mode
        if mode == "montecarlo":
            raise UserError(f"{scenario.source}: simulation.mode is montecarlo: solve and allocate need the analytic "
                            "model (mode analytic or both); its margins are smooth in the solved keys")
        raw.setdefault("simulation", {})["mode"] = "analytic"
        if isinstance(raw.get("output"), dict):
            raw["output"]["sensitivity"] = False  # asked of the run, not of every evaluation
        for module in resolved.cases[0].modules:
            if module.kind == "requirement":
                names = {p.name for p in type(module).params if hasattr(p, "name")}
                for extra in EXTRAS:
                    if extra in names:
                        _set(raw, tuple(module.location.key_path) + (extra,), False)
        if isinstance(raw.get("sweep"), dict) and "map" in raw["sweep"]:
            raise UserError(f"{scenario.source}: solve and allocate do not take a map sweep (sweep.map)")
        self.raw = raw
        self.source = scenario.source
        self.keys = tuple(keys)
        self.n = len(resolved.cases)
        self.names = list(resolved.requirement_names)
        self.labels = list(resolved.cases.labels) if resolved.plan is not None else [c.label for c in resolved.cases]
        self.inputs = resolved.plan.table.input_columns() if resolved.sweep_keys else {}
        self.calls = 0
        self.rows = 0
        self.workers = workers
        self.memo = KernelMemo(MEMO_BYTES, repeated_geometry=True, store=open_cache(None))

    def grid_margins(self, values: np.ndarray) -> np.ndarray:
        """(R, n, P) margins of every requirement in every case at each of P points ``values`` ((P, len(keys))):
        the scenario's sweep times the points, a grid (the sweep's own grid kept, so that each distinct module is
        built once)."""
        values = np.asarray(values, dtype=float).reshape(-1, len(self.keys))
        raw = copy.deepcopy(self.raw)
        names = [key.name for key in self.keys]
        points = [[key.value(v) for key, v in zip(self.keys, row)] for row in values]
        group = {names[0]: [p[0] for p in points]} if len(names) == 1 else {", ".join(names): points}
        sweep = raw.get("sweep")
        if isinstance(sweep, dict) and "parameters" in sweep and sweep.get("mode", "grid") == "grid":
            raw["sweep"] = {"mode": "grid", "parameters": {**sweep["parameters"], **group}}
        elif self.inputs:
            keys = list(self.inputs)
            rows = [[self.inputs[k][i] for k in keys] for i in range(self.n)]
            cases = {keys[0]: [r[0] for r in rows]} if len(keys) == 1 else {", ".join(keys): rows}
            raw["sweep"] = {"mode": "grid", "parameters": {**cases, **group}}
        else:
            raw["sweep"] = {"mode": "grid", "parameters": group}
        margins = self._run(raw, self.n * len(values))
        return margins.reshape(len(self.names), self.n, len(values))

    def _run(self, raw: dict, rows: int) -> np.ndarray:
        try:
            resolved = Scenario(raw, self.source).resolve()
            with verdicts_only():  # the margins alone: no shares of the sources
                result = run_scenario(resolved, progress=False, keep_products=False, spill=False,
                                      workers=self.workers, memo=self.memo, cache=open_cache)
        except UserError as exc:  # a value of the search range the chain refuses: say where, and what to do
            keys = ", ".join(key.name for key in self.keys)
            raise UserError(f"{exc} (while searching {keys}: narrow the search range with --bounds LO HI, or the "
                            "bounds of the allocate section's source)") from exc
        self.calls += 1
        self.rows += rows
        table = result.table
        if not hasattr(self, "limits"):
            self.limits = [np.asarray(r.limit, dtype=float) for r in table.requirements]
            self.units = [r.unit[0] if len(r.unit) else "" for r in table.requirements]
        return np.array([np.asarray(table.requirements[j].margin, dtype=float) for j in range(len(self.names))])

    def limit(self, j: int) -> float:
        """Requirement ``j``'s limit (the same in every case; after a first evaluation)."""
        return float(np.nanmax(self.limits[j]))

    def unit(self, j: int) -> str:
        return str(self.units[j])

    def margins(self, cases: np.ndarray, values: np.ndarray) -> np.ndarray:
        """(R, rows) margins of every requirement: row r is case ``cases[r]`` with the keys at ``values[r]``
        ((rows, len(keys)))."""
        cases = np.asarray(cases, dtype=np.int64)
        values = np.asarray(values, dtype=float).reshape(len(cases), len(self.keys))
        raw = copy.deepcopy(self.raw)
        sweep_keys = list(self.inputs)
        common = np.all(values == values[:1], axis=0) if len(cases) else np.ones(len(self.keys), bool)
        for k, key in enumerate(self.keys):  # a value shared by every row is set, not swept
            if common[k] and len(cases):
                _set(raw, override_path(key.name), key.value(values[0, k]))
        varied = [k for k in range(len(self.keys)) if not common[k]]
        if varied or not np.array_equal(cases, np.arange(self.n)):
            names = sweep_keys + [self.keys[k].name for k in varied]
            rows = [[self.inputs[s][c] for s in sweep_keys] + [self.keys[k].value(values[r, k]) for k in varied]
                    for r, c in enumerate(cases)]
            if not names:  # one case, no sweep: the rows are copies of it
                names, rows = ["simulation.seed"], [[raw.get("simulation", {}).get("seed", 0)]] * len(cases)
            group = {names[0]: [row[0] for row in rows]} if len(names) == 1 else {", ".join(names): rows}
            raw["sweep"] = {"mode": "grid", "parameters": group}
        return self._run(raw, len(cases))
