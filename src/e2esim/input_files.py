"""Opening a file e2esim did not just write: only a regular file, checked before a byte is read.

Used by every reader of a file from a user or an earlier run: results.h5 and resume journals (``open_regular``),
the climatology cache and user AGB maps (``regular_file_stat``, for libraries that open the file by its name).

A FIFO blocks the reader until something writes to it (for ever, if nothing does), ``/dev/zero`` or
``/dev/urandom`` never end, and a folder is not a file. So every file e2esim reads from a user or from an
earlier run (a results.h5, a resume journal and its manifest) is first opened without blocking
(``O_NONBLOCK``, which does not wait for a FIFO's writer) and checked with ``fstat`` on the open descriptor,
so the check and the read are of the same file. ``nofollow`` refuses a symbolic link in the last component
(``O_NOFOLLOW``), for files inside an output folder that e2esim itself names.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from e2esim.errors import UserError


def special_kind(mode: int) -> str | None:
    """What a file of ``st_mode`` is when it is not a regular file ("a FIFO", "a folder", ...), else None."""
    kinds = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
             (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))
    return next((name for test, name in kinds if test(mode)), None if stat.S_ISREG(mode) else "not a regular file")


def open_regular(path, what: str, error=UserError, nofollow: bool = False, write: bool = False) -> int:
    """A descriptor of the regular file ``path`` (read-only; read and write with ``write``); raise ``error``
    naming ``what`` if it is missing, unreadable, a symbolic link (with ``nofollow``) or not a regular file."""
    flags = (os.O_RDWR if write else os.O_RDONLY) | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    if nofollow:
        flags |= getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        if nofollow and exc.errno == errno.ELOOP:
            raise error(f"{path}: the {what} is a symbolic link; e2esim does not follow links there") from exc
        raise error(f"{path}: cannot open the {what}: {exc.strerror or exc}") from exc
    try:
        kind = special_kind(os.fstat(fd).st_mode)
        if kind is not None:
            raise error(f"{path}: the {what} is {kind}, not a regular file; e2esim reads only regular files")
        os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd


class NotARegularFile(OSError):
    """The path exists but is a folder, FIFO, device or socket; ``kind`` says which."""

    def __init__(self, path, kind: str):
        super().__init__(f"{os.fspath(path)!r} is {kind}, not a regular file")
        self.kind = kind


def regular_file_stat(path) -> os.stat_result:
    """``os.stat(path)`` (following links, as the library's open after it does) if it is a regular file;
    ``NotARegularFile`` if it is something else, ``OSError`` if it cannot be looked at. A stat never blocks, even
    on a FIFO; a file swapped for a FIFO between this check and the open needs someone racing you in your folder."""
    st = os.stat(path)
    kind = special_kind(st.st_mode)
    if kind is not None:
        raise NotARegularFile(path, kind)
    return st


def check_regular(path, what: str, error=UserError) -> int:
    """The size of the regular file ``path``, checked as by ``open_regular`` (for a library that opens the file
    by its name itself, such as HDF5)."""
    fd = open_regular(path, what, error)
    try:
        return os.fstat(fd).st_size
    finally:
        os.close(fd)


def read_limited(fd: int, count: int) -> bytes:
    """Exactly ``count`` bytes from ``fd`` (fewer only at the end of the file), read in pieces."""
    pieces, left = [], count
    while left > 0:
        piece = os.read(fd, min(left, 1 << 24))
        if not piece:
            break
        pieces.append(piece)
        left -= len(piece)
    return b"".join(pieces)


def scenario_relative(value: str, scenario_source) -> Path:
    """The file a scenario names with ``value``: ``~`` expanded, and a relative path taken from the scenario file's
    folder when the scenario came from a file (``scenario_source``; else from the working directory). Every module
    that reads an input file and the provenance that hashes it (``e2esim.runner.scenario_files``) use this rule, so
    the file hashed is the file read."""
    path = Path(value).expanduser()
    if not path.is_absolute() and scenario_source and Path(scenario_source).is_file():
        path = Path(scenario_source).parent / path
    return path


__all__ = ["NotARegularFile", "check_regular", "open_regular", "read_limited", "regular_file_stat",
           "scenario_relative", "special_kind"]
