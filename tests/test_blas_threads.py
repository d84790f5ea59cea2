"""One BLAS thread for the stack kernels (e2esim.blas_threads): the count inside and after, the kernels run with it,
and the numbers do not depend on it."""

import numpy as np
import pytest

import e2esim.stack.analytic as analytic
from e2esim.blas_threads import blas_threads, one_blas_thread, single_blas_thread
from e2esim.stack import combination as combos
from stack_helpers import site_scene, stack_errors

THREADS = blas_threads()
needs_openblas = pytest.mark.skipif(not THREADS, reason="no OpenBLAS found in this process (not Linux, or no BLAS)")


def counts() -> list:
    return [get() for _, get in THREADS]


@needs_openblas
def test_one_thread_inside_and_the_count_restored_after():
    set_threads, _ = THREADS[0]
    before = counts()[0]
    set_threads(2)
    try:
        with one_blas_thread():
            assert counts()[0] == 1
        assert counts()[0] == 2
        seen = []
        single_blas_thread(lambda: seen.append(counts()[0]))()
        assert seen == [1] and counts()[0] == 2
    finally:
        set_threads(before)


@needs_openblas
def test_the_stack_kernel_runs_with_one_thread_and_gives_the_same_numbers(monkeypatch):
    """stack_hv_moments evaluates its kernel with one BLAS thread; with two (the kernel called directly) every
    coefficient is the same bit for bit (OpenBLAS splits a product's output among threads, never a sum)."""
    scene = site_scene("boreal", phase="tomographic")
    combination = combos.single_date(scene.passes, 1)
    errors, faraday = stack_errors(correlation=0.5, difference_deg=10.0)
    seen, inputs = [], []
    kernel = analytic.node_polynomials

    def spy(*args):
        seen.append(counts()[0])
        inputs.append(args)
        return kernel(*args)

    monkeypatch.setattr(analytic, "node_polynomials", spy)
    set_threads, _ = THREADS[0]
    before = counts()[0]
    set_threads(2)
    try:
        analytic.stack_hv_moments(scene, errors, faraday, combination, looks=100)
        assert seen == [1] and counts()[0] == 2
        threaded = kernel(*inputs[0])
        set_threads(1)
        single = kernel(*inputs[0])
    finally:
        set_threads(before)
    for key, value in single.items():
        if value is not None:
            np.testing.assert_array_equal(value, threaded[key], err_msg=key)
