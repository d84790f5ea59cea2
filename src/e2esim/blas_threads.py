"""One OpenBLAS thread for a stretch of small matrix products.

numpy and scipy wheels bundle OpenBLAS, which by default starts a thread per core. The physics kernels here are
batches of small products (sides of at most a few tens); a threaded BLAS splits each one, and its threads waiting
on each other cost more CPU time than they save, most of all on a shared machine: a batch of 600 products of a
21 x 21 matrix by a vector took 94 ms with two threads at a load of 16 on two cores, 0.2 ms with one (the
processes of a run already share the cores). The numbers are the same bit for bit: OpenBLAS splits a product's
output among its threads, never a sum, so every entry is computed by the same kernel whatever the count (checked
by the number lock of the stack scenarios and the uncertainty product).
"""

from __future__ import annotations

import ctypes
import functools
from contextlib import contextmanager

SETTERS = (("scipy_openblas_set_num_threads64_", "scipy_openblas_get_num_threads64_"),
           ("scipy_openblas_set_num_threads", "scipy_openblas_get_num_threads"),
           ("openblas_set_num_threads64_", "openblas_get_num_threads64_"),
           ("openblas_set_num_threads", "openblas_get_num_threads"))


def blas_threads() -> list:
    """(set, get) of the thread count of every OpenBLAS this process has loaded (numpy's and scipy's wheels bundle
    one each), found through /proc/self/maps (Linux; elsewhere none: nothing is changed)."""
    try:
        with open("/proc/self/maps") as maps:
            paths = tuple(sorted({line.split()[-1] for line in maps if "openblas" in line.split()[-1]}))
    except OSError:
        return []
    return list(_library_setters(paths))


@functools.cache
def _library_setters(paths: tuple) -> tuple:
    """The (set, get) functions of the libraries ``paths``, looked up once per set of loaded libraries."""
    found = []
    for path in paths:
        library = ctypes.CDLL(path)
        for set_name, get_name in SETTERS:
            if hasattr(library, set_name) and hasattr(library, get_name):
                found.append((getattr(library, set_name), getattr(library, get_name)))
                break
    return tuple(found)


@contextmanager
def one_blas_thread(threads: list | None = None):
    """One BLAS thread inside the block, the count restored afterwards (module docstring). threads : the
    ``blas_threads()`` of this process, found once by a caller that enters the block many times (None: found
    here)."""
    threads = blas_threads() if threads is None else threads
    saved = [get() for _, get in threads]
    for set_threads, _ in threads:
        set_threads(1)
    try:
        yield
    finally:
        for (set_threads, _), count in zip(threads, saved):
            set_threads(count)


@functools.cache
def _threads_at_first_use() -> list:
    return blas_threads()


def single_blas_thread(func):
    """``func`` run inside ``one_blas_thread`` (a decorator for a kernel called many times: the libraries are
    looked up at its first call; numpy's OpenBLAS, loaded with numpy, is among them)."""
    @functools.wraps(func)
    def run(*args, **kwargs):
        with one_blas_thread(_threads_at_first_use()):
            return func(*args, **kwargs)
    return run
