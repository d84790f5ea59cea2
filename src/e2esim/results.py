"""``Results``: the numbers of a run as plain arrays, the same whether the run was made in this process
(``e2esim.run``) or read back from its results.h5 (``e2esim.open_results``), with pandas and xarray views.

Sweep keys become columns of the data frame and coordinates of the xarray Dataset; a grid sweep
(``sweep.parameters`` in grid mode) becomes an N-dimensional array with one dimension per parameter (keys
varied together share one dimension), any other sweep one dimension ``case``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from e2esim.extras import optional_import
from e2esim.io.scalar_units import run_products, scalar_description, scalar_unit
from e2esim.maps.grid import map_section
from e2esim.maps.netcdf import map_dataset
from e2esim.runner.folder_run import write_into_folder


@dataclass
class Results:
    """All cases of a run.

    scenario_name, sweep_keys, labels (one per case: a sequence of text that makes each label when read; compares
    equal to the list of them), inputs ({sweep key: [value per case]}), scalars
    ({name: (n,) float array}, every output scalar, docs/output-format.md), units ({name: unit}),
    requirements (names), requirement_units, requirement_sources (each requirement's ``sources`` setting:
    "computed", "all" or "systematic"), passed (true only where a requirement applies and is met), value, limit,
    margin (NaN where it does not apply) ((n, R) arrays), status ("pass", "fail" or "not_applicable"), reason (why
    not applicable, else ""), dominant, coverage (the error sources each checked value contains, names separated
    by ", ") and coverage_text (the same in words) ((n, R) strings), details ([{key: (n,) array}] per requirement),
    provenance, resolved_scenario (dict). ``run``: the ``ScenarioResult`` with every case's products when the
    run was made in this process (None when read from a file).
    """

    scenario_name: str
    sweep_keys: tuple
    labels: Sequence
    inputs: dict
    scalars: dict
    units: dict
    requirements: list = field(default_factory=list)
    requirement_units: list = field(default_factory=list)
    requirement_sources: list = field(default_factory=list)
    passed: np.ndarray = None
    value: np.ndarray = None
    limit: np.ndarray = None
    margin: np.ndarray = None
    dominant: np.ndarray = None
    details: list = field(default_factory=list)
    status: np.ndarray = None
    reason: np.ndarray = None
    coverage: np.ndarray = None
    coverage_text: np.ndarray = None
    provenance: dict = field(default_factory=dict)
    resolved_scenario: dict = field(default_factory=dict)
    run: object = field(default=None, repr=False)
    settings_without_effect: list = field(default_factory=list)
    """Messages on the swept or overridden settings that change no result (``e2esim.runner.no_effect``)."""

    @property
    def n_cases(self) -> int:
        return len(self.labels)

    def label_list(self) -> list:
        """Every case's label, as a list."""
        return self.labels.tolist() if hasattr(self.labels, "tolist") else list(self.labels)

    # Construction -----------------------------------------------------------------------------------
    @classmethod
    def from_run(cls, result) -> Results:
        """From a ``ScenarioResult`` (``e2esim.runner.run.run_scenario``)."""
        from e2esim.block import Values
        from e2esim.io.summary import requirement_sources
        from e2esim.runner.result_table import text_column

        def joined(values):  # a column of source-name tuples as text
            return text_column(Values([", ".join(v) for v in values.values], values.index))

        table = result.table  # columns of every case, in case order
        n, n_req = table.n, len(result.requirement_names)
        names = sorted(table.scalars)
        req_units = [r.unit[0] for r in table.requirements] if n else []
        products = run_products(result.scenario)  # the units of the output scalars
        labels = result.labels  # a sweep's labels are joined when read (e2esim.runner.sweep.CaseLabels)

        def stacked(attr, convert=np.asarray):
            columns = [convert(getattr(r, attr)) for r in table.requirements]
            return np.stack(columns, axis=1) if columns else np.zeros((n, 0), dtype=object)

        return cls(
            scenario_name=result.scenario.name,
            sweep_keys=tuple(result.scenario.sweep_keys),
            labels=labels,
            inputs=result.input_columns(),
            scalars={k: table.scalar(k).astype(float, copy=False) for k in names},  # each joined anew: not shared
            units={k: scalar_unit(k, tuple(req_units), products) for k in names},
            requirements=list(result.requirement_names),
            requirement_units=req_units,
            requirement_sources=requirement_sources(result.scenario),
            passed=stacked("passed").astype(bool).reshape(n, n_req),
            value=stacked("value").astype(float).reshape(n, n_req),
            limit=stacked("limit").astype(float).reshape(n, n_req),
            margin=stacked("margin").astype(float).reshape(n, n_req),
            dominant=stacked("dominant", text_column).reshape(n, n_req),
            details=[{k: table.detail(j, k) for k in r.details} for j, r in enumerate(table.requirements)],
            status=stacked("status").astype(object).reshape(n, n_req),
            reason=stacked("reason", text_column).reshape(n, n_req),
            coverage=stacked("coverage", joined).reshape(n, n_req),
            coverage_text=stacked("coverage_text", text_column).reshape(n, n_req),
            provenance=dict(result.provenance),
            resolved_scenario=result.scenario.resolved,
            run=result,
            settings_without_effect=[f.message() for f in result.no_effect],  # found once, kept with the run
        )

    # Views ------------------------------------------------------------------------------------------
    def to_dataframe(self):
        """pandas DataFrame, one row per case (index ``case``): ``label``, the sweep keys, every output scalar,
        and per requirement j ``requirement<j>.status`` and ``requirement<j>.dominant``. ``df.attrs["units"]`` gives
        each column's unit."""
        import pandas as pd

        columns = {"label": self.label_list()}
        columns.update({k: self.inputs[k] for k in self.sweep_keys})
        columns.update(self.scalars)
        for j in range(len(self.requirements)):
            columns[f"requirement{j}.status"] = list(self.status[:, j])
            columns[f"requirement{j}.dominant"] = list(self.dominant[:, j])
        df = pd.DataFrame(columns, index=pd.RangeIndex(self.n_cases, name="case"))
        df.attrs["units"] = dict(self.units)
        df.attrs["requirements"] = list(self.requirements)
        return df

    def to_xarray(self):
        """xarray Dataset: every output scalar as a variable (attributes ``units``, ``description``) over the
        sweep's dimensions, the sweep keys as coordinates (module docstring); a map sweep's map on its grid, as in
        its results.nc (``e2esim.maps.netcdf``).

        An output scalar named as a sweep key (``scene.agb_t_ha`` of a sweep over it) is that coordinate, with
        the scalar's attributes, where its values are the swept ones; where they differ it is the variable
        ``<name>.output`` beside the coordinate."""
        xr = optional_import("xarray", "maps", "Results.to_xarray")

        if map_section(self.resolved_scenario.get("sweep")) is not None:
            return map_dataset(self)

        dims, shape = self.sweep_dimensions()
        dim_of = grid_coordinate_keys(self.resolved_scenario.get("sweep")) if dims != ("case",) else {}
        coords = {}
        for key in self.sweep_keys:
            values = np.asarray(self.inputs[key], dtype=object if _is_text(self.inputs[key]) else float)
            grid = values.reshape(shape)
            dim = dim_of.get(key)
            if dim is not None:
                index = tuple(slice(None) if d == dim else 0 for d in dims)
                coords[key] = (dim, grid[index])
            else:
                coords[key] = (tuple(dims), grid)
        coords["label"] = (tuple(dims), np.asarray(self.label_list(), dtype=object).reshape(shape))
        data = {}
        for name, values in self.scalars.items():
            attrs = {"units": self.units.get(name, "unknown"), "description": scalar_description(name)}
            if name in coords:  # an output scalar named as a sweep key (scene.agb_t_ha, instrument.nesz_db)
                if _same_values(self.inputs[name], values):
                    coords[name] = (*coords[name], attrs)  # the coordinate says it all: it gets the units
                    continue
                name = f"{name}{OUTPUT_SUFFIX}"  # the chain's value differs from the swept input: keep both
            data[name] = xr.Variable(tuple(dims), values.reshape(shape), attrs=attrs)
        ds = xr.Dataset(data, coords=coords)
        ds.attrs.update(scenario=self.scenario_name, requirements=list(self.requirements))
        return ds

    def sweep_dimensions(self) -> tuple:
        """(dimension names, shape): one dimension per parameter group of a grid sweep, else ("case",)."""
        groups = _grid_groups(self.resolved_scenario.get("sweep"))
        if groups and int(np.prod([size for _, size in groups])) == self.n_cases:
            return tuple(keys[0] for keys, _ in groups), tuple(size for _, size in groups)
        return ("case",), (self.n_cases,)

    def verdict_table(self, j: int = 0):
        """pandas DataFrame of requirement j per case: status, reason, passed, value, limit, margin (NaN where the
        requirement does not apply), dominant, coverage_text."""
        import pandas as pd

        return pd.DataFrame({"label": self.label_list(), "status": self.status[:, j], "reason": self.reason[:, j],
                             "passed": self.passed[:, j], "value": self.value[:, j], "limit": self.limit[:, j],
                             "margin": self.margin[:, j], "dominant": self.dominant[:, j],
                             "coverage_text": self.coverage_text[:, j]},
                            index=pd.RangeIndex(self.n_cases, name="case"))

    def write(self, folder) -> dict:
        """Write results.h5, summary.json, the report and its plots into ``folder`` (a run made here only), with
        the folder locked as a run locks it (``e2esim.runner.folder_run.write_into_folder``)."""
        if self.run is None:
            raise ValueError("these results were read from a file: their products (for the report and the plots) "
                             "are not kept; run the scenario again to write a report")
        return write_into_folder(self.run, Path(folder))


OUTPUT_SUFFIX = ".output"
"""Suffix of an output scalar whose name is a sweep key's and whose values are not the swept ones."""


def _same_values(inputs, values) -> bool:
    """Whether a sweep key's input values are an output scalar's values (to rounding; NaN and None alike)."""
    if not all(v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)) for v in inputs):
        return False
    swept = np.array([np.nan if v is None else v for v in inputs], dtype=float)
    values = np.asarray(values, dtype=float)  # a dB value read back through linear units may differ in its last bits
    return swept.shape == values.shape and bool(np.allclose(swept, values, rtol=1e-12, atol=0.0, equal_nan=True))


def _is_text(values) -> bool:
    return not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def _grid_groups(sweep) -> list:
    """[(keys, number of values)] of a grid sweep's parameter groups, [] for any other sweep."""
    if not isinstance(sweep, dict) or not isinstance(sweep.get("parameters"), dict) or sweep.get("mode") == "zip":
        return []
    from e2esim.errors import Location
    from e2esim.runner.sweep import sweep_values

    out = []
    for key, spec in sweep["parameters"].items():
        keys = tuple(k.strip() for k in str(key).split(","))
        out.append((keys, len(sweep_values(spec, Location("<sweep>", ())))))
    return out


def grid_coordinate_keys(sweep) -> dict:
    """{key: dimension} of every key of a grid sweep (keys varied together share their first key's dimension)."""
    return {k: keys[0] for keys, _ in _grid_groups(sweep) for k in keys}


__all__ = ["Results", "grid_coordinate_keys"]
