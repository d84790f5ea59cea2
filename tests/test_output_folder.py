"""The output folder (issue 15, defects 4, 6 and 7): one run at a time, ``--force`` clears the old outputs,
a killed run leaves no process and no temporary file behind, and a folder that cannot be used (below a
file, not writable, full) is exit status 2 with one line and no partial file."""

import errno
import json
import os
import signal
import sys
import time
from pathlib import Path

import pytest
from cli_processes import children as _children
from cli_processes import e2esim_process as _cli
from cli_processes import wait_for as _wait_for
from test_parallel_and_resume import _scenario as _sweep

from e2esim.cli import main
from e2esim.runner.journal import JOURNAL
from e2esim.runner.lock import LOCK_NAME

SMALL = """
name: small
scene: {type: forest_agb_model, biome: boreal}
instrument: {type: biomass}
ionosphere: {type: gaussian_faraday, mean_deg: 60, sd_deg: 5}
requirements: [{type: agb_error_bound}]
simulation: {mode: analytic}
sweep: {parameters: {scene.agb_t_ha: [50, 150, 250]}}
output: {plots: [PLOTS]}
"""

def _scenario(tmp_path, text=SMALL, name="s.yaml", **replace):
    for key, value in replace.items():
        text = text.replace(key, str(value))
    path = tmp_path / name
    path.write_text(text.replace("PLOTS", "verdicts"))
    return path


def _run(*args, capsys=None):
    status = main(["run", *map(str, args), "--no-progress"])
    return status, (capsys.readouterr().err if capsys else "")






def test_two_concurrent_runs_one_result_one_refusal(tmp_path, capsys):
    """The first run is another process; the second is this one (pytest's), started while the first holds
    the folder."""
    scenario = _sweep(tmp_path, method="brute_force", looks=1000, realisations=100)
    out = tmp_path / "out"
    first = _cli("run", scenario, "-o", out, "--no-progress")
    _wait_for(lambda: (out / LOCK_NAME).exists() and (out / LOCK_NAME).read_text().strip(), first)
    first.send_signal(signal.SIGSTOP)  # hold the first run inside its work, whatever the machine's speed
    try:
        for flags in ((), ("--force",), ("--resume",)):
            status, err = _run(scenario, "-o", out, *flags, capsys=capsys)
            assert status == 2, err
            assert f"another e2esim run (PID {first.pid}) is writing into this folder" in err and err.count("\n") == 1
    finally:
        first.send_signal(signal.SIGCONT)
    assert first.wait(timeout=300) == 0, first.stderr.read()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_cases"] == 12 and len(summary["cases"]) == 12
    assert not (out / LOCK_NAME).exists() and not (out / JOURNAL).exists()


def test_a_lock_left_by_a_dead_run_does_not_block(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).write_text("999999999\n")  # the file stays when a run is killed; its lock does not
    assert _run(_scenario(tmp_path), "-o", out, capsys=capsys)[0] == 0


def test_force_clears_the_previous_outputs(tmp_path, capsys):
    out = tmp_path / "out"
    first = _scenario(tmp_path, SMALL.replace("PLOTS", "verdicts, agb_error_vs_sweep"), name="first.yaml")
    assert _run(first, "-o", out, capsys=capsys)[0] == 0
    assert (out / "agb_error_vs_sweep.png").exists()
    (out / "notes.txt").write_text("the user's own file")
    second = _scenario(tmp_path, SMALL.replace("[50, 150, 250]", "[75]"), name="second.yaml")
    status, err = _run(second, "-o", out, capsys=capsys)
    assert status == 2 and "output folder exists and is not empty; use --force" in err
    assert _run(second, "-o", out, "--force", capsys=capsys)[0] == 0
    assert not (out / "agb_error_vs_sweep.png").exists()  # stale plot of the first scenario: gone
    assert json.loads((out / "summary.json").read_text())["scenario"] == "small"
    assert json.loads((out / "summary.json").read_text())["n_cases"] == 1
    assert (out / "notes.txt").read_text() == "the user's own file"
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == [".e2esim-outputs.json"]


def test_force_on_a_folder_of_an_older_e2esim_removes_its_plots(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    for name in ("summary.json", "results.h5", "tradeoff.png"):
        (out / name).write_text("stale")
    assert _run(_scenario(tmp_path), "-o", out, "--force", capsys=capsys)[0] == 0
    assert not (out / "tradeoff.png").exists() and (out / "summary.json").read_text() != "stale"


def test_resume_removes_temporary_files_of_a_killed_run(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    leftovers = [out / ".results.h5.ab12cd_9.tmp", out / ".verdicts.png.x8y7z6w5.tmp"]
    for path in leftovers:
        path.write_bytes(b"half a file")
    (out / ".e2esim-trash-abc").mkdir()
    assert _run(_scenario(tmp_path), "-o", out, "--resume", capsys=capsys)[0] == 0
    assert not any(p.exists() for p in leftovers) and not (out / ".e2esim-trash-abc").exists()
    assert (out / "summary.json").exists()


def test_output_folder_below_a_file(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    status, err = _run(_scenario(tmp_path), "-o", tmp_path / "file" / "out", capsys=capsys)
    assert status == 2 and f"cannot create the output folder: {tmp_path / 'file'} is a file, not a folder" in err
    status, err = _run(_scenario(tmp_path), "-o", tmp_path / "file", capsys=capsys)
    assert status == 2 and "exists and is not a folder" in err


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="permissions do not bind root")
def test_output_folder_not_writable(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    out.chmod(0o500)
    status, err = _run(_scenario(tmp_path), "-o", out, capsys=capsys)
    assert status == 2 and "cannot write into the output folder: Permission denied" in err


@pytest.mark.parametrize("error", [errno.EACCES, errno.ENOSPC, errno.EROFS])
def test_output_folder_not_writable_or_full_at_start(tmp_path, capsys, monkeypatch, error):
    from e2esim.runner import lock

    def refuse(path, flags, mode=0o777):
        raise OSError(error, os.strerror(error))

    monkeypatch.setattr(lock.os, "open", refuse)
    status, err = _run(_scenario(tmp_path), "-o", tmp_path / "out", capsys=capsys)
    assert status == 2 and f"cannot write into the output folder: {os.strerror(error)}" in err
    assert err.count("\n") == 1 and list((tmp_path / "out").iterdir()) == []


def test_disk_full_while_writing_outputs(tmp_path, capsys, monkeypatch):
    """The disk fills up in the middle of summary.json: no partial file stays, the finished cases are kept,
    and --resume writes the outputs once there is space."""
    import io

    scenario, out = _scenario(tmp_path), tmp_path / "out"
    real_open = io.open

    class FullFile:
        def __init__(self, fh):
            self.fh = fh

        def write(self, data):
            self.fh.write(data[: len(data) // 2])
            raise OSError(errno.ENOSPC, "No space left on device")

        def __getattr__(self, name):
            return getattr(self.fh, name)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.fh.close()

    def full_open(file, mode="r", *args, **kwargs):
        fh = real_open(file, mode, *args, **kwargs)
        return FullFile(fh) if "summary.json" in str(file) and "w" in mode else fh

    monkeypatch.setattr(io, "open", full_open)  # what pathlib's write_text uses
    status, err = _run(scenario, "-o", out, capsys=capsys)
    assert status == 2 and "cannot write the outputs: No space left on device; no partial file was left" in err
    assert sorted(p.name for p in out.iterdir()) == [JOURNAL]  # no output, no temporary file; the journal stays
    monkeypatch.setattr(io, "open", real_open)
    assert _run(scenario, "-o", out, "--resume", capsys=capsys)[0] == 0
    assert json.loads((out / "summary.json").read_text())["resumed_cases"] == 3


def test_bad_scheduler_address(tmp_path, capsys):
    status, err = _run(_scenario(tmp_path), "-o", tmp_path / "out", "--scheduler", "bogus://x", capsys=capsys)
    assert status == 2 and "--scheduler 'bogus://x': not a dask scheduler address" in err
    assert not (tmp_path / "out").exists()


def test_unreachable_scheduler_leaves_no_journal(tmp_path, capsys, monkeypatch):
    import distributed

    def unreachable(*args, **kwargs):
        raise OSError("Timed out trying to connect to tcp://127.0.0.1:9 after 20 s")

    monkeypatch.setattr(distributed, "Client", unreachable)
    scenario, out = _scenario(tmp_path), tmp_path / "out"
    status, err = _run(scenario, "-o", out, "--scheduler", "tcp://127.0.0.1:9", capsys=capsys)
    assert status == 2 and "cannot connect to the dask scheduler at tcp://127.0.0.1:9" in err
    assert not out.exists()  # no journal, and the folder this run created is taken back
    assert _run(scenario, "-o", out, capsys=capsys)[0] == 0  # not "an interrupted run"


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_killing_a_run_under_workers_leaves_no_process(tmp_path):
    scenario = _sweep(tmp_path, method="brute_force", looks=1000, realisations=3000)
    out = tmp_path / "out"
    proc = _cli("run", scenario, "-o", out, "--no-progress", "--workers", "2")
    _wait_for(lambda: len(_children(proc.pid)) >= 2, proc)
    workers = _children(proc.pid)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    deadline = time.monotonic() + 10
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(_alive(w) for w in workers), workers


def test_the_api_holds_its_folder_lock_and_releases_it(tmp_path, monkeypatch):
    # issue 21 item 11: e2esim.run(output=...) dropped the lock that prepare_folder returned, so a second run
    # into the same folder in the same process was refused as "another e2esim run (PID <own pid>)"
    import e2esim
    from e2esim.errors import OutputFolderError
    from e2esim.runner import folder_run as run_module  # the one run path of the CLI and the API
    from e2esim.runner.lock import FolderLock

    scenario, out = _scenario(tmp_path), tmp_path / "out"
    seen = []
    real = run_module.run_scenario

    def watched(*args, **kwargs):  # the folder is locked while the scenario runs
        seen.append((out / LOCK_NAME).read_text().strip())
        return real(*args, **kwargs)

    monkeypatch.setattr(run_module, "run_scenario", watched)
    first = e2esim.run(scenario, output=out)
    second = e2esim.run(scenario, output=out, force=True)
    assert seen == [str(os.getpid())] * 2 and not (out / LOCK_NAME).exists()
    assert second.labels == first.labels and (out / "summary.json").is_file()

    with FolderLock(out), pytest.raises(OutputFolderError, match="another e2esim run"):
        e2esim.run(scenario, output=out, force=True)  # a live lock still refuses

    def failing(*args, **kwargs):
        raise RuntimeError("a run that fails")

    monkeypatch.setattr(run_module, "run_scenario", failing)
    with pytest.raises(RuntimeError, match="a run that fails"):
        e2esim.run(scenario, output=out, force=True)
    assert not (out / LOCK_NAME).exists()  # released on failure too
    monkeypatch.setattr(run_module, "run_scenario", real)
    assert e2esim.run(scenario, output=out, force=True).n_cases == 3
