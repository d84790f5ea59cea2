"""One run path (issue 27, Build 4): ``e2esim run`` and ``e2esim.run`` take their folder the same way
(``e2esim.runner.folder_run``): the same outputs, the same refusal of a folder another run holds, the same resume
journal, so that a run interrupted through the API resumes through it."""

import json

import h5py
import numpy as np
import pytest
from test_output_folder import _run, _scenario

import e2esim
import e2esim.errors
from e2esim.errors import OutputFolderError
from e2esim.runner import folder_run
from e2esim.runner.interrupts import RunInterrupted
from e2esim.runner.journal import JOURNAL
from e2esim.runner.lock import LOCK_NAME, FolderLock


def _numbers(path):
    """Every dataset of a results.h5 but the provenance (the command and the time differ by design)."""
    out = {}
    with h5py.File(path, "r") as h5:
        def keep(name, node):
            if isinstance(node, h5py.Dataset) and not name.startswith("provenance"):
                out[name] = node[()]
        h5.visititems(keep)
    return out


def test_the_cli_and_the_api_write_the_same_outputs(tmp_path, capsys):
    scenario = _scenario(tmp_path)
    assert _run(scenario, "-o", tmp_path / "cli", capsys=capsys)[0] == 0
    e2esim.run(scenario, output=tmp_path / "api")
    cli, api = tmp_path / "cli", tmp_path / "api"
    assert sorted(p.name for p in cli.iterdir()) == sorted(p.name for p in api.iterdir())
    a, b = _numbers(cli / "results.h5"), _numbers(api / "results.h5")
    assert sorted(a) == sorted(b) and len(a) > 10
    for name in a:
        assert np.array_equal(a[name], b[name], equal_nan=a[name].dtype.kind == "f"), name
    summary_a, summary_b = (json.loads((f / "summary.json").read_text()) for f in (cli, api))
    for summary in (summary_a, summary_b):
        del summary["command"], summary["created_utc"]
    assert summary_a == summary_b


def test_the_api_refuses_a_held_folder_with_the_message_of_the_cli(tmp_path, capsys):
    scenario, out = _scenario(tmp_path), tmp_path / "out"
    with FolderLock(out.mkdir() or out):
        status, err = _run(scenario, "-o", out, "--force", capsys=capsys)
        with pytest.raises(OutputFolderError) as refused:
            e2esim.run(scenario, output=out, force=True)
    assert status == 2 and "another e2esim run" in err
    assert err == f"e2esim: error: {refused.value}\n"


def test_an_api_run_interrupted_while_writing_resumes_through_the_api(tmp_path, monkeypatch):
    scenario, out = _scenario(tmp_path), tmp_path / "out"

    def interrupted(result, folder, progress=False):
        raise KeyboardInterrupt

    monkeypatch.setattr(folder_run, "write_outputs", interrupted)
    with pytest.raises(KeyboardInterrupt) as stop:  # as Python interrupts a program, with what was kept
        e2esim.run(scenario, output=out)
    assert isinstance(stop.value, RunInterrupted) and stop.value.exit_status == 130
    assert "3 of 3 cases are saved" in stop.value.message and "--resume" in stop.value.message
    assert (out / JOURNAL).is_dir() and not (out / LOCK_NAME).exists()
    monkeypatch.undo()
    resumed = e2esim.run(scenario, output=out, resume=True)
    assert resumed.provenance["resumed_cases"] == 3 and (out / "summary.json").is_file()
    assert not (out / JOURNAL).exists()
    assert resumed.scalars.keys() == e2esim.run(scenario).scalars.keys()


def test_results_write_locks_the_folder_as_a_run_does(tmp_path):
    results, out = e2esim.run(_scenario(tmp_path)), tmp_path / "out"
    with FolderLock(out.mkdir() or out), pytest.raises(OutputFolderError, match="another e2esim run"):
        results.write(out)  # a run live in the folder is not written over
    assert not (out / "summary.json").exists()
    results.write(out)
    assert (out / "summary.json").is_file() and not (out / LOCK_NAME).exists()


def test_the_api_checks_its_workers_as_the_cli_does(tmp_path, capsys):
    scenario = _scenario(tmp_path)
    status, err = _run(scenario, "-o", tmp_path / "cli", "--workers", "0", capsys=capsys)
    with pytest.raises(e2esim.errors.UserError) as refused:
        e2esim.run(scenario, workers=0)
    assert status == 2 and err == f"e2esim: error: {refused.value}\n"
