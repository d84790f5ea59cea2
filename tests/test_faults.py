"""Faults end cleanly (issue 22, items 1, 3, 5 and 12): a planted link in an output folder never makes e2esim
write outside it; a full disk or the file-size limit, a killed worker, Ctrl-C or a stop signal give one message,
a non-zero exit, the journal kept and the way to resume; ``--force`` keeps the earlier outputs until the new
ones are complete; an interrupt keeps every finished block and does not wait for the blocks in flight."""

import errno
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from cli_processes import e2esim_process as _cli
from cli_processes import wait_for as _wait_for
from test_output_folder import SMALL, _alive, _children, _run
from test_output_folder import _scenario as _small
from test_parallel_and_resume import _saved
from test_parallel_and_resume import _scenario as _sweep

from e2esim.runner.executors import run_block_remote as _RUN_BLOCK_REMOTE
from e2esim.runner.journal import JOURNAL
from e2esim.runner.lock import LOCK_NAME
from e2esim.runner.outputs import ASIDE

posix_only = pytest.mark.skipif(os.name != "posix", reason="symbolic links, signals and rlimits of POSIX")




def _outside(tmp_path) -> tuple:
    """A file and a folder outside the output folder, and a snapshot of both."""
    victim = tmp_path / "outside" / "victim.txt"
    victim_dir = tmp_path / "outside" / "victim_dir"
    victim_dir.mkdir(parents=True)
    victim.write_text("not e2esim's\n")
    (victim_dir / "keep.txt").write_text("mine\n")
    return victim, victim_dir


def _snapshot(root: Path) -> dict:
    return {str(p.relative_to(root)): (p.read_bytes() if p.is_file() else None) for p in sorted(root.rglob("*"))}


# -------------------------------------------------------------------------------- item 1: planted links
@posix_only
@pytest.mark.parametrize("plant", ["symlink", "hardlink", "fifo"])
def test_a_planted_lock_file_is_refused_and_not_written(tmp_path, capsys, plant):
    # issue 22 item 1: a symlink .e2esim.lock was opened O_RDWR|O_CREAT, its target cut and overwritten with the
    # run's PID, and the link deleted after the run, hiding the trace
    victim, _ = _outside(tmp_path)
    before = _snapshot(tmp_path / "outside")
    out = tmp_path / "out"
    out.mkdir()
    lock = out / LOCK_NAME
    {"symlink": lambda: lock.symlink_to(victim), "hardlink": lambda: os.link(victim, lock),
     "fifo": lambda: os.mkfifo(lock)}[plant]()
    status, err = _run(_small(tmp_path), "-o", out, capsys=capsys)
    assert status == 2 and err.count("\n") == 1, err
    assert f"{lock}: " in err and "not a lock file of e2esim; it was not written to" in err
    assert _snapshot(tmp_path / "outside") == before
    assert os.path.lexists(lock)  # left for the user to look at
    assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]


PLANTED = ["results.h5", "summary.json", "report.md", "report.html", "verdicts.png", ".e2esim-outputs.json",
           f"{JOURNAL}/", f"{ASIDE}x/", ".results.h5.abcd1234.tmp"]


@posix_only
@pytest.mark.parametrize("option", ["--force", "--resume"])
def test_no_planted_link_in_an_output_folder_makes_e2esim_write_outside(tmp_path, capsys, option):
    # issue 22 item 1 and its "done when": a symlink anywhere in an output folder never makes e2esim write outside
    # it. Before, a journal folder planted as a link was written into (its manifest and records) on --resume.
    victim, victim_dir = _outside(tmp_path)
    before = _snapshot(tmp_path / "outside")
    out = tmp_path / "out"
    out.mkdir()
    for name in PLANTED:
        (out / name.rstrip("/")).symlink_to(victim_dir if name.endswith("/") else victim)
    status, err = _run(_small(tmp_path), "-o", out, option, capsys=capsys)
    assert _snapshot(tmp_path / "outside") == before
    assert "Traceback" not in err
    if option == "--resume":  # the planted journal is refused, not used
        assert status == 2 and f"{out / JOURNAL}: is a symbolic link, not a journal of e2esim" in err
    else:  # --force moves the links aside (as links) and removes them with the old outputs after success
        assert status == 0, err
        assert [p.name for p in out.iterdir() if p.is_symlink()] == [f"{ASIDE}x"]  # not e2esim's: not followed


@posix_only
def test_a_planted_journal_records_link_is_not_appended_to(tmp_path, capsys):
    victim, _ = _outside(tmp_path)
    before = _snapshot(tmp_path / "outside")
    out = tmp_path / "out"
    (out / JOURNAL).mkdir(parents=True)
    (out / JOURNAL / "cases.journal").symlink_to(victim)
    status, err = _run(_small(tmp_path), "-o", out, "--resume", capsys=capsys)
    assert status == 2 and err.count("\n") == 1 and "cannot create the resume journal" in err, err
    assert _snapshot(tmp_path / "outside") == before


# -------------------------------------------------------------------------------- item 3: full disk, file size
MONTE_CARLO = SMALL.replace("simulation: {mode: analytic}",
                            "simulation: {mode: both, seed: 5, looks: 1000, realisations: 10000}").replace(
                            "[50, 150, 250]", "[50, 250]")


@posix_only
def test_file_size_limit_while_writing_results_h5_is_one_message(tmp_path, capsys, monkeypatch):
    """The file-size limit (RLIMIT_FSIZE; the same failure as a full disk) strikes inside results.h5, which holds
    the Monte Carlo samples (about 160 kB here; each plot is under 64 kB). Before: a RuntimeError traceback from
    h5py's close, or a segmentation fault at exit (HDF5 closing, after Python had shut down, objects whose flush
    had failed), and the plots of the attempt left behind."""
    from e2esim.runner import outputs

    scenario, out = _small(tmp_path, MONTE_CARLO), tmp_path / "out"

    def disk_full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(outputs, "write_results", disk_full)  # a first run: every case saved, no output
    assert _run(scenario, "-o", out, capsys=capsys)[0] == 2
    monkeypatch.undo()
    proc = _cli("run", scenario, "-o", out, "--no-progress", "--resume", limit_bytes=64_000)
    err = proc.communicate(timeout=300)[1]
    assert proc.returncode == 2, (proc.returncode, err)  # not 1 (a traceback), not -11 (a segmentation fault)
    assert err.count("\n") == 1 and "cannot write the outputs: File too large; no partial file was left" in err
    assert "run the same command with --resume" in err
    assert sorted(p.name for p in out.iterdir()) == [JOURNAL]
    assert _run(scenario, "-o", out, "--resume", capsys=capsys)[0] == 0
    assert json.loads((out / "summary.json").read_text())["resumed_cases"] == 2


@posix_only
def test_a_failed_journal_write_is_cut_off_and_closing_does_not_fail_again(tmp_path):
    """Before: the journal's buffered file kept the unwritten tail of the frame, so closing it failed a second
    time and the clean message became a traceback."""
    import resource

    from e2esim.errors import OutputFolderError
    from e2esim.runner.journal import Journal
    from e2esim.runner.run import run_block
    from e2esim.runner.scenario import Scenario

    resolved = Scenario.load(_sweep(tmp_path)).resolve()
    first, second = run_block(resolved, [0]), run_block(resolved, [1])
    journal = Journal(tmp_path / "out", resolved)
    journal.start(resume=False)
    journal.record(first)
    records = journal.path / "cases.journal"
    good = records.stat().st_size
    from e2esim.runner.journal import encode_block

    frame = encode_block(second, journal.packages)
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (good + len(frame) - 1000, hard))  # the last kB does not fit
    try:
        with pytest.raises(OutputFolderError, match=r"a finished block: File too large \(1 cases are saved\)"):
            journal.record(second, frame)
        journal.close()  # no second failure
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    assert records.stat().st_size == good  # whole frames only
    again = Journal(tmp_path / "out", resolved)
    assert [list(b.indices) for b in again.start(resume=True)] == [[0]]
    again.close()


def test_a_full_disk_while_keeping_finished_blocks_on_disk_is_an_output_folder_error(tmp_path, monkeypatch):
    """A large run keeps its finished blocks in a temporary file (e2esim.runner.spill); a full disk there was an
    OSError with a traceback."""
    import tempfile

    from e2esim.errors import OutputFolderError
    from e2esim.runner import spill
    from e2esim.runner.run import run_scenario
    from e2esim.runner.scenario import Scenario

    real = tempfile.TemporaryFile

    class Full:
        def __init__(self, *args, **kwargs):
            self.file = real()

        def write(self, data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        def __getattr__(self, name):
            return getattr(self.file, name)

    monkeypatch.setattr(spill.tempfile, "TemporaryFile", Full)
    resolved = Scenario.load(_small(tmp_path)).resolve()
    with pytest.raises(OutputFolderError, match="cannot keep the finished blocks in a temporary file: No space left"):
        run_scenario(resolved, progress=False, keep_products=False, spill=True, spill_folder=tmp_path / "out")


def test_force_keeps_the_earlier_outputs_until_the_new_ones_are_complete(tmp_path, capsys, monkeypatch):
    # issue 22 item 3: with --force the earlier results were deleted before the new run had written anything
    from e2esim.runner import outputs

    scenario, out = _small(tmp_path), tmp_path / "out"
    assert _run(scenario, "-o", out, capsys=capsys)[0] == 0
    earlier = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    assert "results.h5" in earlier and "summary.json" in earlier

    def disk_full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(outputs, "write_results", disk_full)
    status, err = _run(scenario, "-o", out, "--force", "--set", "scene.biome=tropical", capsys=capsys)
    aside = sorted(out.glob(f"{ASIDE}*"))
    assert status == 2 and len(aside) == 1 and err.count("\n") == 1, err
    assert f"the earlier outputs are kept in {aside[0]} until a run here completes" in err
    assert {p.name: p.read_bytes() for p in aside[0].iterdir() if p.is_file()} == earlier
    monkeypatch.undo()
    status, err = _run(scenario, "-o", out, "--resume", "--set", "scene.biome=tropical", capsys=capsys)
    assert status == 0, err
    assert not list(out.glob(f"{ASIDE}*"))  # removed once the new outputs are complete
    assert json.loads((out / "summary.json").read_text())["resumed_cases"] == 3


# -------------------------------------------------------------------------------- item 5: a killed worker
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_worker_killed_by_sigkill_is_one_message_and_the_run_resumes(tmp_path):
    # issue 22 item 5: the run ended in a BrokenProcessPool traceback with no hint to resume
    scenario = _sweep(tmp_path, method="brute_force", looks=1000, realisations=600)
    out = tmp_path / "out"
    proc = _cli("run", scenario, "-o", out, "--no-progress", "--workers", "2")
    _wait_for(lambda: _saved(out / JOURNAL) >= 1 and len(_children(proc.pid)) >= 2, proc)  # /proc read last
    os.kill(max(_children(proc.pid)), signal.SIGKILL)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == 2 and err.count("\n") == 1 and "Traceback" not in err, (proc.returncode, err)
    assert "a worker process ended abruptly (killed by SIGKILL" in err
    saved = int(re.search(r"; (\d+) of 12 cases are saved in ", err).group(1))
    assert saved == _saved(out / JOURNAL) and "run the same command with --resume to finish" in err
    resumed = _cli("run", scenario, "-o", out, "--no-progress", "--resume", "--workers", "2")
    assert resumed.wait(300) == 0, resumed.stderr.read()
    assert json.loads((out / "summary.json").read_text())["resumed_cases"] == saved




# -------------------------------------------------------------------------------- item 12: interrupts
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("signum, status, said", [(signal.SIGINT, 130, "interrupted"),
                                                  (signal.SIGTERM, 143, "stopped by SIGTERM")])
def test_a_signal_under_workers_keeps_the_journal_and_stops_the_workers(tmp_path, signum, status, said):
    """Ctrl-C (to the whole process group, as a terminal sends it) or SIGTERM (to the main process): one message
    with the number of saved cases, the journal holding exactly those, no worker left. Before, SIGTERM killed the
    run without a word, and Ctrl-C waited for the blocks in flight and dropped the ones that finished meanwhile."""
    scenario = _sweep(tmp_path, method="brute_force", looks=1000, realisations=600)
    out = tmp_path / "out"
    proc = _cli("run", scenario, "-o", out, "--no-progress", "--workers", "2", start_new_session=True)
    _wait_for(lambda: _saved(out / JOURNAL) >= 1 and len(_children(proc.pid)) >= 2, proc)  # /proc read last
    workers = _children(proc.pid)
    if signum == signal.SIGINT:
        os.killpg(proc.pid, signum)
    else:
        proc.send_signal(signum)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == status and err.count("\n") == 1 and "Traceback" not in err, (proc.returncode, err)
    assert err.startswith(f"e2esim: {said}; ") and "run the same command with --resume to finish" in err
    saved = int(re.search(r"; (\d+) of 12 cases are saved in ", err).group(1))
    assert 1 <= saved == _saved(out / JOURNAL)
    assert not any(_alive(w) for w in workers)


def _block_or_wait(indices, options, resolved=None):
    """In a worker (forked, so it sees this module): blocks 0-2 run; blocks 3 and up wait for ever (a block in
    flight when Ctrl-C comes), after noting their worker's PID."""
    from e2esim.runner.executors import _WORKER

    folder = Path(os.environ["E2ESIM_TEST_MARKS"])
    if indices[0] >= 3:
        (folder / f"waiting{os.getpid()}").touch()
        time.sleep(3600)
    result = _RUN_BLOCK_REMOTE(indices, options, resolved if resolved is not None else _WORKER["resolved"])
    (folder / f"done{indices[0]}").touch()
    return result


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="workers forked from this process")
def test_ctrl_c_keeps_the_blocks_that_finished_meanwhile_and_drops_those_in_flight(tmp_path, monkeypatch):
    """The mechanism of item 12: Ctrl-C arrives while the first finished block is being kept (and is held back
    until it is); blocks 1 and 2 finish meanwhile and are handed over too, each once; the workers running blocks
    3 and 4 (which would never end) are stopped, not waited for."""
    import multiprocessing

    from e2esim.runner import executors
    from e2esim.runner.scenario import Scenario

    if multiprocessing.get_start_method() != "fork":
        pytest.skip("the stand-in block function reaches the workers only when they are forked")
    monkeypatch.setenv("E2ESIM_TEST_MARKS", str(tmp_path))
    monkeypatch.setattr(executors, "run_block_remote", _block_or_wait)
    sources = []

    class Watched(executors._ProcessBlocks):  # the pool's futures, to see the results arrive in this process
        def __init__(self, *args):
            super().__init__(*args)
            sources.append(self)

    monkeypatch.setattr(executors, "_ProcessBlocks", Watched)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    resolved = Scenario.load(_sweep(tmp_path)).resolve()
    taken = []

    def take(block, frame):
        taken.append(int(block.indices[0]))
        if len(taken) == 1:
            os.kill(os.getpid(), signal.SIGINT)  # held back until this block is kept
            # blocks 1 and 2 finish meanwhile and both workers take blocks 3 and 4 (which wait): wait until the
            # results are back in this process (their futures done) and both workers have noted their PID, not for a
            # fixed time (before the PIDs were awaited too, a loaded machine could send Ctrl-C first)
            meanwhile = [f for f, number in sources[0].number.items() if number in (1, 2)]
            deadline = time.monotonic() + 120
            while (not all(f.done() for f in meanwhile) or len(list(tmp_path.glob("waiting*"))) < 2) \
                    and time.monotonic() < deadline:
                time.sleep(0.02)

    try:
        with pytest.raises(KeyboardInterrupt):
            executors.run_blocks(resolved, [[i] for i in range(6)], take, workers=2)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert sorted(taken) == [0, 1, 2]
    waiting = [int(p.name[len("waiting"):]) for p in tmp_path.glob("waiting*")]
    assert waiting and not any(_alive(pid) for pid in waiting)


def test_ctrl_c_while_results_h5_is_written_stops_it_cleanly(tmp_path, monkeypatch):
    """Ctrl-C is held back while HDF5 runs (an exception inside its file callbacks would leave the library in a
    state that crashes the interpreter at exit) and raised before the next dataset: no file is left, and HDF5
    writes the next file normally."""
    import h5py

    from e2esim.io import h5_datasets
    from e2esim.io.results_h5 import write_results
    from e2esim.runner.run import run_scenario
    from e2esim.runner.scenario import Scenario

    result = run_scenario(Scenario.load(_small(tmp_path)).resolve(), progress=False)
    real_put, calls = h5_datasets.put, []

    def put(*args, **kwargs):
        calls.append(1)
        if len(calls) == 5:
            os.kill(os.getpid(), signal.SIGINT)  # held back; raised before this dataset is made
        return real_put(*args, **kwargs)

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    monkeypatch.setattr("e2esim.io.results_h5.put", put)
    try:
        with pytest.raises(KeyboardInterrupt):
            write_results(result, tmp_path / "results.h5")
    finally:
        signal.signal(signal.SIGINT, previous)
    assert len(calls) == 5 and list(tmp_path.glob("*.h5")) == [] and not list(tmp_path.glob(".*.tmp"))
    monkeypatch.undo()
    write_results(result, tmp_path / "results.h5")
    with h5py.File(tmp_path / "results.h5", "r") as f:
        assert f.attrs["n_cases"] == 3


@posix_only
def test_file_size_limit_while_writing_results_nc_is_an_os_error(tmp_path):
    """results.nc (a map sweep's) is written by the NetCDF library, which says only "NetCDF: HDF error" (a
    RuntimeError: a traceback) when a write fails; now the OSError of a full disk or the file-size limit."""
    script = """
import errno, resource, sys
import numpy as np, xarray as xr
from e2esim.maps.netcdf import write_map_netcdf
ds = xr.Dataset({"v": (("lat", "lon"), np.random.default_rng(1).random((200, 200)))})
resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))
try:
    write_map_netcdf(ds, sys.argv[1])
except OSError as exc:
    print(exc.errno == errno.EFBIG, exc.strerror)
"""
    out = subprocess.run([sys.executable, "-c", script, str(tmp_path / "results.nc")], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "True File too large", out.stderr[-2000:]
    assert list(tmp_path.iterdir()) == []


def test_the_pools_race_with_a_cancelled_future_is_not_a_traceback_and_nothing_else_is_hidden(monkeypatch, capsys):
    """Ctrl-C under workers: Python 3.11's pool thread may set an exception on a future this process has just
    cancelled (``InvalidStateError`` in ``terminate_broken``), which printed a traceback after the run's one message
    (the test above failed so, rarely, under load). That error of that thread is left unsaid; any other error of
    the pool's thread, and that error in any other thread, is printed as before."""
    import threading
    from concurrent.futures import InvalidStateError

    from e2esim.runner.executors import quiet_cancelled_future_race

    monkeypatch.setattr(threading, "excepthook", threading.__excepthook__)

    class _ExecutorManagerThread(threading.Thread):  # Python's pool thread
        pass

    def raised(error, thread):
        threading.excepthook(threading.ExceptHookArgs([type(error), error, None, thread]))
        return capsys.readouterr().err

    closed, open_pool, other = _ExecutorManagerThread(), _ExecutorManagerThread(), threading.Thread()
    quiet_cancelled_future_race(closed)
    quiet_cancelled_future_race(closed)  # the hook is set once: not wrapped twice
    assert raised(InvalidStateError("CANCELLED"), closed) == ""
    assert "RuntimeError" in raised(RuntimeError("lost"), closed)
    assert "InvalidStateError" in raised(InvalidStateError("CANCELLED"), open_pool)  # a pool not being closed
    assert "InvalidStateError" in raised(InvalidStateError("CANCELLED"), other)
