"""Incremental results of a run, so an interrupted sweep resumes without recomputing finished cases.

While a run is going, every finished block of cases (``e2esim.runner.run.BlockResult``: the columns of its
cases, and their products when the run keeps them) is appended, as soon as it finishes, to
``<output>/.e2esim-partial/cases.journal``, beside a ``manifest.json`` holding the journal format and
the run's fingerprint: the resolved scenario, the sweep, every seed, and the e2esim version.
Both are plain data, never pickle (``e2esim.runner.plaindata``): each record is a frame

    magic "E2J2" | number of cases, header length, payload length (little-endian u64) | CRC-32 | header | payload

with a JSON header and the block's numeric arrays as raw bytes. Reading a journal builds numbers, text,
arrays and e2esim's own result objects, and runs no code from the file; a record that does not check out
(magic, lengths, CRC, JSON, dtypes and shapes, allowed classes, the case it claims to be) makes the
journal corrupt: exit status 2, with ``--force`` as the way out. A process killed while writing leaves at
most a torn last frame, shorter than it says, which ``--resume`` cuts off. A block whose result holds
something plain data cannot store (a plug-in's own object, say) is simply not journaled and runs again
on resume. The files are created with the first finished case, so a run that fails before any case
finishes (an unreachable scheduler) leaves no journal. ``e2esim run --resume`` loads the records when the
fingerprint matches, runs the other cases and writes the final outputs; the journal is then removed.
One appended file of blocks keeps the bookkeeping cheap for sweeps of a million cases.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import struct
import zlib
from pathlib import Path

import numpy as np

import e2esim
from e2esim.errors import JournalError, OutputExistsError, OutputFolderError
from e2esim.io.atomic import write_text_atomic
from e2esim.runner.plaindata import BadPlainData, NotPlainData, allowed_packages, decode, encode

JOURNAL = ".e2esim-partial"
_RECORDS = "cases.journal"
_MANIFEST = "manifest.json"
FORMAT = "e2esim-journal"
VERSION = 3  # 1 was the pickle journal of e2esim <= 0.x, 2 a journal of single cases; neither is read
_MAGIC = b"E2J2"
_FRAME = struct.Struct("<4sQQQI")  # magic, number of cases, header length, payload length, CRC-32 of both


def fingerprint(resolved) -> str:
    """Hash of everything that determines the numbers of a run: the version, the resolved scenario, the sweep
    (every case's inputs follow from it) and every seed."""
    table = resolved.plan.table
    payload = {
        "version": e2esim.__version__,
        "resolved": resolved.resolved,
        "sweep": [table.layout, [[list(g.keys), [list(v) for v in g.values]] for g in table.groups]],
        "seeds": [s.seed for s in resolved.plan.settings_slot.objects],
    }
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
        self.fingerprint = fingerprint(resolved)
        self.packages = allowed_packages()
        self._file = None
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
        if not self.exists():
            return []
        manifest = read_manifest(self.path)
        if not resume:
            raise OutputExistsError(
                f"{self.path.parent}: holds an interrupted run ({count_finished(self.path.parent)} cases finished); "
                "use --resume to continue it or --force to start again"
            )
        if manifest.get("fingerprint") != self.fingerprint:
            raise OutputExistsError(
                f"{self.path.parent}: the interrupted run there is of a different scenario, seed or e2esim "
                "version; use --force to start again"
            )
        return self._finished()

    def _finished(self):
        seen = np.zeros(len(self.resolved.cases), dtype=bool)
        good_length = 0
        for number, (count, header, payload, end) in enumerate(_frames(self.path / _RECORDS)):
            block = self._block(number, count, header, payload)
            if seen[block.indices].any():
                raise _corrupt(self.path, f"record {number} repeats cases of an earlier record")
            seen[block.indices] = True
            self._count += len(block)
            del header, payload
            yield block
            del block  # not held while the next record is read: one block in memory at a time
            good_length = end
        if (self.path / _RECORDS).exists():
            with open(self.path / _RECORDS, "r+b") as fh:  # cut a torn last frame off, so appends continue cleanly
                fh.truncate(good_length)

    def _block(self, number: int, count: int, header: bytes, payload: bytes):
        from e2esim.runner.run import BlockResult

        try:
            result = decode(header, payload, self.packages)
        except BadPlainData as exc:
            raise _corrupt(self.path, f"record {number} is not valid: {exc}") from exc
        n = len(self.resolved.cases)
        indices = getattr(result, "indices", None)
        if (not isinstance(result, BlockResult) or not isinstance(indices, np.ndarray) or indices.ndim != 1
                or indices.dtype.kind not in "iu" or len(indices) != count or count == 0
                or indices.min() < 0 or indices.max() >= n or len(np.unique(indices)) != count):
            raise _corrupt(self.path, f"record {number} is not a finished block of this run")
        return result

    def record(self, result, data: bytes | None = None) -> None:
        """Append one finished block (``data``: its frame, when a worker already made it)."""
        data = encode_block(result, self.packages) if data is None else data
        if data is None:
            return  # not plain data: it runs again on resume
        if self._file is None:
            self._create()
        try:
            self._file.write(data)
            self._file.flush()  # in the OS's hands at once: a killed process loses nothing it reported finished
        except OSError as exc:
            raise OutputFolderError(f"{self.path}: cannot save a finished block: {exc.strerror or exc}; "
                                    f"{self._count} cases are saved; free the space and run the same command "
                                    "with --resume") from exc
        self._count += len(result)

    def _create(self) -> None:
        try:
            self.path.mkdir(parents=True, exist_ok=True)
            manifest = {"format": FORMAT, "version": VERSION, "e2esim": e2esim.__version__,
                        "fingerprint": self.fingerprint, "cases": len(self.resolved.cases)}
            write_text_atomic(self.path / _MANIFEST, json.dumps(manifest) + "\n")
            self._file = open(self.path / _RECORDS, "ab")
        except OSError as exc:
            raise OutputFolderError(f"{self.path}: cannot create the resume journal: {exc.strerror or exc}") from exc

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def remove(self) -> None:
        self.close()
        shutil.rmtree(self.path, ignore_errors=True)


def read_manifest(path: Path) -> dict:
    """The manifest of the journal folder ``path``, checked: JSON of this format and version."""
    try:
        text = (path / _MANIFEST).read_text(encoding="utf-8")
        manifest = json.loads(text)
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise _corrupt(path, f"its manifest cannot be read ({type(exc).__name__})") from exc
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise _corrupt(path, "it is not an e2esim journal, or one of an older e2esim that is not read")
    if manifest.get("version") != VERSION:
        raise _corrupt(path, f"it has journal version {str(manifest.get('version'))[:20]}, this e2esim reads "
                             f"version {VERSION}")
    return manifest


def count_finished(folder: Path) -> int:
    """Number of cases in the complete records of the journal of an output folder (checked, not decoded)."""
    path = Path(folder) / JOURNAL
    read_manifest(path)
    return sum(count for count, _, _, _ in _frames(path / _RECORDS))


def _frames(path: Path):
    """Yield the complete frames of a journal file as (cases, header, payload, end of the frame), read one at a
    time; a torn last frame is left out, anything else that does not check out is a JournalError."""
    if not path.exists():
        return
    try:
        with open(path, "rb") as fh:
            pos, number = 0, 0
            while True:
                head = fh.read(_FRAME.size)
                if len(head) < _FRAME.size:
                    return  # the end, or a torn frame head
                magic, count, n_header, n_payload, crc = _FRAME.unpack(head)
                if magic != _MAGIC:
                    raise _corrupt(path.parent, f"record {number} does not start with the journal's mark")
                header, payload = fh.read(n_header), fh.read(n_payload)
                if len(header) < n_header or len(payload) < n_payload:
                    return  # a torn last frame
                if zlib.crc32(payload, zlib.crc32(header)) != crc:
                    raise _corrupt(path.parent, f"record {number} fails its checksum")
                pos += _FRAME.size + n_header + n_payload
                yield count, header, payload, pos
                del header, payload  # not held while the next frame is read
                number += 1
    except OSError as exc:
        raise _corrupt(path.parent, f"it cannot be read: {exc.strerror or exc}") from exc


def _corrupt(path: Path, problem: str) -> JournalError:
    return JournalError(f"{path}: the resume journal is corrupt or foreign: {problem}; it is not used. Run with "
                        "--force to discard it and start again")
