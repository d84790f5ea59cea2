"""Incremental results of a run, so an interrupted sweep resumes without recomputing finished cases.

While a run is going, every finished case is appended, as soon as it finishes, to
``<output>/.e2esim-partial/cases.journal`` (a length-prefixed pickle per case, flushed at once), beside a
``manifest.json`` holding the run's fingerprint: the resolved scenario, every case's inputs and seed, and the
e2esim version. A process killed while writing leaves at most a torn last record, which ``--resume``
recognises by its length and cuts off. ``e2esim run --resume`` loads the complete records when the
fingerprint matches, runs the other cases, and writes the final outputs; the journal is removed once they
are written. One appended file, not a file per case, keeps the bookkeeping cheap for sweeps of many
thousand cases. The journal is e2esim's own working data in the user's own output folder; it is not meant
to be shared.
"""

from __future__ import annotations

import hashlib
import json
import pickle
import shutil
import struct
from pathlib import Path

import e2esim
from e2esim.errors import OutputExistsError
from e2esim.io.atomic import write_text_atomic

JOURNAL = ".e2esim-partial"
_RECORDS = "cases.journal"
_LENGTH = struct.Struct("<Q")  # 8-byte little-endian length before each pickled record


def fingerprint(resolved) -> str:
    """Hash of everything that determines the numbers of a run."""
    payload = {
        "version": e2esim.__version__,
        "resolved": resolved.resolved,
        "cases": [[c.index, c.inputs, c.settings.seed] for c in resolved.cases],
    }
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


class Journal:
    """The partial results of one run in ``folder``."""

    def __init__(self, folder: Path, resolved):
        self.path = Path(folder) / JOURNAL
        self.fingerprint = fingerprint(resolved)
        self._file = None

    def exists(self) -> bool:
        return (self.path / "manifest.json").exists()

    def finished_count(self) -> int:
        return len(_read_records(self.path / _RECORDS)[0])

    def start(self, resume: bool) -> dict:
        """Open the journal; with ``resume``, return the finished cases it holds ({index: CaseResult})."""
        finished = {}
        records = self.path / _RECORDS
        if self.exists():
            manifest = json.loads((self.path / "manifest.json").read_text())
            if not resume:
                raise OutputExistsError(
                    f"{self.path.parent}: holds an interrupted run ({self.finished_count()} cases finished); "
                    "use --resume to continue it or --force to start again"
                )
            if manifest.get("fingerprint") != self.fingerprint:
                raise OutputExistsError(
                    f"{self.path.parent}: the interrupted run there is of a different scenario, seed or e2esim "
                    "version; use --force to start again"
                )
            results, good_length = _read_records(records)
            finished = {r.index: r for r in results}
            with open(records, "r+b") as fh:  # cut a torn last record off, so appends continue cleanly
                fh.truncate(good_length)
        else:
            self.path.mkdir(parents=True, exist_ok=True)
            records.write_bytes(b"")
            write_text_atomic(self.path / "manifest.json", json.dumps({"fingerprint": self.fingerprint}) + "\n")
        self._file = open(records, "ab")
        return finished

    def record(self, result, data: bytes | None = None) -> None:
        """Append one finished case (``data``: its pickle, when already made)."""
        data = pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL) if data is None else data
        self._file.write(_LENGTH.pack(len(data)) + data)
        self._file.flush()  # in the OS's hands at once: a killed process loses nothing it reported finished

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def remove(self) -> None:
        self.close()
        shutil.rmtree(self.path, ignore_errors=True)


def _read_records(path: Path) -> tuple[list, int]:
    """The complete records of a journal file and the length they span (a torn tail is left out)."""
    if not path.exists():
        return [], 0
    data = path.read_bytes()
    results, pos = [], 0
    while pos + _LENGTH.size <= len(data):
        (n,) = _LENGTH.unpack_from(data, pos)
        end = pos + _LENGTH.size + n
        if end > len(data):
            break
        try:
            results.append(pickle.loads(data[pos + _LENGTH.size:end]))
        except Exception:  # a torn record whose length happened to fit: stop here
            break
        pos = end
    return results, pos
