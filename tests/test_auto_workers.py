"""``--workers auto`` (e2esim.runner.auto_workers): the first block in this process, the rest on worker processes
only when it is estimated above the threshold and the process may use more than one core. The decision is checked
here without running a block (a clock and ``run_blocks`` stood in); that both paths give the serial numbers bit for
bit is checked in test_parallel_and_resume.py."""

import threading

import numpy as np
import pytest

from e2esim.cli import main
from e2esim.errors import UserError
from e2esim.runner import auto_workers, outputs
from e2esim.runner.auto_workers import AUTO_PARALLEL_ABOVE_S, THRESHOLD_VARIABLE, parallel_threshold_s, run_auto


def _split(cases, workers):
    """Blocks of 4 cases for one worker, of 1 case for several (as block_tasks sizes Monte Carlo blocks)."""
    size = 4 if workers == 1 else 1
    return [cases[i:i + size] for i in range(0, len(cases), size)]


def _auto(monkeypatch, cases=12, first_block_s=1.0, cores=2, threshold=None):
    """Run ``run_auto`` with a first block that takes ``first_block_s``; the calls of run_blocks made and the
    choice."""
    if threshold is None:
        monkeypatch.delenv(THRESHOLD_VARIABLE, raising=False)
    else:
        monkeypatch.setenv(THRESHOLD_VARIABLE, str(threshold))
    monkeypatch.setattr(auto_workers, "usable_cores", lambda: cores)
    now, calls, events = [0.0], [], []

    def fake_run_blocks(resolved, tasks, take, workers, **options):
        calls.append(([list(t) for t in tasks], workers, options["stage_memo"]))
        if workers > 1:
            events.append("fork")
        if options.get("started") is not None:  # run_blocks calls it once its workers have started
            options["started"]()
        events.append("run")
        now[0] += first_block_s * sum(len(t) for t in tasks) / 4

    monkeypatch.setattr(auto_workers, "run_blocks", fake_run_blocks)
    choice = run_auto(None, np.arange(cases), _split, None, {}, after_forks=lambda: events.append("after forks"),
                      clock=lambda: now[0], on_pool=lambda workers: events.append(f"pool of {workers}"))
    return calls, choice, events


def test_a_run_whose_rest_is_estimated_above_the_threshold_goes_to_a_pool_after_its_first_block(monkeypatch):
    calls, choice, events = _auto(monkeypatch, cases=12, first_block_s=1.1)  # the 8 cases left: 2.2 s
    assert [c[1] for c in calls] == [1, 2] and calls[0][0] == [[0, 1, 2, 3]]
    assert calls[1][0] == [[k] for k in range(4, 12)]  # split again for two workers
    assert calls[0][2] is calls[1][2]  # the workers start from this process's stage memo
    # the report's import thread starts once the workers are forked; the progress bar measures the pool's rate afresh
    assert events == ["run", "pool of 2", "fork", "after forks", "run"]
    assert choice.workers == 2 and choice.estimate_s == pytest.approx(2.2)
    assert choice.describe() == ("auto: 2 local processes after the first block (the 8 blocks left estimated at "
                                 "2.2 s, above 2 s; 2 cores usable)")


@pytest.mark.parametrize("cores, expected", [(2, 2), (8, 8), (16, 8)])
def test_the_pool_has_as_many_workers_as_cores_and_never_more_than_the_blocks_left(monkeypatch, cores, expected):
    calls, choice, _ = _auto(monkeypatch, cases=12, first_block_s=3.0, cores=cores)
    assert calls[-1][1] == expected == choice.workers


def test_a_short_run_stays_in_this_process(monkeypatch):
    calls, choice, events = _auto(monkeypatch, cases=12, first_block_s=0.9)  # the rest: 1.8 s
    assert AUTO_PARALLEL_ABOVE_S == 2.0
    assert [c[1] for c in calls] == [1, 1] and calls[1][0] == [[4, 5, 6, 7], [8, 9, 10, 11]]
    assert events == ["run", "after forks", "run"] and choice.workers == 1  # the import thread meanwhile
    assert choice.describe() == "auto: this process (the rest estimated at 1.8 s, not above 2 s)"


@pytest.mark.parametrize("cases, cores, said", [(4, 2, "one block"), (12, 1, "one core usable"),
                                               (0, 2, "nothing left to run")])
def test_one_block_or_one_core_runs_everything_here_without_timing(monkeypatch, cases, cores, said):
    calls, choice, events = _auto(monkeypatch, cases=cases, first_block_s=100.0, cores=cores)
    assert len(calls) == 1 and calls[0][1] == 1 and events == ["after forks", "run"]  # every block here, none timed
    assert choice.describe() == f"auto: this process ({said})"


def test_a_daemonic_process_runs_everything_here(monkeypatch):
    """e2esim.run in a worker of someone's multiprocessing pool: Python forbids it children."""
    monkeypatch.setattr(auto_workers, "may_start_processes", lambda: False)
    calls, choice, events = _auto(monkeypatch, cases=12, first_block_s=100.0, cores=2)
    assert len(calls) == 1 and events == ["after forks", "run"] and choice.workers == 1
    assert choice.describe() == "auto: this process (a daemonic process, which may have no workers)"


def test_the_threshold_comes_from_the_environment(monkeypatch):
    _, choice, _ = _auto(monkeypatch, cases=12, first_block_s=0.01, threshold=0)
    assert choice.workers == 2 and "above 0 s" in choice.describe()
    monkeypatch.setenv(THRESHOLD_VARIABLE, "")
    assert parallel_threshold_s() == AUTO_PARALLEL_ABOVE_S


@pytest.mark.parametrize("text", ["soon", "-1", "nan", "inf"])
def test_a_bad_threshold_is_refused_with_a_message(monkeypatch, text):
    monkeypatch.setenv(THRESHOLD_VARIABLE, text)
    with pytest.raises(UserError, match=f"{THRESHOLD_VARIABLE}='{text}': expected a number of seconds >= 0"):
        parallel_threshold_s()


def test_usable_cores_is_at_least_one():
    assert auto_workers.usable_cores() >= 1


@pytest.mark.parametrize("given, said", [("two", "argument --workers: 'two': expected a number of processes >= 1, "
                                                  "or auto"),
                                         ("0", "--workers 0: expected a number of processes >= 1, or auto")])
def test_the_command_line_takes_auto_or_a_number(tmp_path, capsys, given, said):
    with pytest.raises(SystemExit) if given == "two" else _returns(2):
        raise SystemExit(main(["run", str(tmp_path / "none.yaml"), "--workers", given]))
    assert said in capsys.readouterr().err


class _returns:
    """A context in which ``SystemExit(status)`` is expected."""

    def __init__(self, status):
        self.status = status

    def __enter__(self):
        return self

    def __exit__(self, kind, value, tb):
        assert kind is SystemExit and value.code == self.status
        return True


def test_a_deferred_report_import_starts_only_when_asked_and_once(monkeypatch):
    """--workers auto: the report's import thread starts once the workers are forked (``run_blocks``' ``started``),
    never before; a run that never asks leaves the import to ``write_outputs``."""
    imported = []
    monkeypatch.setattr(outputs, "_import_report", lambda: imported.append(threading.current_thread().name))
    with outputs.report_imported_meanwhile(True, deferred=True) as start:
        assert imported == [] and "e2esim-report-import" not in {t.name for t in threading.enumerate()}
        start()
        start()
    assert imported == ["e2esim-report-import"]
    with outputs.report_imported_meanwhile(True, deferred=True):
        pass
    with outputs.report_imported_meanwhile(True) as start:  # a serial run: at once
        pass
    assert imported == ["e2esim-report-import"] * 2
