"""results.h5: every case's inputs and results with provenance. Layout in docs/output-format.md."""

from __future__ import annotations

import json

import h5py
import numpy as np
import yaml

from e2esim.io.atomic import atomic_path

_STR = h5py.string_dtype("utf-8")


def write_results(result, path) -> None:
    """Write all cases of ``result`` (a ScenarioResult) to ``path`` atomically."""
    cases = result.cases
    n = len(cases)
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        for key, value in result.provenance.items():
            f.attrs[key] = json.dumps(value) if isinstance(value, list) else value
        f.attrs["scenario_name"] = result.scenario.name
        f.attrs["n_cases"] = n
        prov = f.create_group("provenance")
        prov.create_dataset("resolved_scenario", data=yaml.safe_dump(result.scenario.resolved, sort_keys=False),
                            dtype=_STR)
        prov.create_dataset("scenario_as_given", data=yaml.safe_dump(result.scenario.raw, sort_keys=False),
                            dtype=_STR)

        g = f.create_group("cases")
        g.create_dataset("index", data=np.array([c.index for c in cases], dtype=np.int64))
        g.create_dataset("label", data=[c.label for c in cases], dtype=_STR)
        inputs = g.create_group("inputs")
        for key in result.scenario.sweep_keys:
            values = [c.inputs.get(key) for c in cases]
            if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
                inputs.create_dataset(key, data=np.array(values, dtype=float))
            else:
                inputs.create_dataset(key, data=[json.dumps(v) if not isinstance(v, str) else v for v in values],
                                      dtype=_STR)
        res = g.create_group("results")
        names = sorted({k for c in cases for k in c.scalars})
        for name in names:
            res.create_dataset(name, data=np.array([c.scalars.get(name, np.nan) for c in cases], dtype=float))

        req = f.create_group("requirements")
        req_names = result.requirement_names
        req.create_dataset("names", data=req_names, dtype=_STR)
        if req_names:
            verdicts = [[c.verdicts[j] for j in range(len(req_names))] for c in cases]
            req.create_dataset("passed", data=np.array([[v.passed for v in row] for row in verdicts], dtype=bool))
            for attr in ("value", "limit", "margin"):
                req.create_dataset(attr, data=np.array([[getattr(v, attr) for v in row] for row in verdicts]))
            req.create_dataset("unit", data=[v.unit for v in verdicts[0]], dtype=_STR)
            req.create_dataset("basis", data=[[v.basis for v in row] for row in verdicts], dtype=_STR)
            req.create_dataset("dominant", data=[[v.dominant for v in row] for row in verdicts], dtype=_STR)
            det = req.create_group("details")
            keys = sorted({(j, k) for row in verdicts for j, v in enumerate(row) for k in v.details})
            for j, k in keys:
                det.create_dataset(f"{j}/{k}", data=np.array([row[j].details.get(k, np.nan) for row in verdicts],
                                                             dtype=float))

        arrays = f.create_group("arrays")
        for c in cases:
            cg = None
            model = c.get("backscatter.error")
            samples = model.samples() if model is not None else None
            if samples is not None and result.scenario.cases[c.index].settings.keep_samples:
                cg = arrays.require_group(f"case{c.index:06d}")
                cg.create_dataset(f"{model.channel}_errors", data=samples)  # random doubles barely compress: no filter
            for j, v in enumerate(c.verdicts):
                for name, values in v.curves.items():
                    cg = cg or arrays.require_group(f"case{c.index:06d}")
                    cg.create_dataset(f"requirement{j}/{name}", data=np.asarray(values, dtype=float))
