"""Memory numpy frees is kept for the next arrays (``e2esim.allocator.keep_freed_memory``, set when a run starts;
issue 28: the Monte Carlo per Table II case and the small scenarios spent a third of their time faulting in
again pages glibc had handed back)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

SCRIPT = """
import resource, sys
import numpy as np
from e2esim.allocator import keep_freed_memory

keep_freed_memory()  # as e2esim run and e2esim.run do

def touched(n):
    a = np.empty(n)
    a.fill(1.0)
    return a.sum()

touched(10 * 2**20 // 8)  # 10 MB, made, used and freed
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
touched(10 * 2**20 // 8)  # the same again: in the memory freed before, or in pages faulted in anew
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _clean_environment() -> dict:
    return {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator thresholds (Linux)")
def test_an_array_made_again_reuses_the_memory_freed_before():
    """Before, the second 10 MB array faulted in about 500 pages again (glibc had returned the first one's); now
    none."""
    faults = int(subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, check=True,
                                env=_clean_environment()).stdout)
    assert faults < 50, f"{faults} page faults for an array of 2560 pages made again"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator thresholds (Linux)")
def test_the_users_malloc_settings_stand():
    code = "from e2esim.allocator import keep_freed_memory; print(keep_freed_memory())"
    env = {**_clean_environment(), "MALLOC_ARENA_MAX": "2"}
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                          env=env).stdout.strip() == "False"
