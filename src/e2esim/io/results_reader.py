"""Read a results.h5 (``e2esim.io.results_h5``) back into ``e2esim.results.Results``: plain arrays and text,
nothing unpickled. Files of the first format (no units attributes) read too; their units come from the
names (``e2esim.io.scalar_units``).

A results.h5 may come from anyone, so it is read through ``e2esim.io.safe_h5.H5Reader`` (nothing outside
the file, nothing beyond what it stores) against the layout of docs/output-format.md: the number of cases
is that of the labels, within the case limit, and every dataset over cases is checked to have it (and the
number of requirements) before it is read; text codes must point into their tables, statuses be of the
three known ones, the stored scenario be YAML within the scenario limits. Anything else is a
``ResultsFileError`` (exit status 2) naming the file, the dataset and what is expected.
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from e2esim.errors import ResultsFileError, UserError
from e2esim.io.h5_datasets import TABLE_ATTR
from e2esim.io.safe_h5 import H5Reader
from e2esim.io.scalar_units import scalar_unit
from e2esim.limits import MAX_CASES, MAX_MAP_CASES, MAX_STORED_SCENARIO_BYTES, MAX_STORED_SCENARIO_VALUES
from e2esim.maps.grid import LAT_KEYS, LON_KEYS, MONTH_KEY, PASS_KEY, SOLAR_KEY, map_axes, map_section, map_settings
from e2esim.maps.netcdf import grid_positions
from e2esim.requirements.verdict import STATUSES
from e2esim.runner.joined_labels import JoinedLabels
from e2esim.runner.yaml_loader import load_plain_yaml

MAX_RESULT_CASES = max(MAX_CASES, MAX_MAP_CASES)
_ROOT_ATTRS = ("scenario_name", "n_cases", "format_version")


def results_path(path) -> Path:
    """``path`` itself, or the results.h5 inside a run folder."""
    path = Path(path)
    if path.is_dir():
        path = path / "results.h5"
    if not path.exists():
        raise ResultsFileError(f"{path}: no such results file (give a run folder or its results.h5)")
    return path


def read_results(path, results_type):
    """The results of a run folder or its results.h5 as a ``results_type`` (``e2esim.results.Results``, which the
    caller hands in: io sits below the results facade)."""
    path = results_path(path)
    with H5Reader(path) as h5, h5.guard():
        return _read(h5, path, results_type)


def _read(h5: H5Reader, path: Path, results_type):
    if h5.get("cases", h5py.Group, required=False) is None or h5.get("provenance", h5py.Group, required=False) is None:
        raise ResultsFileError(f"{path}: not an e2esim results file (no /cases or /provenance)")
    provenance = {k: _attr(v) for k, v in h5.attributes(h5.file).items() if k not in _ROOT_ATTRS}
    text = h5.read_text(h5.get("provenance/resolved_scenario"), ())[()]
    resolved = load_plain_yaml(text, f"{path}: /provenance/resolved_scenario", MAX_STORED_SCENARIO_BYTES,
                               MAX_STORED_SCENARIO_VALUES)
    if not isinstance(resolved, dict):
        h5.fail("/provenance/resolved_scenario", "is not a scenario (a YAML mapping)")
    labels = _labels(h5, h5.get("cases/label", (h5py.Group, h5py.Dataset)))
    n, declared = len(labels), _declared_cases(h5)
    if declared not in (None, n):
        h5.fail("/ (attribute n_cases)", f"says {declared} cases, the labels are of {n}")
    inputs_group = h5.get("cases/inputs", h5py.Group)
    stored = dict(h5.members(inputs_group))
    sweep_keys, sweep_problem = _sweep_keys(h5, stored, resolved)
    inputs = {k: _input_values(h5, inputs_group, stored[k], n) for k in sweep_keys}
    _check_map(h5, resolved, inputs, sweep_problem)
    req = h5.get("requirements", h5py.Group)
    names = _texts(h5, req, "names", (None,))
    r = len(names)
    req_units = _texts(h5, req, "unit", (r,), required=False) or []
    scalars, units = {}, {}
    for name, ds in h5.members(h5.get("cases/results", h5py.Group)):
        scalars[name] = h5.read(ds, "fiub", (n,)).astype(float)
        units[name] = h5.text_attribute(ds, "units") or scalar_unit(name, tuple(req_units))
    out = results_type(
        scenario_name=h5.text_attribute(h5.file, "scenario_name") or path.parent.name, sweep_keys=sweep_keys,
        labels=labels, inputs=inputs, scalars=scalars, units=units, requirements=names, requirement_units=req_units,
        requirement_sources=_texts(h5, req, "sources", (r,), required=False) or ["all"] * r,
        provenance=provenance, resolved_scenario=resolved,
    )
    if r:
        out.passed = h5.read(h5.get(f"{req.name}/passed"), "biu", (n, r)).astype(bool)
        out.value, out.limit, out.margin = (h5.read(h5.get(f"{req.name}/{k}"), "fiub", (n, r)).astype(float)
                                            for k in ("value", "limit", "margin"))
        out.dominant = coded_text(h5, req, "dominant", (n, r))
        out.details = _details(h5, req, n, r)
        _read_verdict_states(h5, out, req, n, r)
    else:
        out.passed = np.zeros((n, 0), bool)
        out.value = out.limit = out.margin = np.zeros((n, 0))
        out.dominant = out.status = out.reason = out.coverage = out.coverage_text = np.zeros((n, 0), dtype=object)
    return out


def _declared_cases(h5: H5Reader):
    value = h5.attribute(h5.file, "n_cases")
    return int(value) if isinstance(value, (int, np.integer)) else None


def _details(h5: H5Reader, req, n: int, r: int) -> list:
    """Per requirement j: {detail: (n,) floats} of /requirements/details/j."""
    group = h5.get(f"{req.name}/details", h5py.Group, required=False)
    if group is None:
        return [{} for _ in range(r)]
    out = []
    for j in range(r):
        sub = h5.get(f"{group.name}/{j}", h5py.Group, required=False)
        out.append({} if sub is None else {k: h5.read(ds, "fiub", (n,)).astype(float) for k, ds in h5.members(sub)})
    return out


def _read_verdict_states(h5: H5Reader, out, req, n: int, r: int) -> None:
    """Status, reason and coverage of every verdict (format 4); a file of an earlier format has no coverage
    (empty) and its statuses come from ``passed`` and the ``applies`` detail of ``agb_rmse_absolute``: a case
    outside the requirement's range, stored there as passing with a margin, reads as not applicable, with no
    margin."""
    if h5.get(f"{req.name}/status", required=False) is not None:
        for name, dataset in (("status", "status"), ("reason", "reason"), ("coverage", "coverage_sources"),
                              ("coverage_text", "coverage_text")):
            setattr(out, name, coded_text(h5, req, dataset, (n, r)))
        unknown = set(out.status.flat) - set(STATUSES)
        if unknown:
            h5.fail(f"{req.name}/status", f"holds the status {sorted(unknown)[0][:40]!r}",
                    f"expected one of {', '.join(STATUSES)}")
        return
    applies = np.ones((n, r), bool)
    for j, details in enumerate(out.details):
        if "applies" in details:
            applies[:, j] = details["applies"] != 0.0
    out.passed = out.passed & applies
    out.margin = np.where(applies, out.margin, np.nan)
    out.status = np.where(~applies, "not_applicable", np.where(out.passed, "pass", "fail")).astype(object)
    out.reason = np.where(applies, "", "outside the requirement's AGB range").astype(object)
    out.coverage = out.coverage_text = np.full((n, r), "", dtype=object)


def _sweep_keys(h5: H5Reader, stored: dict, resolved: dict) -> tuple:
    """(The sweep keys in the scenario's order (HDF5 lists a group's members alphabetically), the problem of the
    stored sweep when it does not validate)."""
    from e2esim.errors import Location
    from e2esim.runner.sweep import sweep_table

    try:
        keys, problem = sweep_table(resolved.get("sweep"), Location("<results.h5>", ("sweep",))).keys, None
    except UserError as exc:
        keys, problem = (), str(exc)
    tables = {h5.text_attribute(ds, TABLE_ATTR) for ds in stored.values()}
    return tuple([k for k in keys if k in stored] or sorted(k for k in stored if k not in tables)), problem


def _check_map(h5: H5Reader, resolved: dict, inputs: dict, problem: str | None) -> None:
    """A map sweep's results (drawn on its grid by ``Results.to_xarray``): its stored ``sweep.map`` valid, and
    every case a cell of that grid with its month, pass and solar level."""
    section = map_section(resolved.get("sweep"))
    if section is None:
        return
    where = "/provenance/resolved_scenario"
    if problem is not None:
        h5.fail(where, f"its map sweep is not valid ({problem})")
    missing = [k for k in (LAT_KEYS[0], LON_KEYS[0], MONTH_KEY, PASS_KEY, SOLAR_KEY) if k not in inputs]
    if missing:
        h5.fail("/cases/inputs", f"lacks {missing[0]}, a key of the map sweep")
    numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool) for k in (LAT_KEYS[0], LON_KEYS[0], MONTH_KEY)
                  for v in inputs[k])
    if not numbers or not all(isinstance(v, str) for k in (PASS_KEY, SOLAR_KEY) for v in inputs[k]):
        h5.fail("/cases/inputs", "the map's cells, months, passes or solar levels are not of their types")
    m = map_settings(section)
    lat, lon = map_axes(m)
    try:
        for axis, key in ((lat, LAT_KEYS[0]), (lon, LON_KEYS[0])):
            grid_positions(axis, inputs[key], m["step_deg"])
    except ValueError:
        h5.fail(f"/cases/inputs/{key}", "holds a cell that is not on the map's grid")


def _labels(h5: H5Reader, node):
    """The case labels: joined from their parts when read (format 3, ``JoinedLabels``), or a list of text."""
    if isinstance(node, h5py.Dataset):
        if len(h5.shape(node)) != 1 or node.shape[0] > MAX_RESULT_CASES:
            h5.fail(node.name, f"has shape {node.shape}", f"expected one label per case, at most "
                    f"{MAX_RESULT_CASES:,} cases")
        return h5.read_text(node, (None,)).tolist()
    parts = h5.read_text(h5.get(f"{node.name}/parts"), (None,))
    codes_ds = h5.get(f"{node.name}/codes")
    if len(h5.shape(codes_ds)) != 2 or codes_ds.shape[0] > MAX_RESULT_CASES:
        h5.fail(codes_ds.name, f"has shape {codes_ds.shape}", f"expected (cases, groups), at most "
                f"{MAX_RESULT_CASES:,} cases")
    n = codes_ds.shape[0]
    codes = _codes(h5, codes_ds, codes_ds.shape, len(parts))
    numbered = h5.read(h5.get(f"{node.name}/numbered"), "biu", (n,)).astype(bool)
    return JoinedLabels(parts, codes, numbered)


def _input_values(h5: H5Reader, group, ds, n: int) -> list:
    if ds.dtype.kind == "f":
        return h5.read(ds, "f", (n,)).tolist()
    values = coded_text(h5, group, ds.name.rpartition("/")[2], (n,))
    out = np.empty(n, dtype=object)
    for i, text in enumerate(values):
        try:  # values that are not text were written as JSON (e2esim.io.results_h5)
            out[i] = json.loads(text)
        except (ValueError, RecursionError):
            out[i] = text
    return out.tolist()


def coded_text(h5: H5Reader, group, name: str, shape: tuple) -> np.ndarray:
    """Text of ``group/name``, written as codes into a table of distinct texts (format 3) or as strings."""
    ds = h5.get(f"{group.name}/{name}")
    table = h5.text_attribute(ds, TABLE_ATTR)
    if table is None:
        return h5.read_text(ds, shape)
    if not table or "/" in table or table in (".", ".."):
        h5.fail(f"{ds.name} (attribute {TABLE_ATTR})", f"{table[:40]!r} is not the name of a dataset beside it")
    texts = h5.read_text(h5.get(f"{group.name}/{table}"), (None,))
    return texts[_codes(h5, ds, shape, len(texts))]


def _codes(h5: H5Reader, ds, shape: tuple, count: int) -> np.ndarray:
    codes = h5.read(ds, "iu", shape)
    if codes.size and (codes.min() < 0 or codes.max() >= count):
        h5.fail(ds.name, f"holds the code {int(codes.max()) if codes.max() >= count else int(codes.min())}",
                f"expected codes 0 to {count - 1} (into its {count} texts)")
    return codes.astype(np.int64)


def _texts(h5: H5Reader, group, name: str, shape: tuple, required: bool = True):
    ds = h5.get(f"{group.name}/{name}", required=required)
    return None if ds is None else h5.read_text(ds, shape).tolist()


def _attr(value):
    if isinstance(value, str) and value[:1] in "[{":
        try:
            return json.loads(value)
        except (ValueError, RecursionError):
            return value
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


__all__ = ["coded_text", "read_results", "results_path"]

