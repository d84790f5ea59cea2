"""Read the Faraday-rotation samples file of `ionosphere.faraday_samples`: a 1-D list of numbers from a user's file
(a text file, one value per line, or a .npy array).

Errors name the file and the problem, never its content: a scenario pointed at a system file must not
print that file's first line. ``.npy`` files are read without pickle (``allow_pickle=False``).
"""

from __future__ import annotations

import errno
import os
import stat
import warnings
from pathlib import Path

import numpy as np

from e2esim.errors import PhysicsInputError

MAX_SAMPLES_FILE_BYTES = 100 * 2**20
"""A samples file: 100 MiB (about 13 million doubles in .npy, 4 million in text)."""


def read_samples_file(path: str | Path, key: str | None = None) -> np.ndarray:
    """The finite numbers of ``path`` as a 1-D float array; ``PhysicsInputError`` (with ``key``) otherwise."""
    path = Path(path)

    def fail(problem: str):
        return PhysicsInputError(f"samples file {path}: {problem}", key=key)

    try:
        info = os.stat(path)
    except OSError as exc:
        raise fail(_stat_problem(path, exc)) from None
    if not stat.S_ISREG(info.st_mode):
        raise fail("is a folder" if stat.S_ISDIR(info.st_mode) else "is not a regular file")
    if info.st_size > MAX_SAMPLES_FILE_BYTES:
        raise fail(f"is larger than the limit of {MAX_SAMPLES_FILE_BYTES // 2**20} MiB")
    try:
        if path.suffix.lower() == ".npy":
            values = _read_npy(path, fail)
        else:
            with warnings.catch_warnings():  # an empty file: reported below as "holds no samples"
                warnings.simplefilter("ignore", UserWarning)
                values = np.loadtxt(path, ndmin=1, dtype=float, comments="#")
    except PhysicsInputError:
        raise
    except OSError as exc:
        raise fail(f"cannot be read: {exc.strerror or type(exc).__name__}") from None
    except (ValueError, UnicodeDecodeError):
        raise fail("is not a text file of numbers (one sample per line; # starts a comment)") from None
    if values.ndim != 1:
        raise fail(f"holds a {values.ndim}-D array of shape {values.shape}; expected a 1-D list of samples")
    if values.size == 0:
        raise fail("holds no samples")
    if not np.all(np.isfinite(values)):
        raise fail(f"holds {int(np.sum(~np.isfinite(values)))} values that are NaN or infinite")
    return values


def _read_npy(path: Path, fail) -> np.ndarray:
    try:
        values = np.load(path, allow_pickle=False)
    except ValueError:
        problem = "is not a .npy file of numbers (it is malformed, or holds Python objects, which are not read)"
        raise fail(problem) from None
    if not isinstance(values, np.ndarray) or values.dtype.kind not in "biuf":
        raise fail("does not hold real numbers")
    return values.astype(float)


def _stat_problem(path: Path, exc: OSError) -> str:
    if exc.errno == errno.ELOOP:
        return "is a symbolic link loop"
    if exc.errno == errno.ENOENT:
        return "is a broken symbolic link" if os.path.islink(path) else "no such file"
    if exc.errno == errno.EACCES:
        return "permission denied"
    return f"cannot be read: {exc.strerror or type(exc).__name__}"
