"""One exception hierarchy for everything e2esim reports to a user.

``UserError`` and its subclasses are problems the user can fix (a bad scenario, a bad argument, a
physically impossible input); the command line prints their message and exits with status 2, without
a traceback. Anything else is a bug in e2esim and keeps its traceback.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


class E2ESimError(Exception):
    """Base class of all e2esim exceptions."""


class UserError(E2ESimError):
    """A problem the user can act on: shown as a message, exit status 2."""

    exit_status = 2


@dataclass(frozen=True)
class Location:
    """Where a configuration value comes from: a file (or a Python caller) and a key path.

    ``key_path`` is a tuple of mapping keys and list indices, e.g. ``("instrument", "crosstalk",
    "level_db")`` or ``("requirements", 0, "bound_percent")``. ``lines`` maps key paths to the line
    in the file where they start, when the file was read by ``e2esim.runner.yaml_loader``.
    """

    source: str = "<python>"
    key_path: tuple = ()
    lines: dict = field(default_factory=dict, compare=False, repr=False, hash=False)

    def child(self, key: Any) -> Location:
        return Location(self.source, self.key_path + (key,), self.lines)

    def parent(self) -> Location:
        """The enclosing section (e.g. ``calibration`` of ``calibration[1]``)."""
        return Location(self.source, self.key_path[:-1], self.lines)

    @property
    def dotted(self) -> str:
        return format_key_path(self.key_path)

    def line(self) -> int | None:
        path = self.key_path
        while path:
            if path in self.lines:
                return self.lines[path]
            path = path[:-1]
        return None

    def describe(self) -> str:
        line = self.line()
        if isinstance(line, int):
            where = f"{self.source}:{line}"
        elif line is not None:  # a value that came from the command line or a sweep case
            where = f"{self.source} ({line})"
        else:
            where = self.source
        return f"{where}: {self.dotted}" if self.key_path else where


def format_key_path(key_path: tuple) -> str:
    """``("requirements", 0, "bound_percent")`` -> ``requirements[0].bound_percent``."""
    text = ""
    for key in key_path:
        if isinstance(key, int):
            text += f"[{key}]"
        else:
            text += ("." if text else "") + str(key)
    return text


class ConfigError(UserError):
    """A scenario or module configuration value is wrong.

    The message names the file, the key path, the bad value and what is allowed, e.g.
    ``scenario.yaml:12: instrument.crosstalk.level_db: 5.0 is out of range; expected a value <= 0 dB``.
    """

    def __init__(self, location: Location, problem: str, allowed: str | None = None):
        self.location = location
        self.problem = problem
        self.allowed = allowed
        message = f"{location.describe()}: {problem}"
        if allowed:
            message += f"; {allowed}"
        super().__init__(message)


class ScenarioFileError(UserError):
    """The scenario file is missing, unreadable, empty or not valid YAML."""


class OutputExistsError(UserError):
    """The output folder exists and ``--force`` was not given."""


class PhysicsInputError(UserError, ValueError):
    """A physically impossible input given through the Python API (e.g. a covariance that is not
    Hermitian positive semi-definite). Inside a scenario it is re-raised as a ``ConfigError`` that
    names the key path: the module's section, and below it ``key`` (a dotted parameter name such as
    ``acquisitions.start``) when the raiser knows which parameter is at fault."""

    def __init__(self, message: str, key: str | None = None):
        super().__init__(message)
        self.key = key

    def location(self, section: Location) -> Location:
        """Where the bad value is: ``section`` and below it ``key``, when known."""
        where = section
        for part in (self.key or "").split("."):
            if part:
                where = where.child(int(part) if part.isdigit() else part)
        return where


class ModuleLookupError(UserError, LookupError):
    """A module type name that no registered module has, or a ``package.module:Class`` that may not or
    cannot be imported."""


class LimitError(UserError):
    """An input beyond one of the validation limits (``e2esim.limits``): the message names the
    number, the limit and, where the work is legitimate, how to run it."""


class OutputFolderError(UserError):
    """The output folder cannot be used: below a file, not writable, full, or locked by a live run."""


class JournalError(UserError):
    """The resume journal in an output folder is corrupt, foreign or of another version."""


class MissingExtraError(UserError):
    """An optional dependency that is not installed: the message names the optional extra that brings it and the
    pip command (``e2esim.extras``)."""


class E2ESimWarning(UserWarning):
    """Something e2esim could not use and went on without (a cache, a plug-in): the command line prints it as one
    line, ``e2esim: warning: ...``."""


class ResultsFileError(UserError):
    """A results.h5 (given to ``e2esim compare`` or ``open_results``) that is not one e2esim can read safely:
    not HDF5, not of e2esim, damaged, or holding what e2esim never writes (links or storage outside the file,
    data beyond the limits)."""


def one_line(text: str) -> str:
    """``text`` on one line: line breaks (and runs of blanks around them) become one space, so that every
    message e2esim prints is a single line."""
    return " ".join(part.strip() for part in str(text).splitlines() if part.strip())
