"""What a run's results depend on besides the scenario: the versions of the scientific packages and the
source commit of e2esim, when it runs from a git checkout. Never fails: a package that is not installed
is "not installed", and without git (or outside a checkout) there is no commit. Both are asked once per process:
its packages and its code are those it imported, and the inverse solve runs the engine a dozen times (each ask of
git took a tenth of a second and more on a loaded machine: ``git describe --dirty`` refreshes the index)."""

from __future__ import annotations

import functools
import subprocess
from importlib import metadata
from pathlib import Path

SCIENTIFIC_PACKAGES = ("numpy", "scipy", "h5py", "matplotlib", "PyIRI", "ppigrf", "pandas", "xarray", "PyYAML",
                       "jinja2", "markdown-it-py")
"""Distributions whose version can change a number, a file or the report."""


def dependency_versions() -> dict:
    """{distribution: version} of ``SCIENTIFIC_PACKAGES`` (a new dict each call, read once per process)."""
    return dict(_versions())


@functools.cache
def _versions() -> tuple:
    out = {}
    for name in SCIENTIFIC_PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return tuple(out.items())


@functools.cache
def source_commit() -> str | None:
    """``git describe --always --dirty --tags`` of the checkout e2esim is imported from, or None when e2esim
    is not imported from a git checkout's src/e2esim (an installed wheel) or git is missing; asked once per
    process."""
    package = Path(__file__).resolve().parents[1]
    try:
        top = subprocess.run(["git", "rev-parse", "--show-toplevel"], cwd=package, capture_output=True, text=True,
                             timeout=5)
        if top.returncode != 0 or Path(top.stdout.strip()).resolve() / "src" / "e2esim" != package:
            return None
        out = subprocess.run(["git", "describe", "--always", "--dirty", "--tags"], cwd=package, capture_output=True,
                             text=True, timeout=5)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None if out.returncode == 0 else None
