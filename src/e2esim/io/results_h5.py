"""results.h5: every case's inputs and results with provenance. Layout in docs/output-format.md.

Every dataset carries a ``units`` and a ``description`` attribute (``e2esim.io.scalar_units``), so the file
reads without the documentation; ``e2esim.open_results`` reads it back.
"""

from __future__ import annotations

import json

import numpy as np
import yaml

from e2esim.atomic import atomic_path
from e2esim.block import Values
from e2esim.io.campaign_h5 import write_campaign
from e2esim.io.guarded_h5 import guarded_h5_file
from e2esim.io.h5_datasets import code_dtype, coded_values, put, put_coded, put_text
from e2esim.io.scalar_units import detail_unit, run_products, scalar_description, scalar_unit, scalar_units
from e2esim.io.sensitivity_h5 import write_sensitivity
from e2esim.io.summary import requirement_sources
from e2esim.maps.grid import is_map_sweep
from e2esim.requirements.verdict import STATUSES
from e2esim.runner.joined_labels import JoinedLabels

FORMAT_VERSION = 4
"""2: units and descriptions on every dataset, acquisitions, requirement sources; 3: text over cases (labels,
basis, dominant source, text sweep values) as integer codes into tables of distinct texts; 4: every verdict's
status (pass, fail, not_applicable) and reason, and the error sources it covers (coverage)."""


def write_results(result, path) -> None:
    """Write all cases of ``result`` (a ScenarioResult) to ``path`` atomically, column by column from the run's
    columns (``e2esim.runner.result_table``: one output scalar in memory at a time); per-case arrays and
    acquisitions only where the run kept its products."""
    table = result.table
    n = table.n
    with atomic_path(path) as tmp, guarded_h5_file(tmp) as f:  # a full disk: an OSError, never a crash
        for key, value in result.provenance.items():
            if value is None:
                continue  # e.g. no source commit outside a git checkout
            f.attrs[key] = json.dumps(value) if isinstance(value, (list, dict)) else value
        f.attrs["scenario_name"] = result.scenario.name
        f.attrs["n_cases"] = n
        f.attrs["format_version"] = FORMAT_VERSION
        prov = f.create_group("provenance")
        put_text(prov, "resolved_scenario", scenario_yaml(result.scenario.resolved),
                 "the scenario with every module's defaults filled in (first case) and the sweep, YAML")
        put_text(prov, "scenario_as_given", scenario_yaml(result.scenario.raw),
                 "the scenario as read, after --set overrides, YAML")

        answer = getattr(result, "answer", None)
        if answer:  # the scenario's own question, answered by e2esim run (e2esim.flowdown.answer)
            a = f.create_group("answer")
            a.attrs["question"] = answer["question"]
            put_text(a, "text", "\n".join(answer["lines"]), "the answer to the scenario's solve or allocate section")
            put_text(a, "result", json.dumps(answer["result"]), "the answer as e2esim solve --json prints it, or "
                     "e2esim allocate's specification, JSON")
        if getattr(result, "sensitivity", None):
            write_sensitivity(f, result.sensitivity)  # output.sensitivity (e2esim.runner.sensitivity)
        g = f.create_group("cases")
        put(g, "index", np.arange(n, dtype=np.int64), "1", "case number")
        _write_labels(g.create_group("label"), result.labels)
        inputs = g.create_group("inputs")
        for key, (distinct, codes) in _input_codes(result).items():
            about = f"sweep value of {key} in each case"
            if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in distinct):
                put(inputs, key, np.array(distinct, dtype=float)[codes], _input_unit(key), about)
            else:
                put_coded(inputs, key, [v if isinstance(v, str) else json.dumps(v) for v in distinct], codes,
                          about + " (JSON for values that are not text)")
        res = g.create_group("results")
        req_units = tuple(r.unit[0] for r in table.requirements) if n else ()
        products = run_products(result.scenario)
        names = sorted(table.scalars)
        for name, unit in zip(names, scalar_units(names, req_units, products)):
            put(res, name, table.scalar(name), unit, scalar_description(name) + "; NaN where a case lacks it")
        _write_requirements(f.create_group("requirements"), result, list(req_units))
        arrays, acquisitions = f.create_group("arrays"), f.create_group("acquisitions")
        _write_curves(arrays, table)
        if result.keeps_products:
            _write_samples(arrays, result)
            if not is_map_sweep(result.scenario):  # a map's cells: their swath samples would be 200 000 groups
                _write_acquisitions(acquisitions, result.cases)
            write_campaign(f, result.cases)  # issue 25: the campaign's daily residuals, visits and schedules


_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
"""libyaml's emitter where PyYAML has it: the text of ``yaml.safe_dump`` (the same for every shipped scenario:
tests/test_results_h5_content.py) in a quarter of the time."""


def scenario_yaml(scenario: dict) -> str:
    """A scenario as YAML text, its keys in their order: ``yaml.safe_dump(scenario, sort_keys=False)``."""
    return yaml.dump(scenario, Dumper=_DUMPER, sort_keys=False)


def _write_labels(group, labels) -> None:
    """The case labels in factored form (``e2esim.runner.joined_labels``): parts, codes, numbered cases."""
    joined = labels.joined() if hasattr(labels, "joined") else JoinedLabels.of(labels)
    group.attrs["description"] = ('case label: the sweep keys that differ between cases; label i is ", ".join of '
                                  'the non-empty parts[codes[i, :]] ("base case" if none), followed by " (#i)" where '
                                  "numbered[i]")
    put_text(group, "parts", joined.parts.tolist(), "the distinct parts of the labels (one or more per group of "
             "sweep keys)")
    put(group, "codes", joined.codes.astype(code_dtype(len(joined.parts))), "1",
        "per case and group of sweep keys: the position of its part in parts")
    put(group, "numbered", joined.numbered, "1", "cases whose label another case shares: their number is appended")


def _input_codes(result) -> dict:
    """{sweep key: (its distinct values, the position of each case's value among them)}: made group by group of the
    sweep's table, not case by case (None where a case of ``sweep.cases`` does not set the key)."""
    if result.scenario.plan is not None:
        return result.scenario.plan.table.input_codes()
    out = {}
    for key, values in result.input_columns().items():
        column = Values.of(values)
        out[key] = (column.values, column.index)
    return out


def _input_unit(key: str) -> str:
    unit = scalar_unit(key.rpartition(".")[2])
    return unit if unit != "unknown" else "as the scenario key (docs/scenario-reference.md)"


def _write_requirements(req, result, units: list) -> None:
    names = list(result.requirement_names)
    put_text(req, "names", names, "requirement labels in scenario order")
    if not names:
        return
    table = result.table
    n = table.n
    put_text(req, "sources", requirement_sources(result.scenario),
             "the sources setting of each requirement: computed (every source the chain computes), all (the same, "
             "checked complete at validation) or systematic (system distortions, Faraday rotation, noise); what each "
             "verdict covers is /requirements/coverage_sources")

    def stacked(attr, dtype):  # (case, requirement), one requirement's column joined at a time
        out = np.empty((n, len(names)), dtype=dtype)
        for j, r in enumerate(table.requirements):
            out[:, j] = getattr(r, attr)
        return out

    put(req, "passed", stacked("passed", bool), "1", "verdict of requirement j (column) in case i (row): true passes "
        "(false where it fails or does not apply: see /requirements/status)")
    applicable = stacked("applicable", bool)
    put_coded(req, "status", list(STATUSES), np.where(~applicable, 2, np.where(stacked("passed", bool), 0, 1)),
              "status of requirement j (column) in case i (row): pass, fail, or not_applicable (outside the "
              "requirement's range: no margin)")
    put_coded(req, "reason", *coded_values([r.reason for r in table.requirements]),
              "why requirement j does not apply to case i (empty where it applies)")
    put_coded(req, "coverage_sources", *coded_values([_joined(r.coverage) for r in table.requirements]),
              "the error sources the checked value of requirement j contains in case i, as the chain computed them "
              "(names separated by ', ')")
    put_coded(req, "coverage_text", *coded_values([r.coverage_text for r in table.requirements]),
              "the same in words, with the terms the chain does not compute")
    about = {
        "value": "the checked quantity",
        "limit": "the requirement's bound",
        "margin": "limit - value; positive passes; NaN where the requirement does not apply",
    }
    for attr in ("value", "limit", "margin"):
        put(req, attr, stacked(attr, float), "see /requirements/unit",
            f"{about[attr]} (case, requirement), in /requirements/unit")
    put_text(req, "unit", units, "unit of each requirement's value, limit and margin")
    put_coded(req, "basis", *coded_values([r.basis for r in table.requirements]), "analytic or montecarlo")
    put_coded(req, "dominant", *coded_values([r.dominant for r in table.requirements]),
              "the error source whose removal would reduce the checked value most")
    det = req.create_group("details")
    for j, r in enumerate(table.requirements):
        for k in sorted(r.details):
            put(det, f"{j}/{k}", table.detail(j, k), detail_unit(k, units[j]),
                f"requirement {j}: {k} (docs/output-format.md, summary.json details)")


def _joined(coverage: Values) -> Values:
    """A ``Values`` column of source-name tuples as text, each distinct tuple once."""
    return Values([", ".join(sources) for sources in coverage.values], coverage.index)


def _write_curves(arrays, table) -> None:
    """The trade-off curves of every case that has them, read block by block (``ResultTable.curves_by_block``)."""
    for j in range(len(table.requirements)):
        for cases, curves in table.curves_by_block(j):
            drawn = np.array([bool(v) for v in curves.values], dtype=bool)
            for k in np.nonzero(drawn[curves.index])[0]:
                cg = arrays.require_group(f"case{int(cases[k]):06d}")
                for name, values in curves[k].items():
                    what = ("crosstalk level (abscissa of the trade-off curve)" if name == "crosstalk_db" else
                            "largest channel imbalance meeting the requirement at each crosstalk level (NaN: "
                            "crosstalk alone breaks it)" if name.endswith("imbalance_db") else name)
                    put(cg, f"requirement{j}/{name}", np.asarray(values, dtype=float),
                        "dB (instrument convention)" if name.endswith("_db") else "unknown", f"requirement {j}: {what}")


def _write_samples(arrays, result) -> None:
    """The Monte Carlo errors of the cases that keep them (``simulation.keep_samples``)."""
    for c in result.cases:
        model = c.get("backscatter.error")
        samples = model.samples() if model is not None else None
        if samples is not None and result.scenario.cases[c.index].settings.keep_samples:
            cg = arrays.require_group(f"case{c.index:06d}")
            put(cg, f"{model.channel}_errors", samples, "m^2/m^2",  # random doubles barely compress: no filter
                f"Monte Carlo errors of sigma_{model.channel} (realisations, noise realisations)")


_GEOMETRY = (  # (attribute, dataset, scale, units, description)
    ("incidence", "incidence_deg", np.degrees, "deg", "incidence angle at the target"),
    ("heading", "heading_deg", np.degrees, "deg", "satellite heading"),
    ("local_time_h", "local_time_h", None, "h", "local solar time of the acquisition"),
    ("pierce_lat", "pierce_lat_deg", np.degrees, "deg", "latitude of the ionospheric pierce point"),
    ("pierce_lon", "pierce_lon_deg", np.degrees, "deg", "longitude of the ionospheric pierce point"),
    ("weight", "weight", None, "1", "weight of the acquisition in the case's statistics"),
)
_FARADAY = (
    ("acquisition_omega", "omega_deg", np.degrees, "deg", "one-way Faraday rotation at the IRI median (before "
     "day-to-day variability)"),
    ("vtec", "vtec_tecu", lambda x: np.asarray(x) / 1e16, "TECU", "vertical TEC at the pierce point"),
    ("stec", "stec_tecu", lambda x: np.asarray(x) / 1e16, "TECU", "slant TEC along the ray"),
    ("b_dot_k", "b_dot_k_ut", lambda x: np.asarray(x) * 1e6, "uT", "density-weighted mean B.k along the ray"),
    ("range_delay_m", "range_delay_m", None, "m", "one-way slant range delay"),
)


def _write_acquisitions(acq, cases) -> None:
    """Per case and acquisition: the geometry (``geometry``) and the Faraday rotation before any correction
    (``faraday.geophysical``, when it comes from a climatology of the acquisitions)."""
    for c in cases:
        geom, fr = c.get("geometry"), c.get("faraday.geophysical")
        omega = getattr(fr, "acquisition_omega", None)
        if geom is None and omega is None:
            continue
        cg = acq.create_group(f"case{c.index:06d}")
        if geom is not None:
            put_text(cg, "time_utc", np.datetime_as_string(geom.time_utc, unit="s"), "time of the acquisition (UTC)")
            put_text(cg, "pass_label", [str(p) for p in geom.pass_label], "pass of the acquisition (e.g. dawn, dusk)")
            for attr, name, scale, units, about in _GEOMETRY:
                _put_array(cg, name, getattr(geom, attr), scale, units, about)
        if omega is not None:
            if geom is None and fr.pass_label is not None:
                put_text(cg, "pass_label", [str(p) for p in fr.pass_label], "pass of the acquisition")
            for attr, name, scale, units, about in _FARADAY:
                _put_array(cg, name, getattr(fr, attr), scale, units, about)


def _put_array(group, name, values, scale, units, about) -> None:
    if values is None:
        return
    put(group, name, np.asarray(scale(values) if scale else values, dtype=float), units, about + ", per acquisition")
