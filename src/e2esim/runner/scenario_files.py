"""The input files a scenario names (an orbit file, an AGB map, a site list, ...): key, path as given, size, SHA-256.

A parameter names an input file when it is declared ``Param(..., input_file=True)`` (``e2esim.params``), so a
plug-in's file parameter is found as the shipped ones are. Every module of the run (every distinct value of a swept
file too) and the map sweep's section are walked against their declarations. The list goes into the provenance
(summary.json and results.h5, key ``input_files``) and into the resume journal's identity
(``e2esim.runner.journal``): a file changed between an interrupted run and ``--resume`` is refused, naming it.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from e2esim.errors import UserError
from e2esim.input_files import open_regular, scenario_relative
from e2esim.maps.grid import MAP_PARAMS, map_section
from e2esim.params import Param, ParamGroup

_CHUNK = 1 << 22


def declared_files(params, values, key_path: tuple) -> list:
    """(dotted key, value) of every ``input_file`` parameter of ``params`` set in ``values`` (nested groups too).
    Reads ``values`` with ``dict.get``, so a module's record of the keys it read is left as it was."""
    out = []
    if not isinstance(values, dict):
        return out
    for p in params:
        if isinstance(p, ParamGroup):
            out += declared_files(p.params, dict.get(values, p.name), key_path + (p.name,))
        elif isinstance(p, Param) and p.input_file:
            value = dict.get(values, p.name)
            if isinstance(value, str) and value:
                out.append((".".join(str(k) for k in key_path + (p.name,)), value))
    return out


def _declares_file(params) -> bool:
    """Whether ``params`` (nested groups too) declare an ``input_file`` parameter."""
    return any(_declares_file(p.params) if isinstance(p, ParamGroup) else isinstance(p, Param) and p.input_file
               for p in params)


def file_digest(path: Path, key: str) -> tuple[int, str]:
    """(size in bytes, SHA-256 hex) of the regular file ``path``, read in pieces."""
    fd = open_regular(path, f"input file of {key}")
    try:
        digest, size = hashlib.sha256(), 0
        while piece := os.read(fd, _CHUNK):
            digest.update(piece)
            size += len(piece)
    except OSError as exc:
        raise UserError(f"{path}: cannot read the input file of {key}: {exc.strerror or exc}") from exc
    finally:
        os.close(fd)
    return size, digest.hexdigest()


def scenario_input_files(resolved) -> list:
    """``[{"key", "path", "size_bytes", "sha256"}, ...]`` of every input file ``resolved`` (a resolved scenario)
    names, sorted by key and path; ``path`` as the scenario gives it."""
    found = set()
    names_files: dict = {}  # module class -> whether it declares an input file (a sweep has 10,000 instruments)
    for slot in resolved.plan.slots:
        for module in slot.objects:
            params, config = getattr(type(module), "params", None), getattr(module, "config", None)
            if type(module) not in names_files:
                names_files[type(module)] = bool(params) and _declares_file(params)
            if names_files[type(module)] and isinstance(config, dict):
                found.update(declared_files(params, config, tuple(module.location.key_path)))
    section = map_section(resolved.raw.get("sweep") if isinstance(resolved.raw, dict) else None)
    if section is not None:
        found.update(declared_files(MAP_PARAMS, section, ("sweep", "map")))
    out = []
    for key, value in sorted(found):
        size, sha = file_digest(scenario_relative(value, resolved.source), key)
        out.append({"key": key, "path": value, "size_bytes": size, "sha256": sha})
    return out


def changed_files(recorded, current) -> list:
    """The entries of ``current`` whose file differs from the one ``recorded`` (by key and path), or that are new,
    and the recorded ones no longer named."""
    before = {(f.get("key"), f.get("path")): f.get("sha256") for f in recorded if isinstance(f, dict)}
    now = {(f["key"], f["path"]): f["sha256"] for f in current}
    return sorted(k for k in before.keys() | now.keys() if before.get(k) != now.get(k))


__all__ = ["changed_files", "declared_files", "file_digest", "scenario_input_files"]
