"""One run at a time per output folder: a lock file holding the PID of the run that writes there.

POSIX: ``fcntl.flock`` on ``<folder>/.e2esim.lock``. The kernel releases the lock when its process ends,
however it ends (SIGKILL included), so a lock is never stale; the PID in the file is only for the message.
Elsewhere: the file is created exclusively (``O_EXCL``) and a file whose PID no longer runs is stale and
taken over. A second run into a locked folder is refused, with or without ``--force``.

The lock file is opened without following a symbolic link (``O_NOFOLLOW``) and used only if it is a regular
file with one name: a link planted under its name, or a hard link to a file elsewhere, would otherwise have
the PID written into (and the content cut off) a file outside the output folder. Such a lock is refused.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
from pathlib import Path

from e2esim.errors import OutputFolderError

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

LOCK_NAME = ".e2esim.lock"
_OPEN_FLAGS = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)


class FolderLock:
    """The lock of one output folder; ``acquire`` or refuse, ``release`` when the run is done."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self.path = self.folder / LOCK_NAME
        self._fd: int | None = None

    def acquire(self) -> FolderLock:
        for _ in range(20):  # another run may remove the file between our open and our lock: try again
            try:
                fd = self._open()
            except OSError as exc:
                if exc.errno == errno.ELOOP:
                    raise self._foreign("is a symbolic link") from None
                raise OutputFolderError(f"{self.folder}: cannot write into the output folder: "
                                        f"{exc.strerror or exc}") from exc
            if fd is None:
                continue
            try:
                self._check_own(fd)
                os.ftruncate(fd, 0)
                os.write(fd, f"{os.getpid()}\n".encode())
            except OutputFolderError:
                os.close(fd)  # not ours: left as it is, for the user to look at
                raise
            except OSError as exc:
                os.close(fd)
                with contextlib.suppress(OSError):
                    os.unlink(self.path)
                raise OutputFolderError(f"{self.folder}: cannot write into the output folder: "
                                        f"{exc.strerror or exc}") from exc
            self._fd = fd
            return self
        raise OutputFolderError(f"{self.folder}: cannot lock the output folder; other runs keep starting there")

    def _open(self) -> int | None:
        """A descriptor of the lock file that this process now holds, None to try again; refuses if held."""
        if fcntl is None:  # pragma: no cover - Windows
            return self._open_exclusive()
        fd = os.open(self.path, _OPEN_FLAGS | os.O_NONBLOCK, 0o644)  # O_NONBLOCK: a FIFO planted there cannot hang
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise self._busy(self._holder()) from None
            raise
        try:  # still the file at the path? (a finishing run unlinks it after we opened it)
            same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if not same:
            os.close(fd)
            return None
        return fd

    def _check_own(self, fd: int) -> None:
        """Refuse a lock file that is not a regular file with this one name (a FIFO, a device, a hard link)."""
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise self._foreign("is not a regular file")
        if info.st_nlink != 1:
            raise self._foreign(f"has {info.st_nlink} names (a hard link to a file elsewhere?)")

    def _foreign(self, what: str) -> OutputFolderError:
        return OutputFolderError(f"{self.path}: {what}, not a lock file of e2esim; it was not written to. Remove it "
                                 "if you know where it comes from, or choose another folder with -o")

    def _open_exclusive(self) -> int | None:  # pragma: no cover - Windows
        try:
            return os.open(self.path, _OPEN_FLAGS | os.O_EXCL, 0o644)
        except FileExistsError:
            pid = self._holder()
            if pid is not None and _alive(pid):
                raise self._busy(pid) from None
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.path)  # stale: its run is gone
            return None

    def _holder(self) -> int | None:
        """The PID in the lock file (for the message); None if it cannot be read."""
        try:
            fd = os.open(self.path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOFOLLOW", 0))
        except OSError:
            return None
        try:
            text = os.read(fd, 32).decode("ascii", errors="replace").strip()  # a PID is a few digits
        except OSError:
            return None
        finally:
            os.close(fd)
        return int(text) if text.isdigit() else None

    def _busy(self, pid: int | None) -> OutputFolderError:
        who = f"PID {pid}" if pid is not None else "PID unknown"
        return OutputFolderError(f"{self.folder}: another e2esim run ({who}) is writing into this folder; wait "
                                 "for it to end, or choose another folder with -o (--force does not take over a "
                                 "live run)")

    def release(self) -> None:
        if self._fd is None:
            return
        with contextlib.suppress(OSError):
            os.unlink(self.path)  # unlink first, then unlock: a waiting run then re-checks the path
        os.close(self._fd)
        self._fd = None

    def __enter__(self) -> FolderLock:
        return self.acquire() if self._fd is None else self

    def __exit__(self, *exc) -> None:
        self.release()


def _alive(pid: int) -> bool:  # pragma: no cover - used on Windows only
    if os.name != "posix":
        return True  # no safe liveness test without extra packages: the user removes a stale lock
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
