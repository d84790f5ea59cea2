"""Incremental results of a run, so an interrupted sweep resumes without recomputing finished cases.

While a run is going, every finished case is pickled to ``<output>/.e2esim-partial/case<NNNNNN>.pkl``
(written to a temporary name and renamed, so a killed process leaves no partial file), beside a
``manifest.json`` holding the run's fingerprint: the resolved scenario, every case's inputs and seed, and
the e2esim version. ``e2esim run --resume`` loads the cases whose files exist when the fingerprint matches,
runs the rest, and writes the final outputs; the journal is removed once they are written. The journal is
e2esim's own working data in the user's own output folder; it is not meant to be shared.
"""

from __future__ import annotations

import hashlib
import json
import pickle
import shutil
from pathlib import Path

import e2esim
from e2esim.errors import OutputExistsError
from e2esim.io.atomic import atomic_path, write_text_atomic

JOURNAL = ".e2esim-partial"


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

    def exists(self) -> bool:
        return (self.path / "manifest.json").exists()

    def start(self, resume: bool) -> dict:
        """Open the journal; with ``resume``, return the finished cases it holds ({index: CaseResult})."""
        finished = {}
        if self.exists():
            manifest = json.loads((self.path / "manifest.json").read_text())
            if not resume:
                raise OutputExistsError(
                    f"{self.path.parent}: holds an interrupted run ({len(self._files())} cases finished); "
                    "use --resume to continue it or --force to start again"
                )
            if manifest.get("fingerprint") != self.fingerprint:
                raise OutputExistsError(
                    f"{self.path.parent}: the interrupted run there is of a different scenario, seed or e2esim "
                    "version; use --force to start again"
                )
            for file in self._files():
                with open(file, "rb") as fh:
                    result = pickle.load(fh)
                finished[result.index] = result
        self.path.mkdir(parents=True, exist_ok=True)
        for stray in self.path.glob(".*.tmp"):  # left by a process killed while writing
            stray.unlink()
        write_text_atomic(self.path / "manifest.json", json.dumps({"fingerprint": self.fingerprint}) + "\n")
        return finished

    def record(self, result) -> None:
        with atomic_path(self.path / f"case{result.index:06d}.pkl", durable=False) as tmp:
            with open(tmp, "wb") as fh:
                pickle.dump(result, fh, protocol=pickle.HIGHEST_PROTOCOL)

    def remove(self) -> None:
        shutil.rmtree(self.path, ignore_errors=True)

    def _files(self) -> list:
        return sorted(self.path.glob("case*.pkl"))
