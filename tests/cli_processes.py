"""``e2esim`` in a fresh interpreter, for the tests that signal, kill or race real runs (faults, locks, resume)."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest


def e2esim_process(*args, limit_bytes=None, **kw) -> subprocess.Popen:
    """``e2esim ARGS`` started in a fresh interpreter (text pipes), with a file-size limit (RLIMIT_FSIZE) when
    asked; ``kw`` go to ``subprocess.Popen``."""

    def limited():
        import resource

        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))

    return subprocess.Popen([sys.executable, "-m", "e2esim", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=limited if limit_bytes else None, **kw)


def wait_for(predicate, proc, timeout=120) -> None:
    """Wait until ``predicate()`` holds; fail the test if ``proc`` ends first or ``timeout`` s pass (a hang)."""
    start = time.monotonic()
    while not predicate():
        if proc.poll() is not None:
            pytest.fail(f"the run ended early: {proc.stderr.read()}")
        if time.monotonic() - start > timeout:
            pytest.fail("timed out")
        time.sleep(0.02)
