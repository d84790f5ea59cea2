"""Write the outputs of a run into its folder: results.h5, summary.json, report.md, report.html, PNG plots."""

from __future__ import annotations

from pathlib import Path

from e2esim.errors import OutputExistsError
from e2esim.io.results_h5 import write_results
from e2esim.io.summary import write_summary
from e2esim.report.render import write_report
from e2esim.report.plots import make_plots

OUTPUT_FILES = ("results.h5", "summary.json", "report.md", "report.html")


def output_folder(resolved, override: str | None) -> Path:
    """The run's folder: ``-o`` from the command line, else ``output.folder``, else runs/<name>."""
    if override:
        return Path(override)
    if resolved.output["folder"]:
        return Path(resolved.output["folder"])
    return Path("runs") / Path(resolved.source).stem


def prepare_folder(folder: Path, force: bool, resume: bool = False) -> None:
    """Refuse to write into an existing non-empty folder unless ``force`` (or ``resume``, which continues
    an interrupted run there); create it otherwise. ``force`` discards an interrupted run."""
    from e2esim.runner.journal import JOURNAL

    if folder.exists() and not folder.is_dir():
        raise OutputExistsError(f"{folder}: exists and is not a folder")
    if force and (folder / JOURNAL).exists():
        import shutil

        shutil.rmtree(folder / JOURNAL)
    if (folder / JOURNAL).exists() and not (force or resume):
        from e2esim.runner.journal import _read_records

        done = len(_read_records(folder / JOURNAL / "cases.journal")[0])
        raise OutputExistsError(f"{folder}: holds an interrupted run ({done} cases finished); use --resume to "
                                "continue it or --force to start again")
    if folder.exists() and any(folder.iterdir()) and not (force or resume):
        raise OutputExistsError(
            f"{folder}: output folder exists and is not empty; use --force to overwrite it, or -o to choose another"
        )
    folder.mkdir(parents=True, exist_ok=True)


def write_outputs(result, folder: Path) -> dict:
    """Write every output file; return their paths and the warnings of plots that could not be drawn."""
    warnings: list = []
    plots = make_plots(result, folder, warnings)
    write_results(result, folder / "results.h5")
    write_summary(result, folder / "summary.json")
    write_report(result, folder, plots, warnings)
    return {"folder": folder, "plots": [folder / name for name, _ in plots], "warnings": warnings}
