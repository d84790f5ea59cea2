"""The scenario's ``plugins:`` list: packages whose modules ``type: package.module:Class`` may import.

Installed distributions may be imported without it; the list (and ``--allow-import``) is for code the
user trusts that is not installed, on the normal import path (``PYTHONPATH``). The current working
directory and the scenario's folder are never searched (e2esim.registry, docs/security.md).
"""

from __future__ import annotations

import re

from e2esim.errors import ConfigError, Location
from e2esim.limits import shorten

MODULE_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")


def plugin_list(value, where: Location) -> tuple:
    """The top-level package names of a ``plugins:`` list (None: none)."""
    if value is None:
        return ()
    if isinstance(value, str) or not isinstance(value, list):
        raise ConfigError(where, f"{shorten(repr(value))} is not a list",
                          "expected a list of Python package names, e.g. [my_instruments]")
    names = []
    for i, item in enumerate(value):
        if not isinstance(item, str) or not MODULE_NAME.match(item):
            raise ConfigError(where.child(i), f"{shorten(repr(item))} is not a Python package name",
                              "expected a dotted name such as my_instruments or my_instruments.radar")
        names.append(item.split(".")[0])
    return tuple(names)
