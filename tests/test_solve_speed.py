"""What makes the inverse solve fast (issue 23, Speed) gives the numbers it gave before: budgets shared by instruments
that differ only where the budget does not look, and verdicts without the sources' shares while solving."""

from __future__ import annotations

import numpy as np

import e2esim
from e2esim.block import Catalog, Factor
from e2esim.budget.block import block_budgets
from e2esim.flowdown import boundary
from e2esim.flowdown.evaluate import Evaluator
from e2esim.flowdown.keys import solve_key
from e2esim.flowdown.report import solve_lines
from e2esim.requirements.attribution import verdicts_only
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario

CROSSTALK = "instrument.crosstalk.level_db"


def _catalog(values) -> Catalog:
    catalog = Catalog()
    for v in values:
        catalog.add(v)
    return catalog


def test_a_budget_is_made_once_per_scene_and_what_it_reads_of_the_instrument():
    scenes = _catalog([{"scene": "a"}, {"scene": "b"}])
    instruments = _catalog([{"nesz": 1.0, "crosstalk": c} for c in (-30, -25, -20)] + [{"nesz": 2.0,
                                                                                          "crosstalk": -30}])
    made = []

    def budget_of(scene, inst):
        made.append((scene["scene"], inst["nesz"]))
        return made[-1]
    scene = Factor(scenes, np.array([0, 0, 0, 1, 1, 1, 0, 1]))
    inst = Factor(instruments, np.array([0, 1, 2, 0, 1, 2, 3, 3]))
    budgets = block_budgets(scene, inst, {}, budget_of, reads=lambda i: i["nesz"])
    assert sorted(made) == [("a", 1.0), ("a", 2.0), ("b", 1.0), ("b", 2.0)]
    assert [budgets.item(i) for i in range(8)] == [("a", 1.0)] * 3 + [("b", 1.0)] * 3 + [("a", 2.0), ("b", 2.0)]
    made.clear()  # without ``reads``: one budget per scene and instrument, as before
    block_budgets(scene, inst, {}, budget_of)
    assert len(made) == 8


def _budget_scenario() -> dict:
    return {
        "name": "budget_shared",
        "scene": {"type": "forest_agb_model", "biome": "boreal"},
        "instrument": {"type": "biomass"},
        "ionosphere": {"type": "gaussian_faraday", "mean_deg": 5, "sd_deg": 5},
        "propagation": [{"type": "hv_backscatter_error"},
                        {"type": "backscatter_error_budget", "preset": "biomass_200m"}],
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_error_bound", "sources": "systematic", "bound_percent": 20},
                         {"type": "agb_rmse", "max_percent": 40}],
        "simulation": {"mode": "analytic", "seed": 1},
        "sweep": {"parameters": {"scene.agb_t_ha": [100, 300], CROSSTALK: [-35, -30, -25],
                                 "instrument.nesz_db": [-27, -20]}},
    }


def _run(raw, engine="batched"):
    return run_scenario(Scenario(raw, "budget_shared.yaml").resolve(), progress=False, engine=engine)


def test_shared_budgets_give_the_per_case_engines_numbers_bit_for_bit():
    batched, per_case = _run(_budget_scenario()), _run(_budget_scenario(), "per_case")
    for a, b in zip(batched.table.requirements, per_case.table.requirements):
        np.testing.assert_array_equal(np.asarray(a.value, float), np.asarray(b.value, float))
        np.testing.assert_array_equal(np.asarray(a.margin, float), np.asarray(b.margin, float))
    rmse = np.asarray(batched.table.requirements[1].value, float)
    assert len(np.unique(rmse)) == 12  # every case its own value: the swept NESZ reaches the budget


def test_verdicts_only_gives_the_same_margins_without_the_shares_or_the_output_scalars():
    full = _run(_budget_scenario())
    with verdicts_only():
        bare = _run(_budget_scenario())
    for a, b in zip(full.table.requirements, bare.table.requirements):
        np.testing.assert_array_equal(np.asarray(a.margin, float), np.asarray(b.margin, float))
        assert any(k.startswith(("share.", "contribution.")) for k in a.details)
        assert not any(k.startswith(("share.", "contribution.")) for k in b.details)
    assert len(full.table.scalars) > 0 and len(bare.table.scalars) == 0  # no output scalars: the solve reads none
    again = _run(_budget_scenario())  # the switch ends with its block
    assert set(again.table.requirements[0].details) == set(full.table.requirements[0].details)


def test_the_boundary_by_continuation_is_the_fully_scanned_one(monkeypatch):
    """Continuation along the first key (``boundary.COARSE``) gives the boundary of the full scan of every point
    (COARSE = 1), with fewer rows."""
    raw = _budget_scenario()
    raw["sweep"] = {"parameters": {"scene.agb_t_ha": [100, 300]}}
    args = (raw, [CROSSTALK, "instrument.channel_imbalance.level_db"])
    kwargs = {"bounds": [(-40, -20), (-45, -15)], "points": 19}
    fast = e2esim.solve(*args, **kwargs)
    monkeypatch.setattr(boundary, "COARSE", 1)
    full = e2esim.solve(*args, **kwargs)
    np.testing.assert_array_equal(fast.y, full.y)
    assert fast.state == full.state and fast.side == full.side and fast.binding == full.binding
    assert "met at" in fast.state and fast.rows < full.rows
    met = [i for i, state in enumerate(fast.state) if state == "met at"]
    for i in met:  # on the boundary the binding case keeps no margin, every other case keeps its own (>= 0)
        case = fast.labels.index(fast.binding[i][1])
        assert np.nanargmin(fast.case_margins[:, i]) == case and abs(fast.case_margins[case, i]) < 1e-3
        assert np.all(fast.case_margins[:, i] > -1e-3)
    lines = solve_lines("s", fast)
    assert lines[2].endswith(", ".join(f"{fast.x[i]:.4g}: <= {fast.y[i]:.4g}" for i in met))
    assert lines[3].startswith("  binding case: ")


class _Margins:
    """A stand-in evaluator: one requirement, one case, margin root(x) - y (no value of y meets where root < 0)."""

    def __init__(self, root):
        self.root, self.rows = root, 0

    def grid_margins(self, values):
        self.rows += len(values)
        return (self.root(values[:, 0]) - values[:, 1])[None, None, :]


def test_continuation_from_one_met_neighbour_keeps_the_full_scans_brackets(monkeypatch):
    """A point next to a scanned point where no value meets (the ends of biomass_fr_requirement's bias range) is
    bracketed from its met neighbour's bracket and the scan values next to it, where its root moved to the next
    scan interval too: the brackets and states of the full scan of every point, in fewer evaluations."""
    from e2esim.flowdown.scan import SCAN

    x, ys = np.linspace(-15.0, 15.0, 13), np.linspace(0.0, 30.0, SCAN)

    def root(v):
        return 9.5 * (1 - (v / 11.5) ** 2) + 0.7
    fast = _Margins(root)
    got = boundary._brackets(fast, x, ys)
    monkeypatch.setattr(boundary, "COARSE", 1)
    full = _Margins(root)
    want = boundary._brackets(full, x, ys)
    assert list(got[0]) == list(want[0]) and {"met at", "no value meets it"} == set(want[0])
    for a, b in zip(got[1:6], want[1:6]):
        np.testing.assert_array_equal(a, b)
    assert len({int(k) for k in np.searchsorted(ys, got[1][got[0] == "met at"])}) > 1  # roots in several intervals
    assert fast.rows <= 3 * full.rows // 4  # 85 of 117 here (the continuation between two met points alone: 117)


def test_the_margins_on_the_boundary_are_read_from_the_evaluations_that_found_it():
    """The boundary's margins at its points (every case's) are those the scan and the root search evaluated there:
    no engine run of their own; a point never evaluated is run (with the others)."""
    stub = _Margins(lambda v: 10.0 - v)
    recorded = boundary._Recorded(stub)
    points = np.array([[1.0, 2.0], [3.0, 4.5]])
    first = recorded.grid_margins(points)
    again = recorded.found(points[::-1])
    assert stub.rows == 2 and np.array_equal(again, first[..., ::-1])
    assert np.array_equal(recorded.found(np.array([[1.0, 2.0], [5.0, 1.0]])), [[[7.0, 4.0]]]) and stub.rows == 4


def test_the_provenance_asks_git_and_the_package_metadata_once_per_process(monkeypatch):
    """The solve runs the engine a dozen times; each run's provenance asked git twice (``git describe --dirty``
    refreshes the index) and parsed eleven packages' metadata: now once per process, the same answer."""
    from e2esim.runner import provenance

    provenance.source_commit.cache_clear()
    provenance._versions.cache_clear()
    first = (provenance.source_commit(), provenance.dependency_versions())
    calls = []
    monkeypatch.setattr(provenance.subprocess, "run", lambda *a, **k: calls.append(a) or None)
    monkeypatch.setattr(provenance.metadata, "version", lambda name: calls.append(name) or "changed")
    again = provenance.dependency_versions()
    again["numpy"] = "edited"  # a caller's copy: the next run's provenance is not changed by it
    assert (provenance.source_commit(), provenance.dependency_versions()) == first and not calls


def test_the_solve_on_several_workers_gives_the_serial_margins():
    """``--workers`` spreads each engine run's rows over processes, in blocks of other sizes: the same margins."""
    raw = _budget_scenario()
    raw["sweep"] = {"parameters": {"scene.agb_t_ha": [100, 300]}}
    scenario = Scenario(raw, "<test>")
    resolved = scenario.resolve()
    keys = tuple(solve_key(resolved, k) for k in (CROSSTALK, "instrument.channel_imbalance.level_db"))
    grid = np.array([[-40, -45], [-35, -30], [-30, -20], [-25, -35], [-22, -15], [-20, -40]], dtype=float)
    serial = Evaluator(scenario, resolved, keys).grid_margins(grid)
    np.testing.assert_array_equal(Evaluator(scenario, resolved, keys, workers=2).grid_margins(grid), serial)


def test_the_engine_runs_of_a_search_share_one_kernel_memo_and_the_array_cache(monkeypatch):
    """Every run of an ``Evaluator`` hands its stages the same ``KernelMemo``, kept over many rows of one geometry
    (``repeated_geometry``: the stack's residual coefficients are built once per search), and the front doors'
    array cache (a climatology's table is not rebuilt in every run)."""
    from e2esim.io.array_cache import open_cache
    from e2esim.runner import executors

    asked = []
    original = executors.default_services
    monkeypatch.setattr(executors, "default_services", lambda progress=False, cache=None, memo=None: asked.append(
        (cache, memo)) or original(progress, cache, memo))
    raw = _budget_scenario()
    raw["sweep"] = {"parameters": {"scene.agb_t_ha": [100, 300]}}
    scenario = Scenario(raw, "<test>")
    resolved = scenario.resolve()
    evaluator = Evaluator(scenario, resolved, (solve_key(resolved, CROSSTALK),))
    evaluator.grid_margins(np.array([[-40.0]]))
    evaluator.grid_margins(np.array([[-30.0], [-20.0]]))
    assert len(asked) == 2 and all(cache is open_cache and memo is evaluator.memo for cache, memo in asked)
    assert evaluator.memo.repeated_geometry
