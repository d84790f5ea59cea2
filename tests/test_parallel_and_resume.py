"""Sweeps on local processes and on a dask.distributed cluster give the serial numbers; an interrupted
sweep resumes without recomputing finished cases and leaves no corrupt file."""

import functools
import json
import signal
import time
from pathlib import Path

import pytest
import yaml
from cli_processes import e2esim_process as _cli

from e2esim.cli import main
from e2esim.runner import auto_workers
from e2esim.runner.auto_workers import THRESHOLD_VARIABLE
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario

SWEEP = """
name: sweep
scene: {type: forest_agb_model, biome: boreal}
instrument: {type: biomass}
ionosphere: {type: gaussian_faraday, mean_deg: 60, sd_deg: 5}
propagation: {type: hv_backscatter_error, mc_method: MC_METHOD}
requirements: [{type: agb_error_bound}]
simulation: {mode: both, seed: 11, looks: LOOKS, realisations: REALISATIONS}
sweep:
  parameters:
    scene.agb_t_ha: [50, 100, 150, 200, 250, 300]
    instrument.crosstalk.level_db: [-32, -28]
output: {plots: [verdicts]}
"""


def _scenario(tmp_path, method="fast", looks=20000, realisations=3000):
    path = tmp_path / "sweep.yaml"
    path.write_text(SWEEP.replace("MC_METHOD", method).replace("LOOKS", str(looks))
                    .replace("REALISATIONS", str(realisations)))
    return path


def _numbers(result):
    return [(c.index, c.inputs, c.scalars) for c in result.cases]


def test_local_processes_give_the_serial_numbers(tmp_path, monkeypatch):
    resolved = Scenario.load(_scenario(tmp_path)).resolve()
    serial = run_scenario(resolved, progress=False)
    parallel = run_scenario(resolved, progress=False, workers=2)
    assert _numbers(parallel) == _numbers(serial)
    assert parallel.provenance["executor"] == "2 local processes"
    # --workers auto forced onto its pool (threshold 0 s, two cores): the first block here, the rest in blocks of
    # two cases (POOL_BLOCK_MIN_CASES: 8 cases for 2 workers would be 1-case blocks) on two forked workers that start
    # from this process's stage memo; the same bits
    monkeypatch.setenv(THRESHOLD_VARIABLE, "0")
    monkeypatch.setattr(auto_workers, "usable_cores", lambda: 2)
    auto = run_scenario(resolved, progress=False, workers="auto")
    assert _numbers(auto) == _numbers(serial)
    assert auto.provenance["executor"] == "2 local processes"
    assert auto.provenance["workers"].startswith("auto: 2 local processes after the first block (the 4 blocks left")
    assert sorted(len(b) for b in auto.blocks) == [2] * 4 + [4]


def test_dask_local_cluster_gives_the_serial_numbers(tmp_path):
    distributed = pytest.importorskip("distributed")
    resolved = Scenario.load(_scenario(tmp_path)).resolve()
    serial = run_scenario(resolved, progress=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        on_dask = run_scenario(resolved, progress=False, scheduler=cluster.scheduler_address)
    assert _numbers(on_dask) == _numbers(serial)
    assert on_dask.provenance["executor"].startswith("dask tcp://")




def _saved(journal: Path) -> int:
    from e2esim.runner.journal import count_finished

    return count_finished(journal.parent) if (journal / "manifest.json").exists() else 0


def _wait_for_cases(journal: Path, n: int, proc, timeout=120):
    start = time.time()
    while time.time() - start < timeout:
        if _saved(journal) >= n:
            return
        if proc.poll() is not None:
            pytest.fail(f"run ended before {n} cases were saved: {proc.stderr.read()}")
        time.sleep(0.05)
    pytest.fail("timed out waiting for the journal")


@pytest.mark.parametrize("how", ["kill", "interrupt"])
def test_interrupted_sweep_resumes_without_recomputing(tmp_path, capsys, how):
    scenario = _scenario(tmp_path, method="brute_force", looks=1000, realisations=150)
    out = tmp_path / "out"
    journal = out / ".e2esim-partial"
    proc = _cli("run", str(scenario), "-o", str(out), "--no-progress")
    _wait_for_cases(journal, 3, proc)
    proc.send_signal(signal.SIGKILL if how == "kill" else signal.SIGINT)
    stderr = proc.communicate(timeout=60)[1]
    if how == "interrupt":
        assert proc.returncode == 130 and "run the same command with --resume" in stderr
        assert "Traceback" not in stderr
    assert not (out / "summary.json").exists() and not (out / "results.h5").exists()
    saved = _saved(journal)
    assert 3 <= saved < 12

    # without --resume the folder is protected (asked in this process: the exit status is main's return value)
    assert main(["run", str(scenario), "-o", str(out), "--no-progress"]) == 2
    assert "use --resume" in capsys.readouterr().err

    resumed = _cli("run", str(scenario), "-o", str(out), "--no-progress", "--resume")
    assert resumed.wait(300) == 0, resumed.stderr.read()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["resumed_cases"] == saved
    assert not journal.exists()

    assert [c["results"] for c in summary["cases"]] == _reference_results(scenario.read_text())


@functools.cache
def _reference_results(text: str) -> list:
    """The summary results of an uninterrupted run of the scenario ``text``, run once for the tests that ask (the
    kill and the interrupt resume the same scenario)."""
    reference = run_scenario(Scenario(yaml.safe_load(text), "sweep.yaml").resolve(), progress=False)
    return [_json_clean(c.scalars) for c in reference.cases]


def _json_clean(scalars):
    return json.loads(json.dumps({k: (v if v == v and abs(v) != float("inf") else None) for k, v in scalars.items()}))


def test_resume_refuses_a_different_scenario(tmp_path):
    scenario = _scenario(tmp_path)
    out = tmp_path / "out"
    resolved = Scenario.load(scenario).resolve()
    from e2esim.runner.journal import Journal
    from e2esim.runner.run import run_block

    journal = Journal(out, resolved)
    journal.start(resume=False)
    journal.record(run_block(resolved, [0]))  # the journal is created with its first block
    journal.close()
    proc = _cli("run", str(scenario), "-o", str(out), "--no-progress", "--resume", "--set", "simulation.seed=12")
    assert proc.wait(60) == 2 and "different scenario, seed or e2esim version" in proc.stderr.read()


def test_a_torn_last_record_is_cut_off(tmp_path):
    from e2esim.runner.journal import Journal
    from e2esim.runner.run import run_block

    resolved = Scenario.load(_scenario(tmp_path)).resolve()
    blocks = [run_block(resolved, [i]) for i in range(4)]
    journal = Journal(tmp_path / "out", resolved)
    journal.start(resume=False)
    for block in blocks[:3]:
        journal.record(block)
    journal.close()
    path = tmp_path / "out" / ".e2esim-partial" / "cases.journal"
    with open(path, "ab") as fh:  # half of a fourth record, as a killed process may leave it
        fh.write(path.read_bytes()[: len(path.read_bytes()) // 5])
    finished = list(Journal(tmp_path / "out", resolved).start(resume=True))
    assert [list(b.indices) for b in finished] == [[0], [1], [2]]
    assert finished[1].case(0, {}, "").scalars == blocks[1].case(0, {}, "").scalars
