"""Writing an HDF5 file so that a full disk, the file-size limit or Ctrl-C ends in one clean error, never a crash.

HDF5 does not recover from a failed write. When the disk fills while results.h5 is written, the write fails
inside HDF5's flush of an object that h5py is freeing ("Can't decrement id ref count"): the error cannot be
raised there, the object stays open inside HDF5, and HDF5 closes it again when the interpreter exits, after
Python has shut down, and the process dies with a segmentation fault; a failure inside ``close`` gives a
``RuntimeError`` instead of an ``OSError``. So HDF5 never sees a failed write here: it writes through h5py's
file-object driver into ``GuardedFile``, which hands the bytes to the real file until a write fails, keeps that
error, and from then on keeps the bytes in memory (reads see them), so that HDF5 finishes and closes the file
normally. The writer calls ``check_writing`` before each dataset (``e2esim.io.h5_datasets.put`` does) and so
stops at the first dataset after a failure: memory holds at most that dataset and the file's metadata. The
error is raised once HDF5 has closed the file, and the atomic writer deletes the half-written file. Ctrl-C is
held back while HDF5 runs, for the same reason (an exception inside HDF5's file callbacks), and raised the same
way, at the next dataset.
"""

from __future__ import annotations

import contextlib
import io
import os
from contextvars import ContextVar

import h5py

from e2esim.runner.interrupts import interrupts_deferred

_WRITING: ContextVar = ContextVar("e2esim_guarded_h5", default=None)
_FLAGS = os.O_RDWR | os.O_TRUNC | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)


class GuardedFile(io.RawIOBase):
    """A binary file for h5py's file-object driver whose writes never fail (see the module's docstring).

    failure : the first exception a read or write of the real file raised, or None.
    """

    def __init__(self, fd: int):
        self._file = open(fd, "r+b", buffering=0, closefd=False)
        self._pos = 0
        self._size = os.fstat(fd).st_size  # the file's length as HDF5 sees it
        self._kept: list = []  # [(offset, bytes)] written after the failure, kept in memory
        self.failure: BaseException | None = None

    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        base = {os.SEEK_SET: 0, os.SEEK_CUR: self._pos, os.SEEK_END: self._size}[whence]
        self._pos = base + offset
        return self._pos

    def tell(self) -> int:
        return self._pos

    def readinto(self, buffer) -> int:
        view = memoryview(buffer).cast("B")
        n = max(0, min(len(view), self._size - self._pos))
        view[:n] = bytes(n)  # beyond what the disk holds: zeros, as a sparse file reads
        try:
            self._file.seek(self._pos)
            self._file.readinto(view[:n])
        except BaseException as exc:  # nothing may reach HDF5
            self._fail(exc)
        for offset, data in self._kept:  # what was written after a failure, later writes over earlier ones
            lo, hi = max(offset, self._pos), min(offset + len(data), self._pos + n)
            if lo < hi:
                view[lo - self._pos:hi - self._pos] = data[lo - offset:hi - offset]
        self._pos += n
        return n

    def write(self, data) -> int:
        view = memoryview(data).cast("B")
        if self.failure is None:
            try:
                self._file.seek(self._pos)
                done = 0
                while done < len(view):
                    done += self._file.write(view[done:])
            except BaseException as exc:  # nothing may reach HDF5
                self._fail(exc)
        if self.failure is not None:
            self._kept.append((self._pos, bytes(view)))
        self._pos += len(view)
        self._size = max(self._size, self._pos)
        return len(view)

    def truncate(self, size: int | None = None) -> int:
        size = self._pos if size is None else size
        if self.failure is None:
            try:
                self._file.truncate(size)
            except BaseException as exc:  # nothing may reach HDF5
                self._fail(exc)
        self._size = size
        return size

    def flush(self) -> None:
        pass  # unbuffered: every write went to the OS (or to memory after a failure)

    def _fail(self, exc: BaseException) -> None:
        if self.failure is None:
            self.failure = exc

    def close(self) -> None:
        self._file.close()
        self._kept = []
        super().close()


@contextlib.contextmanager
def guarded_h5_file(path):
    """A new ``h5py.File`` at ``path`` (created or emptied; never through a symbolic link), written through a
    ``GuardedFile``. The first failed write (an ``OSError``: a full disk, the file-size limit) or a Ctrl-C is
    raised after HDF5 has closed the file, or earlier by ``check_writing``; the file is then incomplete."""
    fd = os.open(path, _FLAGS | os.O_CREAT, 0o600)
    guard = GuardedFile(fd)
    try:
        with interrupts_deferred() as interrupt:
            token = _WRITING.set((guard, interrupt))
            try:
                with h5py.File(guard, "w") as f:
                    yield f
            finally:
                _WRITING.reset(token)
            if guard.failure is not None:
                raise guard.failure
    finally:
        guard.close()
        os.close(fd)


def check_writing() -> None:
    """Inside ``guarded_h5_file``: raise the write error, or the interrupt (Ctrl-C, a stop signal), that came meanwhile,
    so that the writer stops (HDF5 then closes the file normally). Elsewhere: nothing."""
    active = _WRITING.get()
    if active is None:
        return
    guard, interrupt = active
    if guard.failure is not None:
        raise guard.failure
    interrupt.raise_now()  # raised here, not again when the deferral ends
