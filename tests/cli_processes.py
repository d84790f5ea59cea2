"""``e2esim`` in a fresh interpreter, for the tests that signal, kill or race real runs (faults, locks, resume)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

_STARTED: list = []
"""Every process ``e2esim_process`` started, so that ``stop_leftovers`` can end what a failed test left running."""


def e2esim_process(*args, limit_bytes=None, **kw) -> subprocess.Popen:
    """``e2esim ARGS`` started in a fresh interpreter (text pipes), with a file-size limit (RLIMIT_FSIZE) when
    asked; ``kw`` go to ``subprocess.Popen``."""

    def limited():
        import resource

        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))

    proc = subprocess.Popen([sys.executable, "-m", "e2esim", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=limited if limit_bytes else None, **kw)
    _STARTED.append(proc)
    return proc


def children(pid: int) -> set:
    """PIDs whose parent is ``pid`` (Linux /proc)."""
    out = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.add(int(stat.parent.name))
    return out


def stop_leftovers() -> None:
    """Kill the runs a test started and did not see end (a hang guard that fired, a failed assertion), their
    workers first: a run left behind would load the machine for the tests after it."""
    while _STARTED:
        proc = _STARTED.pop()
        if proc.poll() is not None:
            continue
        for pid in children(proc.pid):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        proc.kill()
        proc.communicate()


def wait_for(predicate, proc, timeout=120) -> None:
    """Wait until ``predicate()`` holds; fail the test if ``proc`` ends first or ``timeout`` s pass (a hang)."""
    start = time.monotonic()
    while not predicate():
        if proc.poll() is not None:
            pytest.fail(f"the run ended early: {proc.stderr.read()}")
        if time.monotonic() - start > timeout:
            pytest.fail("timed out")
        time.sleep(0.02)
