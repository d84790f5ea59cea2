"""Real results.h5 and journal files of quick runs, for the tests that craft hostile ones from them
(tests/test_hostile_results.py, tests/test_hostile_journal.py, tests/test_fuzz_results.py,
tests/test_fuzz_journals.py)."""

from __future__ import annotations

import atexit
import contextlib
import shutil
import signal
import tempfile
from pathlib import Path

import yaml
from hypothesis import HealthCheck
from hypothesis import strategies as st

from e2esim.cli import main
from e2esim.errors import UserError, one_line

SECRET = "SECRET-e2esim-7Q4Z"
"""Text of a file outside the crafted ones: it must never appear in anything e2esim prints or writes."""
FUZZ_FOLDER = Path(tempfile.mkdtemp(prefix="e2esim-fuzz-files-"))
atexit.register(shutil.rmtree, FUZZ_FOLDER, True)  # (ignore_errors) each process that imports this left one
SECRET_FILE = FUZZ_FOLDER / "outside.txt"
SECRET_FILE.write_text((SECRET + "\n") * 50)
COMMON = dict(deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
"""Hypothesis settings of the fuzz tests (tests/test_fuzz_results.py, tests/test_fuzz_journals.py)."""
SEEDS = st.integers(min_value=0, max_value=2**64 - 1)

RESULTS_SCENARIO = {  # analytic, a 2 x 2 grid with a text sweep key and two requirements: fast, every dataset kind
    "name": "hostile",
    "scene": {"type": "table1_forest"},
    "instrument": {"type": "biomass"},
    "ionosphere": {"type": "gaussian_faraday", "mean_deg": 60.0, "sd_deg": 5.0},
    "requirements": [{"type": "agb_error_bound", "bound_percent": 20}, {"type": "agb_rmse", "max_percent": 5}],
    "simulation": {"mode": "analytic", "seed": 3, "looks": 100000},
    "sweep": {"parameters": {"scene.forest": ["boreal_50", "boreal_200"],
                             "instrument.crosstalk.level_db": [-34.0, -26.0]}},
}

JOURNAL_SCENARIO = """
name: hostile_journal
scene: {type: forest_agb_model, biome: boreal}
instrument: {type: biomass}
ionosphere: {type: gaussian_faraday, mean_deg: 60, sd_deg: 5}
propagation: {type: hv_backscatter_error}
requirements: [{type: agb_error_bound}, {type: agb_rmse}]
simulation: {mode: both, seed: 11, looks: 500, realisations: 100, keep_samples: true}
sweep: {parameters: {scene.agb_t_ha: [50, 300]}}
output: {plots: [verdicts]}
"""
"""Two cases, each journaled as its own block with every product kept (Monte Carlo samples included)."""


def make_results(folder: Path) -> Path:
    """A results.h5 of ``RESULTS_SCENARIO`` in ``folder``."""
    import e2esim
    from e2esim.io.results_h5 import write_results

    folder.mkdir(parents=True, exist_ok=True)
    write_results(e2esim.run(RESULTS_SCENARIO).run, folder / "results.h5")
    return folder / "results.h5"


def make_journal(folder: Path):
    """(scenario path, resolved scenario, output folder) with a journal of both cases of ``JOURNAL_SCENARIO``."""
    from e2esim.runner.journal import Journal
    from e2esim.runner.run import run_block
    from e2esim.runner.scenario import Scenario

    folder.mkdir(parents=True, exist_ok=True)
    scenario = folder / "journal.yaml"
    scenario.write_text(JOURNAL_SCENARIO)
    resolved = Scenario.load(scenario).resolve()
    out = folder / "out"
    journal = Journal(out, resolved)
    journal.start(resume=False)
    for indices in ([0], [1]):
        journal.record(run_block(resolved, indices, keep_products=True))
    journal.close()
    return scenario, resolved, out


@contextlib.contextmanager
def hang_guard(seconds: int):
    """Fail (TimeoutError) when the block takes longer than ``seconds``: a hang."""
    def _raise(signum, frame):
        raise TimeoutError(f"took more than {seconds} s: a hang")

    if not hasattr(signal, "SIGALRM"):  # pragma: no cover - Windows: no guard
        yield
        return
    old = signal.signal(signal.SIGALRM, _raise)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def cli(capsys, *args) -> tuple:
    """(status, stdout, stderr) of ``e2esim ARGS`` in this process; a status 2 must come with one line."""
    with hang_guard(60):
        status = main(list(map(str, args)))
    out, err = capsys.readouterr()
    if status == 2:
        assert err.startswith("e2esim: error: ") and err.count("\n") == 1, repr(err)
    return status, out, err


def refused_scenario(tmp_path: Path, capsys, scenario: dict) -> str:
    """The one-line message of ``e2esim run`` refusing ``scenario`` (a dict written as YAML): exit status 2, no
    traceback and no output folder left behind."""
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(scenario))
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("e2esim: error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()
    return err


def expect_clean(exc: UserError, path: Path) -> None:
    """A refusal of a crafted file: one line naming it (or its journal), nothing of the secret file."""
    message = one_line(exc)
    assert SECRET not in message and (str(path) in message or "journal" in message), message
