"""Stopping the worker pool never hangs (issue 28 item 2, the rare hang of test_faults'
test_a_signal_under_workers...[SIGTERM]).

A worker sends its block's result to the main process through one pipe; a result over 16 KiB goes as a length
header, then the body. Stopping the run (Ctrl-C, SIGTERM, an error) kills the workers at once, so a worker can die
between the two: the pool's result reader (concurrent.futures' manager thread) then waits for the rest of the
body for ever, since the main process itself holds the pipe's writing end, and the main process hangs at exit
joining that thread. Here a worker writes such a half result on purpose, so the race happens every time."""

import os
import struct
import sys
import threading
import time
from pathlib import Path

import pytest
from test_parallel_and_resume import _scenario as _sweep

_MARK = "E2ESIM_TEST_MARKS"


def _half_sent_result(indices, options, resolved=None, then=lambda: time.sleep(3600)):
    """In a worker (forked, so it sees this module): write the length header of a 1 MB result and 10 bytes of
    its body to the pool's result pipe, as a worker killed mid-send leaves it, note it, and wait to be stopped."""
    frame = sys._getframe(1)
    while "result_queue" not in frame.f_locals:  # concurrent.futures.process._process_worker's
        frame = frame.f_back
    result_queue = frame.f_locals["result_queue"]
    with result_queue._wlock:
        os.write(result_queue._writer.fileno(), struct.pack("!i", 1_000_000) + b"x" * 10)
        (Path(os.environ[_MARK]) / f"half_sent{indices[0]}").touch()
        then()


def _half_sent_then_killed(indices, options, resolved=None):
    """Block 0's worker dies half-way through sending its result (killed from outside, say by the system when
    memory ran out); the other blocks wait for ever."""
    if indices[0] == 0:
        _half_sent_result(indices, options, then=lambda: os._exit(1))
    time.sleep(3600)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="workers forked from this process")
def test_stopping_the_workers_while_one_sends_its_result_ends_the_pool(tmp_path, monkeypatch):
    import multiprocessing

    from e2esim.runner import executors
    from e2esim.runner.scenario import Scenario

    if multiprocessing.get_start_method() != "fork":
        pytest.skip("the stand-in block function reaches the workers only when they are forked")
    monkeypatch.setenv(_MARK, str(tmp_path))
    monkeypatch.setattr(executors, "run_block_remote", _half_sent_result)
    resolved = Scenario.load(_sweep(tmp_path)).resolve()
    source = executors._ProcessBlocks(resolved, [[0]], 2, ("batched", False, None, None))
    reader, results = source.pool._executor_manager_thread, source.pool._result_queue
    try:
        deadline = time.monotonic() + 60
        while not (tmp_path / "half_sent0").exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        assert (tmp_path / "half_sent0").exists(), "the worker never ran its block"
        source.close()  # as Ctrl-C or SIGTERM does: the workers are killed, the half-sent result never completes
        reader.join(timeout=10)
        assert not reader.is_alive(), "the pool's result reader still waits for the half-sent result"
    finally:
        if reader.is_alive():  # before the fix: unblock it, or this test process would hang at exit
            results._writer.close()
            reader.join(timeout=30)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="workers forked from this process")
def test_a_worker_that_dies_while_it_sends_its_result_ends_the_run_with_a_message(tmp_path, monkeypatch):
    """The pool's result reader, waiting for the rest of the result, never marks that worker's blocks lost: the
    run waited for them for ever. Now a worker found dead with its blocks not marked lost ends the run as a lost
    worker does (the grace before that, 5 s, shortened here)."""
    import multiprocessing

    from e2esim.runner import executors
    from e2esim.runner.scenario import Scenario

    if multiprocessing.get_start_method() != "fork":
        pytest.skip("the stand-in block function reaches the workers only when they are forked")
    monkeypatch.setenv(_MARK, str(tmp_path))
    monkeypatch.setattr(executors, "run_block_remote", _half_sent_then_killed)
    monkeypatch.setattr(executors, "_LOST_AFTER_S", 0.5, raising=False)
    made = []

    class Recorded(executors._ProcessBlocks):  # the run's pool, for the clean-up below
        def __init__(self, *args):
            super().__init__(*args)
            made.append(self)

    monkeypatch.setattr(executors, "_ProcessBlocks", Recorded)
    resolved = Scenario.load(_sweep(tmp_path)).resolve()
    outcome = []

    def run():
        try:
            executors.run_blocks(resolved, [[0], [1]], lambda block, frame: None, workers=2)
        except BaseException as exc:  # handed to the test's thread
            outcome.append(exc)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(timeout=60)  # a hang guard: the run ends within a second or waits for ever
    waited_for_ever = thread.is_alive()
    if waited_for_ever:  # before the fix: stop the workers and end the pool's read, so that this process can end
        for process in made[0].processes:
            process.kill()
        made[0].pool._result_queue._writer.close()
        thread.join(timeout=30)
    assert not waited_for_ever, "the run waits for ever for the result of a worker that died sending it"
    assert len(outcome) == 1 and isinstance(outcome[0], executors.WorkerLost), outcome
    assert str(outcome[0]).startswith("a worker process ended abruptly (exit status 1, "), str(outcome[0])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="workers forked from this process")
def test_ctrl_c_while_the_pool_forks_its_workers_stops_them(tmp_path, monkeypatch):
    """Ctrl-C that lands while the pool starts its workers (where --workers auto forks, right after its first block
    is saved) ends the run with the pool closed: its workers stopped. Before, the interrupt cut the pool's making
    short, nobody closed it, and the interpreter's exit waited for its workers for ever."""
    import multiprocessing
    import signal

    from e2esim.runner import executors
    from e2esim.runner.scenario import Scenario

    if multiprocessing.get_start_method() != "fork":
        pytest.skip("the pool's workers are forked")
    made = []

    class InterruptedWhileMade(executors._ProcessBlocks):
        def __init__(self, *args):
            super().__init__(*args)
            made.append(self)
            os.kill(os.getpid(), signal.SIGINT)  # as a terminal's Ctrl-C, with the workers started
            time.sleep(0.5)  # where a KeyboardInterrupt, if not held back, is raised

    monkeypatch.setattr(executors, "_ProcessBlocks", InterruptedWhileMade)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    resolved = Scenario.load(_sweep(tmp_path)).resolve()
    try:
        with pytest.raises(KeyboardInterrupt):
            executors.run_blocks(resolved, [[0], [1], [2]], lambda block, frame: None, workers=2)
    finally:
        signal.signal(signal.SIGINT, previous)
        processes = made[0].processes if made else []
        alive = [p for p in processes if p.is_alive()]
        for process in alive:  # before the fix: end them here, so that this test process can end
            process.kill()
        if made:
            made[0].pool.shutdown(wait=False, cancel_futures=True)
    assert made and processes and not alive, "the pool's workers were left running"


def _pool_then_die(folder: str, sweep: str) -> None:
    """In a forked process: start the run's worker pool with the workers' start held back 0.3 s (as a loaded machine
    delays it), note their PIDs, and die at once, as a main process killed by SIGKILL just as its pool starts."""
    from e2esim.runner import executors
    from e2esim.runner.scenario import Scenario

    real = executors.exit_with_parent

    def late(*args):
        time.sleep(0.3)
        real(*args)

    executors.exit_with_parent = late  # the workers, forked from here, see it
    source = executors._ProcessBlocks(Scenario.load(sweep).resolve(), [[0], [1]], 2, ("batched", False, None, None))
    (Path(folder) / "workers").write_text(" ".join(str(p.pid) for p in source.processes))
    os._exit(0)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as stat:  # a zombie is dead (not yet reaped by its new parent)
        return stat.read().rsplit(")", 1)[1].split()[0] != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc and workers forked from this process")
def test_workers_whose_parent_died_before_they_started_end(tmp_path):
    """A main process killed just as its pool forks (a SIGKILL right after the first block of --workers auto, which
    test_parallel_and_resume's kill test hit under load): its workers find another parent when they start, which the
    parent-death signal and the watch took for theirs, and they waited for blocks for ever, holding the pipes of
    whoever ran the command. They must end."""
    import multiprocessing

    if multiprocessing.get_start_method() != "fork":
        pytest.skip("the held-back start reaches the workers only when they are forked")
    main = multiprocessing.get_context("fork").Process(target=_pool_then_die, args=(str(tmp_path),
                                                                                  str(_sweep(tmp_path))))
    main.start()
    main.join(30)  # its sentinel closes when it and the workers that inherited it are gone
    pids = [int(p) for p in (tmp_path / "workers").read_text().split()]
    assert pids
    deadline = time.monotonic() + 10
    while any(_alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = [p for p in pids if _alive(p)]
    for p in left:
        os.kill(p, 9)
    assert not left, "workers left running after their parent died"
