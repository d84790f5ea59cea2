"""Refuse special files before a library opens them: a FIFO blocks its reader for ever, a device such as
``/dev/zero`` never ends, a directory is no file at all.

Used by the readers of files e2esim did not write itself in this run and that no user names as text to parse:
the climatology cache (``e2esim.io.array_cache``) and user AGB maps (``e2esim.scene.agb_map``). The check
follows symbolic links, as the open that comes after it does. (Issue 22; a file could still be swapped for a
FIFO between this check and the open: that needs someone racing you in your own folder.)
"""

from __future__ import annotations

import os
import stat

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


class NotARegularFile(OSError):
    """The path exists but is a directory, FIFO, device or socket; ``kind`` says which."""

    def __init__(self, path, kind: str):
        super().__init__(f"{os.fspath(path)!r} is {kind}, not a regular file")
        self.kind = kind


def regular_file_stat(path) -> os.stat_result:
    """``os.stat(path)`` (following links) if it is a regular file; ``NotARegularFile`` if it is something else,
    ``OSError`` (FileNotFoundError, PermissionError, ...) if it cannot be looked at."""
    st = os.stat(path)
    if not stat.S_ISREG(st.st_mode):
        raise NotARegularFile(path, special_kind(st.st_mode))
    return st


def special_kind(mode: int) -> str:
    """What a non-regular file of ``st_mode`` is, in words."""
    return next((words for test, words in _KINDS if test(mode)), "not a regular file")
