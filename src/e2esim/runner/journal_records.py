"""Reading the files of a resume journal (``e2esim.runner.journal``) as hostile input.

An output folder can come from anyone, so its journal is read with limits: the manifest and the records
file must be regular files inside the journal folder (not symbolic links, FIFOs or devices, which would
point elsewhere, block for ever or never end), the manifest is small JSON, and the records are read one
frame at a time, each checked before its bytes are read: the number of cases it claims, and its length
against ``MAX_JOURNAL_RECORD_BYTES`` and against what the file holds. A frame that runs past the end of
the file is the torn last frame of a killed run, which ``--resume`` cuts off; anything else that does not
check out is a ``JournalError`` (exit status 2).
"""

from __future__ import annotations

import json
import os
import stat
import struct
import zlib
from pathlib import Path

from e2esim.errors import JournalError
from e2esim.input_files import open_regular, read_limited
from e2esim.limits import MAX_CASES, MAX_JOURNAL_RECORD_BYTES, MAX_MAP_CASES

RECORDS = "cases.journal"
MANIFEST = "manifest.json"
FORMAT = "e2esim-journal"
VERSION = 3  # 1 was the pickle journal of e2esim <= 0.x, 2 a journal of single cases; neither is read
MAGIC = b"E2J2"
FRAME = struct.Struct("<4sQQQI")  # magic, number of cases, header length, payload length, CRC-32 of both
MAX_MANIFEST_BYTES = 64 * 1024
"""A manifest is about 200 bytes of JSON."""


def read_manifest(path: Path) -> dict:
    """The manifest of the journal folder ``path``, checked: JSON of this format and version."""
    check_folder(path)
    fd = _open(path, MANIFEST)
    try:
        data = read_limited(fd, MAX_MANIFEST_BYTES + 1)
    except OSError as exc:
        raise corrupt(path, f"its manifest cannot be read: {exc.strerror or exc}") from exc
    finally:
        os.close(fd)
    if len(data) > MAX_MANIFEST_BYTES:
        raise corrupt(path, f"its manifest is larger than {MAX_MANIFEST_BYTES:,} bytes")
    try:
        manifest = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise corrupt(path, f"its manifest cannot be read ({type(exc).__name__})") from exc
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise corrupt(path, "it is not an e2esim journal, or one of an older e2esim that is not read")
    if manifest.get("version") != VERSION:
        raise corrupt(path, f"it has journal version {str(manifest.get('version'))[:20]}, this e2esim reads "
                            f"version {VERSION}")
    return manifest


def check_folder(path: Path) -> None:
    """Refuse a journal folder that is a symbolic link (its files would lie outside the output folder)."""
    try:
        mode = os.lstat(path).st_mode
    except OSError as exc:
        raise corrupt(path, f"it cannot be read: {exc.strerror or exc}") from exc
    if stat.S_ISLNK(mode):
        raise corrupt(path, "it is a symbolic link; e2esim does not follow links in an output folder")


def records(path: Path, truncate: bool = False):
    """Yield the complete frames of the journal folder ``path``'s records as (cases, header, payload); with
    ``truncate``, cut a torn last frame off the file once read (so that appends continue cleanly)."""
    if not (path / RECORDS).exists() and not (path / RECORDS).is_symlink():
        return
    fd = _open(path, RECORDS, write=truncate)
    try:
        size = os.fstat(fd).st_size
        good = 0
        for count, header, payload, end in _frames(fd, size, path):
            good = end
            yield count, header, payload
            del header, payload  # not held while the next record is read
        if truncate and good < size:
            os.ftruncate(fd, good)
    except OSError as exc:
        raise corrupt(path, f"it cannot be read: {exc.strerror or exc}") from exc
    finally:
        os.close(fd)


def _frames(fd: int, size: int, path: Path):
    pos, number = 0, 0
    max_cases = max(MAX_CASES, MAX_MAP_CASES)
    while pos + FRAME.size <= size:
        magic, count, n_header, n_payload, crc = FRAME.unpack(read_limited(fd, FRAME.size))
        if magic != MAGIC:
            raise corrupt(path, f"record {number} does not start with the journal's mark")
        if not 0 < count <= max_cases:
            raise corrupt(path, f"record {number} claims {count:,} cases")
        if n_header + n_payload > MAX_JOURNAL_RECORD_BYTES:
            raise corrupt(path, f"record {number} claims {n_header + n_payload:,} bytes, more than the limit of "
                                f"{MAX_JOURNAL_RECORD_BYTES:,}")
        end = pos + FRAME.size + n_header + n_payload
        if end > size:
            return  # a torn last frame
        try:
            header, payload = read_limited(fd, n_header), read_limited(fd, n_payload)
        except MemoryError as exc:
            raise corrupt(path, f"record {number} ({n_header + n_payload:,} bytes) does not fit in memory") from exc
        if len(header) != n_header or len(payload) != n_payload:
            return  # the file shrank while read: as torn
        if zlib.crc32(payload, zlib.crc32(header)) != crc:
            raise corrupt(path, f"record {number} fails its checksum")
        yield count, header, payload, end
        del header, payload  # one record in memory at a time (a resumed run reads its journal record by record)
        pos, number = end, number + 1


def _open(path: Path, name: str, write: bool = False) -> int:
    return open_regular(path / name, f"journal's {name.split('.')[0]} file", lambda problem: corrupt(path, problem),
                        nofollow=True, write=write)


def corrupt(path: Path, problem: str) -> JournalError:
    return JournalError(f"{path}: the resume journal is corrupt or foreign: {problem}; it is not used. Run with "
                        "--force to discard it and start again")


__all__ = ["FORMAT", "FRAME", "MAGIC", "MANIFEST", "RECORDS", "VERSION", "check_folder", "corrupt", "read_manifest",
           "records"]
