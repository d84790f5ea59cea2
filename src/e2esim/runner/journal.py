"""Incremental results of a run, so an interrupted sweep resumes without recomputing finished cases.

While a run is going, every finished block of cases (``e2esim.runner.run.BlockResult``: the columns of its
cases, and their products when the run keeps them) is appended, as soon as it finishes, to
``<output>/.e2esim-partial/cases.journal``, beside a ``manifest.json`` holding the journal format and
the run's fingerprint: the resolved scenario, the sweep, every seed, and the e2esim version.
Both are plain data, never pickle (``e2esim.runner.plaindata``): each record is a frame

    magic "E2J2" | number of cases, header length, payload length (little-endian u64) | CRC-32 | header | payload

with a JSON header and the block's numeric arrays as raw bytes. Reading a journal builds numbers, text,
arrays and e2esim's own result objects, and runs no code from the file; the files are read with limits
(``e2esim.runner.journal_records``: regular files only, each record checked before its bytes are read) and
a record that does not check out (magic, lengths, CRC, JSON, dtypes and shapes, allowed classes, the block
it must be for this run, ``e2esim.runner.journal_check``) makes the journal corrupt: exit status 2, with
``--force`` as the way out. A process killed while writing leaves at
most a torn last frame, shorter than it says, which ``--resume`` cuts off. A block whose result holds
something plain data cannot store (a plug-in's own object, say) is simply not journaled and runs again
on resume. The files are created with the first finished case, so a run that fails before any case
finishes (an unreachable scheduler) leaves no journal. ``e2esim run --resume`` loads the records when the
fingerprint matches, runs the other cases and writes the final outputs; the journal is then removed.
One appended file of blocks keeps the bookkeeping cheap for sweeps of a million cases.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import stat
import zlib
from pathlib import Path

import numpy as np

import e2esim
from e2esim.atomic import write_text_atomic
from e2esim.errors import OutputExistsError, OutputFolderError
from e2esim.runner.interrupts import interrupts_deferred
from e2esim.runner.journal_check import BadRecord, check_block
from e2esim.runner.journal_records import FORMAT, VERSION, corrupt, read_manifest, records
from e2esim.runner.journal_records import FRAME as _FRAME
from e2esim.runner.journal_records import MAGIC as _MAGIC
from e2esim.runner.journal_records import MANIFEST as _MANIFEST
from e2esim.runner.journal_records import RECORDS as _RECORDS
from e2esim.runner.plaindata import BadPlainData, NotPlainData, allowed_packages, decode, encode
from e2esim.runner.scenario_files import changed_files, scenario_input_files

JOURNAL = ".e2esim-partial"
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)  # never write through a planted link


def fingerprint(resolved, input_files=()) -> str:
    """Hash of everything that determines the numbers of a run: the version, the resolved scenario, the sweep
    (every case's inputs follow from it), every seed and the content of every input file the scenario names
    (``input_files``, from ``e2esim.runner.scenario_files``)."""
    table = resolved.plan.table
    payload = {
        "version": e2esim.__version__,
        "resolved": resolved.resolved,
        "sweep": [table.layout, [[list(g.keys), [list(v) for v in g.values]] for g in table.groups]],
        "seeds": [s.seed for s in resolved.plan.settings_slot.objects],
    }
    if input_files:  # absent without files, so that the journals of runs without input files keep their identity
        payload["input_files"] = [[f["key"], f["path"], f["sha256"]] for f in input_files]
    digest = hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode())
    if table.table is not None:
        digest.update(np.ascontiguousarray(table.table).tobytes())
    return digest.hexdigest()


def encode_block(result, packages: frozenset) -> bytes | None:
    """The journal frame of one finished block, or None if its result is not plain data."""
    try:
        header, payload = encode(result, packages)
    except (NotPlainData, ValueError):
        return None
    crc = zlib.crc32(payload, zlib.crc32(header))
    return _FRAME.pack(_MAGIC, len(result), len(header), len(payload), crc) + header + payload


class Journal:
    """The partial results of one run in ``folder``."""

    def __init__(self, folder: Path, resolved):
        self.path = Path(folder) / JOURNAL
        self.resolved = resolved
        self.input_files = scenario_input_files(resolved)
        self.fingerprint = fingerprint(resolved, self.input_files)
        self.packages = allowed_packages()
        self._fd: int | None = None  # the records file, appended to without a buffer
        self._end = 0  # its length in whole frames
        self._count = 0

    def exists(self) -> bool:
        return (self.path / _MANIFEST).exists()

    def finished_count(self) -> int:
        return self._count

    def start(self, resume: bool):
        """Check an existing journal; with ``resume``, return the finished blocks it holds (``BlockResult``s) as an
        iterator that reads, checks and gives one record at a time, to be consumed once and whole: the runner spills
        each block before the next is read (``run_scenario``), so resuming a large run never holds its journal, or
        its blocks, in memory. A record that does not check out raises ``JournalError`` when it is reached."""
        self._refuse_link()
        if not self.exists():
            return []
        manifest = read_manifest(self.path)
        if not resume:
            raise OutputExistsError(
                f"{self.path.parent}: holds an interrupted run ({count_finished(self.path.parent)} cases finished); "
                "use --resume to continue it or --force to start again"
            )
        if manifest.get("fingerprint") != self.fingerprint:
            self._refuse_changed_files(manifest)
            raise OutputExistsError(
                f"{self.path.parent}: the interrupted run there is of a different scenario, seed or e2esim "
                "version; use --force to start again"
            )
        return self._finished()

    def _refuse_changed_files(self, manifest: dict) -> None:
        recorded = manifest.get("input_files")
        changed = changed_files(recorded, self.input_files) if isinstance(recorded, list) else []
        if changed:
            named = ", ".join(f"{key} ({path})" for key, path in changed)
            raise OutputExistsError(
                f"{self.path.parent}: the input file {named} changed since the interrupted run there (its size or "
                "SHA-256 differs, or it is named anew); a resumed run would mix results of two inputs. Run without "
                "--resume (with --force) to start again, or restore the file as it was"
            )

    def _finished(self):
        seen = np.zeros(len(self.resolved.cases), dtype=bool)
        # a torn last frame is cut off once read, so appends continue cleanly
        for number, (count, header, payload) in enumerate(records(self.path, truncate=True)):
            block = self._block(number, count, header, payload)
            if seen[block.indices].any():
                raise corrupt(self.path, f"record {number} repeats cases of an earlier record")
            seen[block.indices] = True
            self._count += len(block)
            del header, payload
            yield block
            del block  # not held while the next record is read: one block in memory at a time

    def _block(self, number: int, count: int, header: bytes, payload: bytes):
        """The checked ``BlockResult`` of one record (``e2esim.runner.journal_check``)."""
        try:
            result = decode(header, payload, self.packages)
            check_block(result, self.resolved, self.packages)
        except (BadPlainData, BadRecord) as exc:
            raise corrupt(self.path, f"record {number} is not a finished block of this run: {exc}") from exc
        if len(result) != count:
            raise corrupt(self.path, f"record {number} claims {count} cases and holds {len(result)}")
        return result

    def record(self, result, data: bytes | None = None) -> None:
        """Append one finished block (``data``: its frame, when a worker already made it). The frame goes to the OS
        at once (no buffer: a killed process loses nothing it reported finished, and a failed write leaves nothing
        behind to fail again on close); Ctrl-C waits until it is written; a write that fails (a full disk, the
        file-size limit) is cut off again, so the journal keeps whole frames only."""
        data = encode_block(result, self.packages) if data is None else data
        if data is None:
            return  # not plain data: it runs again on resume
        if self._fd is None:
            self._create()
        with interrupts_deferred():
            try:
                _write_all(self._fd, data)
            except OSError as exc:
                with contextlib.suppress(OSError):
                    os.ftruncate(self._fd, self._end)
                raise OutputFolderError(f"{self.path}: cannot save a finished block: {exc.strerror or exc} "
                                        f"({self._count} cases are saved)") from exc
            self._end += len(data)
            self._count += len(result)

    def _create(self) -> None:
        try:
            self.path.mkdir(parents=True, exist_ok=True)
            self._refuse_link()
            manifest = {"format": FORMAT, "version": VERSION, "e2esim": e2esim.__version__,
                        "fingerprint": self.fingerprint, "cases": len(self.resolved.cases),
                        "input_files": self.input_files}
            write_text_atomic(self.path / _MANIFEST, json.dumps(manifest) + "\n")
            fd = os.open(self.path / _RECORDS, os.O_WRONLY | os.O_CREAT | os.O_APPEND | _NOFOLLOW, 0o644)
            info = os.fstat(fd)
            if not stat.S_ISREG(info.st_mode):
                os.close(fd)
                raise OutputFolderError(f"{self.path / _RECORDS}: is not a regular file; it was not written to")
            self._fd, self._end = fd, info.st_size
        except OSError as exc:
            raise OutputFolderError(f"{self.path}: cannot create the resume journal: {exc.strerror or exc}") from exc

    def _refuse_link(self) -> None:
        """A journal folder planted as a symbolic link would have the journal written (and cut) elsewhere."""
        if self.path.is_symlink():
            raise OutputFolderError(f"{self.path}: is a symbolic link, not a journal of e2esim; it was not used. "
                                    "Remove it, or choose another folder with -o")

    def close(self) -> None:
        """Close the records file; never fails (every frame was written whole or cut off when it was appended)."""
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.close(self._fd)
            self._fd = None

    def remove(self) -> None:
        self.close()
        shutil.rmtree(self.path, ignore_errors=True)


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def count_finished(folder: Path) -> int:
    """Number of cases in the complete records of the journal of an output folder (checked, not decoded)."""
    path = Path(folder) / JOURNAL
    read_manifest(path)
    return sum(count for count, _, _ in records(path))
