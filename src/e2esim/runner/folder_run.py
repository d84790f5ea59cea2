"""The one run path of ``e2esim run`` and ``e2esim.run``: a scenario run into its output folder.

Both front doors call ``run_into_folder``, so that what a run does with its folder cannot drift between them:
the folder is locked for the whole run (a second run into it is refused with the same message), ``force``
sets the outputs of the run that was there aside until the new ones are complete, the resume journal records
every finished block (``resume`` continues from it), the outputs are written atomically, and a run that ends
early (Ctrl-C, SIGTERM or SIGHUP, a lost worker, a full disk) says how many cases it kept and how to go on; a
folder the run created and left empty (an error met while the cases ran) is taken back.
The front doors differ only in how they say it: the command line prints the message and exits with
``exit_status``; the API raises.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from e2esim.errors import OutputFolderError, UserError
from e2esim.io.array_cache import open_cache
from e2esim.runner.auto_workers import AUTO
from e2esim.runner.executors import WorkerLost, check_scheduler_address
from e2esim.runner.interrupts import RunInterrupted, stop_signals_as_interrupts
from e2esim.runner.journal import Journal
from e2esim.runner.lock import FolderLock
from e2esim.runner.outputs import aside_note, prepare_folder, report_imported_meanwhile, write_outputs
from e2esim.runner.run import ScenarioResult, run_scenario


def check_executor(workers: int | str, scheduler: str | None, auto: bool = False) -> None:
    """``workers`` a number of processes >= 1 (or "auto" where ``auto``: ``e2esim.runner.auto_workers``), and
    ``scheduler`` (if given) a dask scheduler address."""
    counted = not isinstance(workers, bool) and isinstance(workers, int) and workers >= 1
    if not counted and not (auto and workers == AUTO):
        raise UserError(f"--workers {workers}: expected a number of processes >= 1{', or auto' if auto else ''}")
    if scheduler:
        check_scheduler_address(scheduler)


def run_into_folder(resolved, folder, force: bool = False, resume: bool = False, *, progress: bool = True,
                    command: str | None = None, workers: int | str = AUTO, scheduler: str | None = None,
                    engine: str = "batched", answer=None) -> ScenarioResult:
    """Run ``resolved`` and write its outputs into ``folder`` (module docstring); return the run's results.

    ``folder`` None writes nothing: the run only (no lock, no journal). Raises ``RunInterrupted`` when stopped,
    ``WorkerLost`` or ``OutputFolderError`` (with the count of saved cases and the way to resume) when a worker or
    the disk fails, and the ``UserError`` of a folder that cannot be used. answer : ``answer(resolved)`` -> the
    answer to the scenario's own question (``e2esim.flowdown.answer.scenario_answer``) or None, computed after the
    run and kept as ``result.answer`` for the outputs.
    """
    check_executor(workers, scheduler, auto=True)
    options = {"progress": progress, "command": command, "workers": workers, "scheduler": scheduler,
               "engine": engine, "cache": open_cache}  # the array cache, handed to the stages through their services
    if folder is None:
        if resume:
            raise UserError("resume: continuing an interrupted run needs its output folder")
        result = run_scenario(resolved, **options)
        result.answer = None if answer is None else answer(resolved)
        return result
    folder = Path(folder)
    created = not folder.exists()
    with stop_signals_as_interrupts():  # SIGTERM, SIGHUP: ended as Ctrl-C ends a run, finished blocks kept
        lock = prepare_folder(folder, force, resume)
        try:
            journal = Journal(folder, resolved)
            # a run in this process: the report's modules are imported meanwhile (with auto, from when no worker
            # is forked any more: while the pool computes)
            with report_imported_meanwhile(workers in (1, AUTO) and not scheduler, deferred=workers == AUTO) as start:
                result = _run_journalled(resolved, folder, journal, resume, {**options, "after_forks": start})
            result.answer = None if answer is None else answer(resolved)
            try:
                write_outputs(result, folder, progress=progress)
            except KeyboardInterrupt as stop:
                raise RunInterrupted(stop, "no partial output file was left; " + _saved(journal, resolved, folder),
                                     " while writing the outputs") from stop
            journal.remove()
        finally:
            lock.release()
            if created:
                _remove_if_empty(folder)
    return result


def _remove_if_empty(folder: Path) -> None:
    """Take back the folder this run created where it ended with nothing in it (an error met while the cases ran):
    a failed run leaves no output, not an empty folder. A folder holding anything (a journal of saved cases, the
    outputs) stays."""
    with contextlib.suppress(OSError):  # the system refuses a folder that is not empty
        folder.rmdir()


def write_into_folder(result: ScenarioResult, folder: Path) -> dict:
    """Write the outputs of a run made before into ``folder`` (created if need be; other files stay), locked while
    they are written (``Results.write``); return ``write_outputs``'s answer."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputFolderError(f"{folder}: cannot create the output folder: {exc.strerror or exc}") from exc
    with FolderLock(folder):
        return write_outputs(result, folder)


def _run_journalled(resolved, folder: Path, journal: Journal, resume: bool, options: dict) -> ScenarioResult:
    """The run, each finished block recorded in ``journal`` (and those it holds taken back with ``resume``)."""
    finished = journal.start(resume=resume)
    try:
        return run_scenario(resolved, journal=journal, finished=finished, spill_folder=folder, **options)
    except KeyboardInterrupt as stop:
        journal.close()
        raise RunInterrupted(stop, _saved(journal, resolved, folder)) from stop
    except WorkerLost as exc:
        raise WorkerLost(f"{exc}; {_saved(journal, resolved, folder)}") from exc
    except OutputFolderError as exc:  # the journal or the spill file could not be written: a full disk
        raise OutputFolderError(f"{exc}; {_saved(journal, resolved, folder, 'free the space and run')}") from exc
    finally:
        journal.close()


def _saved(journal: Journal, resolved, folder: Path, then: str = "run") -> str:
    """What a run that ends early leaves, and how to go on."""
    return (f"{journal.finished_count()} of {len(resolved.cases)} cases are saved in {journal.path}; {then} the "
            f"same command with --resume to finish{aside_note(folder)}")


__all__ = ["check_executor", "run_into_folder", "write_into_folder"]
