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
import stat
import tempfile
import threading
from pathlib import Path

from e2esim.atomic import write_text_atomic
from e2esim.errors import OutputExistsError, OutputFolderError
from e2esim.io.results_h5 import write_results
from e2esim.io.summary import write_summary
from e2esim.maps.grid import is_map_sweep
from e2esim.maps.netcdf import map_dataset_of, write_map_netcdf
from e2esim.runner.journal import JOURNAL, count_finished
from e2esim.runner.lock import LOCK_NAME, FolderLock
from e2esim.runner.progress import StepProgress

OUTPUT_FILES = ("results.h5", "summary.json", "report.md", "report.html")
OUTPUT_LIST = ".e2esim-outputs.json"
"""The files a run wrote, so that ``--force`` removes exactly those (and no file of the user's)."""
ASIDE = ".e2esim-previous-"
"""Prefix of the folder where ``--force`` sets the previous run's outputs aside until the new ones are complete."""
_ASIDE_PREFIXES = (ASIDE, ".e2esim-trash-")  # the second: the trash of an e2esim that deleted at once
_TEMP = re.compile(r"^\..+\.[A-Za-z0-9_]{8}\.tmp$")  # e2esim.atomic: ".<name>.<random>.tmp"
_LIST_LIMIT = 1_000_000  # bytes: a list of a few hundred file names is a few kB


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
    is refused too; ``resume`` continues an interrupted run there; ``force`` first sets the previous run's
    outputs and journal aside (``set_aside``), to be removed when the new outputs are complete. Temporary
    files of the atomic writer that a killed run left are removed in every case.
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
            set_aside(folder)
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


def set_aside(folder: Path) -> Path | None:
    """Move the previous run's outputs, each with one rename, into a new folder ``ASIDE``* inside ``folder``, so that
    no stale output stays beside the new ones and none is lost before the new ones are complete (``write_outputs``
    removes the folder then; a run that fails or is interrupted leaves it, and says so). Moved: the files the run
    listed in its ``OUTPUT_LIST``, the standard outputs and the journal; for an e2esim that kept no list, also
    every PNG. Other files are the user's and stay. Returns the folder, or None when there was nothing to move."""
    names = set(OUTPUT_FILES) | {JOURNAL, OUTPUT_LIST}
    listed = _listed_outputs(folder)
    if listed is not None:
        names |= listed
    elif any((folder / n).exists() for n in OUTPUT_FILES):
        names |= {p.name for p in folder.glob("*.png")}
    present = [folder / n for n in sorted(names) if os.path.lexists(folder / n)]
    if not present:
        return None
    aside = Path(tempfile.mkdtemp(prefix=ASIDE, dir=folder))
    for path in present:
        os.replace(path, aside / path.name)  # a link is moved as a link, never followed
    return aside


def aside_folders(folder: Path) -> list:
    """The folders of earlier outputs that ``--force`` set aside (real folders only, never a link)."""
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return []
    return sorted(Path(e.path) for e in entries
                  if e.name.startswith(_ASIDE_PREFIXES) and e.is_dir(follow_symlinks=False))


def aside_note(folder: Path) -> str:
    """For a message when a run fails: where the earlier outputs are kept, or '' if none were set aside."""
    kept = aside_folders(folder)
    if not kept:
        return ""
    return (f"; the earlier outputs are kept in {kept[-1]}{f' (and {len(kept) - 1} more)' if len(kept) > 1 else ''} "
            "until a run here completes (delete them to free space)")


def _listed_outputs(folder: Path) -> set | None:
    """The names in ``OUTPUT_LIST``: read as a regular file of at most ``_LIST_LIMIT`` bytes, never through a link
    or from a FIFO (it is the user's folder: anything may have been put there)."""
    try:
        fd = os.open(folder / OUTPUT_LIST, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return None
    try:
        with os.fdopen(fd, "rb") as fh:
            if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
                return None
            names = json.loads(fh.read(_LIST_LIMIT + 1)[:_LIST_LIMIT].decode("utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(names, list):
        return None
    return {n for n in names if isinstance(n, str) and n == Path(n).name and n not in ("", ".", "..")}


def _remove_leftovers(folder: Path) -> None:
    """Temporary files of the atomic writer that a killed run left behind (outputs set aside stay)."""
    for entry in os.scandir(folder):
        if _TEMP.match(entry.name) and not entry.is_dir(follow_symlinks=False):
            with contextlib.suppress(FileNotFoundError):
                os.unlink(entry.path)


def _remove_aside(folder: Path) -> None:
    """The earlier outputs set aside: removed once the new outputs are complete."""
    for aside in aside_folders(folder):
        shutil.rmtree(aside, ignore_errors=True)


def _report_functions() -> tuple:
    """(make_plots, requested_plots, write_report), imported here: matplotlib costs half a second at start-up."""
    from e2esim.report.plots import make_plots, requested_plots
    from e2esim.report.render import write_report

    return make_plots, requested_plots, write_report


@contextlib.contextmanager
def report_imported_meanwhile(enabled: bool = True, deferred: bool = False):
    """Import the report's modules (matplotlib above all: half a second) in a thread while the body (a run that
    computes in this process) goes on, so that its outputs need not wait for them. Nothing forks while the thread
    may hold an import lock: ``deferred`` (``--workers auto``) starts it only when the body calls the function it
    gets (once the run's worker processes are forked, or once it is known that none will be), not at once; so a
    run that goes to a pool imports the report while its workers compute, rather than while its first block does,
    alone on one core. The thread is joined when the body ends. An import that fails is left for
    ``write_outputs``, which raises it as usual."""
    thread = threading.Thread(target=_import_report, name="e2esim-report-import", daemon=True) if enabled else None

    def start() -> None:
        if thread is not None and thread.ident is None:
            thread.start()

    if not deferred:
        start()
    try:
        yield start
    finally:
        if thread is not None and thread.ident is not None:
            thread.join()


def _import_report() -> None:
    with contextlib.suppress(Exception):
        _report_functions()


def write_outputs(result, folder: Path, progress: bool = False) -> dict:
    """Write every output file; return their paths and the warnings of plots that could not be drawn. On failure
    (a full disk, say) the files of this attempt are removed again and an ``OutputFolderError`` says why; the
    journal stays for ``--resume``. ``progress``: a bar of the plots and files (``StepProgress``)."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        before = {p.name for p in folder.iterdir()}
    except OSError as exc:
        raise OutputFolderError(f"{folder}: cannot create the output folder: {_reason(folder, exc)}") from exc
    make_plots, requested_plots, write_report = _report_functions()
    files = ["results.h5"] + (["results.nc"] if is_map_sweep(result.scenario) else []) + ["summary.json", "report"]
    steps = StepProgress(len(requested_plots(result)) + len(files), "outputs", progress)
    try:
        warnings: list = []

        def files_without_plots() -> None:  # written here while the plot helper draws (make_plots)
            with steps.step("results.h5"):
                write_results(result, folder / "results.h5")
            if "results.nc" in files:
                with steps.step("results.nc"):
                    write_map_netcdf(map_dataset_of(result), folder / "results.nc")
            with steps.step("summary.json"):
                write_summary(result, folder / "summary.json")

        plots = make_plots(result, folder, warnings, steps, meanwhile=files_without_plots)
        with steps.step("report"):
            write_report(result, folder, plots, warnings)
        written = sorted({p.name for p in folder.iterdir()} - before - {JOURNAL, LOCK_NAME})
        write_text_atomic(folder / OUTPUT_LIST, json.dumps(written + [OUTPUT_LIST], indent=0) + "\n")
    except BaseException as exc:  # a full disk, the file-size limit, Ctrl-C: no output of this attempt stays
        with contextlib.suppress(OSError):
            for name in {p.name for p in folder.iterdir()} - before - {JOURNAL, LOCK_NAME}:
                with contextlib.suppress(OSError):
                    (folder / name).unlink()
        if not isinstance(exc, OSError):
            raise
        raise OutputFolderError(f"{folder}: cannot write the outputs: {exc.strerror or exc}; no partial file was "
                                "left; the finished cases are kept: free the space and run the same command with "
                                f"--resume{aside_note(folder)}") from exc
    finally:
        steps.close()
    _remove_aside(folder)  # the new outputs are complete: the earlier ones go
    return {"folder": folder, "plots": [folder / name for name, _ in plots], "warnings": warnings}


def _reason(folder: Path, exc: OSError) -> str:
    if isinstance(exc, (NotADirectoryError, FileExistsError)):
        for parent in [folder, *folder.parents]:
            if parent.exists() and not parent.is_dir():
                return f"{parent} is a file, not a folder"
    return exc.strerror or str(exc)
