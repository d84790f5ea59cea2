"""Shared fixtures.

Statistical tests draw from ``rng``, seeded by ``E2ESIM_TEST_SEED`` (default 20210406). Set it to
another integer, or to ``random``, to check that a test is not tuned to one seed (the model is
scikit-learn's ``global_random_seed``); the seed in use is printed in the test report header.
"""

from __future__ import annotations

import functools
import gc
import inspect
import os
import re
import shutil
import signal
import tempfile
import zlib

import numpy as np
import pytest
from cli_processes import stop_leftovers

from helpers import TEST_SEED
from quick_runs import SCENARIOS, quick_overrides, quick_run_group, scenario_names


def pytest_configure(config):
    # Each test process holds the results of its quick runs for the session (a few hundred MB of objects), and every
    # full collection of the cyclic garbage collector scans them all: 40 or so per process at the default
    # thresholds, 13 s of CPU in the suite. A full collection waits for 100 collections of the middle generation
    # here instead of 10: 7 s of CPU less, 7 to 10 full collections per process. The tests that count memory
    # collect explicitly (test_memory_of_large_runs).
    young, middle, _ = gc.get_threshold()
    gc.set_threshold(young, middle, 100)
    # Keep climatology caches out of the user's home during the tests (subprocesses and the pytest-xdist
    # workers inherit it, and the workers share the seed the controller drew).
    if "E2ESIM_CACHE" not in os.environ:
        os.environ["E2ESIM_CACHE"] = _MADE_CACHE[config] = tempfile.mkdtemp(prefix="e2esim-test-cache-")
    os.environ["E2ESIM_TEST_SEED"] = str(TEST_SEED)
    # A suite started as a background job of a non-interactive shell inherits SIGINT ignored, and so would every
    # e2esim the tests start (an ignored signal stays ignored across exec): the Ctrl-C tests would then see a run
    # that cannot be interrupted. Python's own handler here makes the children start with the default one.
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


_MADE_CACHE: dict = {}
"""The climatology cache folder this process made for the session (the workers of pytest-xdist inherit it)."""


def pytest_unconfigure(config):
    # the session's cache folder goes with it (every session left one of its own in the temporary folder)
    folder = _MADE_CACHE.pop(config, None)
    if folder is not None:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the groups
def pytest_collection_modifyitems(config, items):
    # pytest-xdist (-n, --dist loadgroup): the tests that share a scenario's quick run run on one worker, so each
    # scenario is run once; the scenarios are split into two groups of about equal cost (quick_runs.GROUP), one
    # per worker of `make test`; the other tests spread over the workers.
    for item in items:
        if "quick_run" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.xdist_group(quick_run_group(_scenarios_used(item))))


def _scenarios_used(item) -> list:
    """The shipped scenarios whose quick runs ``item`` reads: its parameters that name one, and the names it or
    its fixtures pass to ``quick_run`` as literals."""
    names = set(scenario_names())
    params = getattr(getattr(item, "callspec", None), "params", {})
    used = [v for v in params.values() if isinstance(v, str) and v in names]
    fixtures = getattr(getattr(item, "_fixtureinfo", None), "name2fixturedefs", {})
    for function in [item.function] + [d[-1].func for d in fixtures.values() if d]:
        used += [n for n in _quick_runs_named_in(function) if n in names]
    return used


@functools.cache
def _quick_runs_named_in(function) -> tuple:
    """The names ``function``'s source passes to ``quick_run`` as literals (read once per function: the items of a
    parametrised test and the tests sharing a fixture ask again)."""
    try:
        source = inspect.getsource(function)
    except (OSError, TypeError):
        return ()
    return tuple(re.findall(r"""quick_run\(["'](\w+)["']\)""", source))


def pytest_report_header(config):
    return f"e2esim test seed: {TEST_SEED} (set E2ESIM_TEST_SEED=<int> or random)"


@pytest.fixture(autouse=True)
def _no_run_left_behind():
    """A run a test started through tests/cli_processes.py ends with the test, passed or failed."""
    yield
    stop_leftovers()


@pytest.fixture
def seed(request) -> int:
    """A seed that depends on E2ESIM_TEST_SEED and on the test, so tests do not share streams."""
    # crc32, not hash(): str hashes change from one Python process to the next
    return int(np.random.SeedSequence([TEST_SEED, zlib.crc32(request.node.nodeid.encode())]).generate_state(1)[0])


@pytest.fixture
def rng(seed) -> np.random.Generator:
    return np.random.default_rng(seed)



@pytest.fixture(scope="session")
def published_records() -> dict:
    """{id: ``check(p)``} of every published value (``e2esim.verification``), computed once per session for the
    tests that read them (tests/test_reproduce.py, test_verification_can_fail.py, test_verification_doc.py): a
    record is a frozen dataclass, and a check gives the same record every time."""
    from e2esim.verification.published import all_published
    from e2esim.verification.reproduce import check

    return {p.id: check(p) for p in all_published()}


@pytest.fixture(scope="session")
def quick_run(tmp_path_factory):
    """``quick_run(name)`` -> (ScenarioResult, output folder) of the shipped scenario ``name`` at reduced sizes
    (tests/quick_runs.py), run once per session and shared by the tests that need it."""
    from e2esim.runner.outputs import write_outputs
    from e2esim.runner.run import run_scenario
    from e2esim.runner.scenario import Scenario

    done: dict = {}

    def run(name: str):
        if name not in done:
            scenario = Scenario.load(SCENARIOS / f"{name}.yaml", quick_overrides(name))
            result = run_scenario(scenario.resolve(), progress=False, command=f"quick run of {name}")
            folder = tmp_path_factory.mktemp(name)
            write_outputs(result, folder)
            done[name] = (result, folder)
        return done[name]

    return run

