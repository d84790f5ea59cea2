"""The output folder of a run: prepare it (lock, refuse or clear), and write the outputs into it:
results.h5, summary.json, report.md, report.html, PNG plots.

Every problem with the folder (below a file, not writable, full, locked by a live run) is an
``OutputFolderError`` with one line saying so, never a traceback, and never a partial file.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import tempfile
from pathlib import Path

from e2esim.errors import OutputExistsError, OutputFolderError
from e2esim.io.atomic import write_text_atomic
from e2esim.io.map_netcdf import map_dataset_of, write_map_netcdf
from e2esim.io.results_h5 import write_results
from e2esim.io.summary import write_summary
from e2esim.runner.journal import JOURNAL, count_finished
from e2esim.runner.lock import LOCK_NAME, FolderLock
from e2esim.runner.map_sweep import is_map_sweep

OUTPUT_FILES = ("results.h5", "summary.json", "report.md", "report.html")
OUTPUT_LIST = ".e2esim-outputs.json"
"""The files a run wrote, so that ``--force`` removes exactly those (and no file of the user's)."""
_TRASH = ".e2esim-trash-"
_TEMP = re.compile(r"^\..+\.[A-Za-z0-9_]{8}\.tmp$")  # e2esim.io.atomic: ".<name>.<random>.tmp"


def output_folder(resolved, override: str | None) -> Path:
    """The run's folder: ``-o`` from the command line, else ``output.folder``, else runs/<name>."""
    if override:
        return Path(override)
    if resolved.output["folder"]:
        return Path(resolved.output["folder"])
    return Path("runs") / Path(resolved.source).stem


def prepare_folder(folder: Path, force: bool, resume: bool = False) -> FolderLock:
    """Create and lock the run's folder; return the lock, which the caller releases when the run ends.

    A folder locked by a live run is refused. Without ``force`` or ``resume`` an existing non-empty folder
    is refused too; ``resume`` continues an interrupted run there; ``force`` first clears the previous
    run's outputs and journal. Leftovers of a killed run (temporary files of the atomic writer, a half
    cleared ``--force``) are removed in every case.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise OutputExistsError(f"{folder}: exists and is not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputFolderError(f"{folder}: cannot create the output folder: {_reason(folder, exc)}") from exc
    lock = FolderLock(folder).acquire()
    try:
        _remove_leftovers(folder)
        if (folder / JOURNAL).exists() and not (force or resume):
            raise OutputExistsError(f"{folder}: holds an interrupted run ({count_finished(folder)} cases finished); "
                                    "use --resume to continue it or --force to start again")
        if force:
            clear_outputs(folder)
        elif not resume and any(p.name != LOCK_NAME for p in folder.iterdir()):
            raise OutputExistsError(
                f"{folder}: output folder exists and is not empty; use --force to overwrite it, or -o to choose another"
            )
    except OSError as exc:
        lock.release()
        raise OutputFolderError(f"{folder}: cannot prepare the output folder: {exc.strerror or exc}") from exc
    except BaseException:
        lock.release()
        raise
    return lock


def clear_outputs(folder: Path) -> None:
    """Remove the previous run's outputs: first moved, each with one rename, into a trash folder inside
    ``folder``, then deleted, so that no stale or half-deleted output stays beside the new ones. Removed:
    the files the run listed in its ``OUTPUT_LIST``, the standard outputs and the journal; for an e2esim
    that kept no list, also every PNG. Other files are the user's and stay."""
    names = set(OUTPUT_FILES) | {JOURNAL, OUTPUT_LIST}
    listed = _listed_outputs(folder)
    if listed is not None:
        names |= listed
    elif any((folder / n).exists() for n in OUTPUT_FILES):
        names |= {p.name for p in folder.glob("*.png")}
    present = [folder / n for n in sorted(names) if os.path.lexists(folder / n)]
    if not present:
        return
    trash = Path(tempfile.mkdtemp(prefix=_TRASH, dir=folder))
    for path in present:
        os.replace(path, trash / path.name)
    shutil.rmtree(trash, ignore_errors=True)


def _listed_outputs(folder: Path) -> set | None:
    try:
        names = json.loads((folder / OUTPUT_LIST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(names, list):
        return None
    return {n for n in names if isinstance(n, str) and n == Path(n).name and n not in ("", ".", "..")}


def _remove_leftovers(folder: Path) -> None:
    """Temporary files of the atomic writer and trash of a ``--force`` that a killed run left behind."""
    for path in folder.iterdir():
        if path.name.startswith(_TRASH) and path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
        elif _TEMP.match(path.name) and path.is_file():
            with contextlib.suppress(FileNotFoundError):
                path.unlink()


def write_outputs(result, folder: Path) -> dict:
    """Write every output file; return their paths and the warnings of plots that could not be drawn. On failure
    (a full disk, say) the files of this attempt are removed again and an ``OutputFolderError`` says why; the
    journal stays for ``--resume``."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        before = {p.name for p in folder.iterdir()}
    except OSError as exc:
        raise OutputFolderError(f"{folder}: cannot create the output folder: {_reason(folder, exc)}") from exc
    from e2esim.report.plots import make_plots  # imported here: matplotlib costs a second at start-up
    from e2esim.report.render import write_report

    try:
        warnings: list = []
        plots = make_plots(result, folder, warnings)
        write_results(result, folder / "results.h5")
        if is_map_sweep(result.scenario):
            write_map_netcdf(map_dataset_of(result), folder / "results.nc")
        write_summary(result, folder / "summary.json")
        write_report(result, folder, plots, warnings)
        written = sorted({p.name for p in folder.iterdir()} - before - {JOURNAL, LOCK_NAME})
        write_text_atomic(folder / OUTPUT_LIST, json.dumps(written + [OUTPUT_LIST], indent=0) + "\n")
    except OSError as exc:
        for name in {p.name for p in folder.iterdir()} - before - {JOURNAL, LOCK_NAME}:
            with contextlib.suppress(OSError):
                (folder / name).unlink()
        raise OutputFolderError(f"{folder}: cannot write the outputs: {exc.strerror or exc}; no partial file was "
                                "left; the finished cases are kept: free the space and run the same command with "
                                "--resume") from exc
    return {"folder": folder, "plots": [folder / name for name, _ in plots], "warnings": warnings}


def _reason(folder: Path, exc: OSError) -> str:
    if isinstance(exc, (NotADirectoryError, FileExistsError)):
        for parent in [folder, *folder.parents]:
            if parent.exists() and not parent.is_dir():
                return f"{parent} is a file, not a folder"
    return exc.strerror or str(exc)
