"""Read a results.h5 (``e2esim.io.results_h5``) back into ``e2esim.results.Results``: plain arrays and text,
nothing unpickled. Files of the first format (no units attributes) read too; their units come from the
names (``e2esim.io.scalar_units``)."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import yaml

from e2esim.errors import UserError
from e2esim.io.h5_datasets import TABLE_ATTR, read_text
from e2esim.io.scalar_units import scalar_unit
from e2esim.results import Results
from e2esim.runner.joined_labels import JoinedLabels


def results_path(path) -> Path:
    """``path`` itself, or the results.h5 inside a run folder."""
    path = Path(path)
    if path.is_dir():
        path = path / "results.h5"
    if not path.is_file():
        raise UserError(f"{path}: no such results file (give a run folder or its results.h5)")
    return path


def read_results(path) -> Results:
    path = results_path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise UserError(f"{path}: not a results.h5 file ({exc})") from exc
    with f:
        if "cases" not in f or "provenance" not in f:
            raise UserError(f"{path}: not an e2esim results file (no /cases or /provenance)")
        provenance = {
            k: _attr(v) for k, v in f.attrs.items() if k not in ("scenario_name", "n_cases", "format_version")
        }
        resolved = yaml.safe_load(_str(f["provenance/resolved_scenario"][()]))
        cases = f["cases"]
        labels = _labels(cases["label"])
        sweep_keys = tuple(_sweep_keys(cases["inputs"], resolved))
        inputs = {k: _input_values(cases["inputs"][k]) for k in sweep_keys if k in cases["inputs"]}
        req_units_ds = f["requirements"].get("unit")
        req_units = [_str(x) for x in req_units_ds[()]] if req_units_ds is not None else []
        scalars, units = {}, {}
        for name, ds in cases["results"].items():
            scalars[name] = ds[()].astype(float)
            units[name] = _str(ds.attrs["units"]) if "units" in ds.attrs else scalar_unit(name, tuple(req_units))
        req = f["requirements"]
        names = [_str(x) for x in req["names"][()]]
        n, r = len(labels), len(names)
        out = Results(
            scenario_name=_str(f.attrs.get("scenario_name", path.parent.name)), sweep_keys=sweep_keys, labels=labels,
            inputs=inputs, scalars=scalars, units=units, requirements=names, requirement_units=req_units,
            requirement_sources=[_str(x) for x in req["sources"][()]] if "sources" in req else ["all"] * r,
            provenance=provenance, resolved_scenario=resolved,
        )
        if r:
            out.passed = req["passed"][()].astype(bool)
            out.value, out.limit, out.margin = (req[k][()].astype(float) for k in ("value", "limit", "margin"))
            out.dominant = read_text(req["dominant"])
            out.details = [{k: ds[()].astype(float) for k, ds in req["details"][str(j)].items()}
                           if str(j) in req.get("details", {}) else {} for j in range(r)]
            _read_verdict_states(out, req, n, r)
        else:
            out.passed = np.zeros((n, 0), bool)
            out.value = out.limit = out.margin = np.zeros((n, 0))
            out.dominant = out.status = out.reason = out.coverage = out.coverage_text = np.zeros((n, 0), dtype=object)
        return out


def _read_verdict_states(out, req, n: int, r: int) -> None:
    """Status, reason and coverage of every verdict (format 4); a file of an earlier format has no coverage
    (empty) and its statuses come from ``passed`` and the ``applies`` detail of ``agb_rmse_absolute``: a case
    outside the requirement's range, stored there as passing with a margin, reads as not applicable, with no
    margin."""
    if "status" in req:
        for name, dataset in (("status", "status"), ("reason", "reason"), ("coverage", "coverage_sources"),
                              ("coverage_text", "coverage_text")):
            setattr(out, name, read_text(req[dataset]))
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


def _sweep_keys(inputs, resolved) -> list:
    """The sweep keys in the scenario's order (HDF5 lists a group's members alphabetically)."""
    from e2esim.errors import Location
    from e2esim.runner.sweep import sweep_table

    try:
        keys = sweep_table(resolved.get("sweep"), Location("<results.h5>", ("sweep",))).keys
    except UserError:
        keys = ()
    tables = {_str(ds.attrs[TABLE_ATTR]) for ds in inputs.values() if TABLE_ATTR in ds.attrs}
    return [k for k in keys if k in inputs] or sorted(k for k in inputs if k not in tables)


def _labels(ds):
    """The case labels: joined from their parts when read (format 3, ``JoinedLabels``), or a list of text."""
    if isinstance(ds, h5py.Group):
        return JoinedLabels(read_text(ds["parts"]), ds["codes"][()], ds["numbered"][()])
    return [_str(x) for x in ds[()]]


def _input_values(ds) -> list:
    if ds.dtype.kind == "f":
        return ds[()].tolist()
    if TABLE_ATTR in ds.attrs:  # format 3: codes into the distinct texts
        distinct, codes = ds.parent[_str(ds.attrs[TABLE_ATTR])][()], ds[()]
    else:
        distinct, codes = ds[()], None
    values = np.empty(len(distinct), dtype=object)
    for i, x in enumerate(distinct):
        text = _str(x)
        try:  # values that are not text were written as JSON (e2esim.io.results_h5)
            values[i] = json.loads(text)
        except ValueError:
            values[i] = text
    return (values if codes is None else values[codes]).tolist()


def _str(x) -> str:
    return x.decode() if isinstance(x, bytes) else str(x)


def _attr(value):
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, str) and value[:1] in "[{":
        try:
            return json.loads(value)
        except ValueError:
            return value
    if isinstance(value, np.generic):
        return value.item()
    return value
