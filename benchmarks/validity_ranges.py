"""Measure where each analytic error model holds, against the exact Monte Carlo (docs/theory/validity.md).

For every analytic model, representative case (the Table I forests at the mean Faraday rotations of Men et al.
2021, Table II, SD 5 deg; the multi-pass sites) and direction in the (crosstalk, channel imbalance) plane
(``e2esim.verification.validity.DIRECTIONS``), the levels -30 dB to -4 dB (3-sigma amplitude labels, 2 dB
apart) and the hard limit (variance 0.1, -3.47 dB): the departures of the analytic mean, variance and Gaussian
99.865 % quantiles from the Monte Carlo (``departures``, 100 000 realisations; 25 000 for the multi-pass models),
and the largest level up to which every channel agrees within 5 %. Prints the table of docs/theory/validity.md;
``--write`` puts it there (between its markers), ``--json FILE`` keeps every departure and ``--from-json FILE``
makes the table from such a file without measuring again. About twenty minutes on one free core.

    python benchmarks/validity_ranges.py --write --json validity.json
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from e2esim.distortion.analytic import hv_error_moments
from e2esim.distortion.faraday_correction import FaradayCorrection
from e2esim.distortion.polarimetric_moments import polarimetric_error_moments
from e2esim.distortion.validity import HARD_LIMIT_VARIANCE
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.stack import combination as combos
from e2esim.stack.acquisitions import preset_stack
from e2esim.stack.error_model import StackHVErrorModel
from e2esim.stack.faraday import StackFaraday
from e2esim.stack.joint_model import StackJointErrorModel
from e2esim.stack.scene import StackScene
from e2esim.stack.sites import SITE_FORESTS, SITES
from e2esim.stack.system import StackSystemErrors
from e2esim.stack.temporal import TemporalDecorrelation
from e2esim.units import THREE_SIGMA_AMPLITUDE, level_db_from_variance
from e2esim.verification.men2021 import forest, system
from e2esim.verification.validity import (
    CHECKS,
    DIRECTIONS,
    TOLERANCE,
    departures,
    direction_levels,
    single_pass_errors,
    stack_errors,
)

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "theory" / "validity.md"
MARKERS = ("<!-- validity-table:start -->", "<!-- validity-table:end -->")
HARD_LIMIT_DB = float(level_db_from_variance(HARD_LIMIT_VARIANCE, THREE_SIGMA_AMPLITUDE))
LEVELS_DB = [*range(-30, -3, 2), round(HARD_LIMIT_DB, 2)]
REALISATIONS = 100_000
SEED = 20250801
TABLE2_FR_DEG = {"boreal_50": 30.0, "boreal_200": 60.0, "boreal_350": 90.0, "tropical_338": 0.0, "tropical_341": 0.0}
"""Mean Faraday rotation of each Table I forest in Men et al. (2021), Table II (SD 5 deg, Fig. 1)."""
CORRECTED = FaradayCorrection("estimated", GaussianFaraday(0.0, np.radians(0.1)))
"""The co-polarised channels rotated back by an estimate with a 0.1 deg residual (Bickel-Bates over a 2 km window,
biomass_multichannel)."""


def single_pass_cases():
    """(name, scene, Faraday rotation, correction) of the single-pass models."""
    for name, fr_deg in TABLE2_FR_DEG.items():
        fr = GaussianFaraday(np.radians(fr_deg), np.radians(5.0))
        yield f"{name}, FR {fr_deg:g}+-5 deg", forest(name), fr, None
        yield f"{name}, FR {fr_deg:g}+-5 deg, corrected", forest(name), fr, CORRECTED


def stack_cases():
    """(name, scene, errors factory, Faraday rotation, combination) of the multi-pass models: the interferometric
    stack of each site, stable system errors, a 3 deg Faraday-rotation difference between passes."""
    for site, fr_deg in (("boreal", 60.0), ("tropical", 0.0)):
        scene = StackScene(preset_stack("interferometric", np.radians(28.375)), forest(SITE_FORESTS[site]),
                           SITES[site], TemporalDecorrelation())
        fr = StackFaraday(GaussianFaraday(np.radians(fr_deg), np.radians(5.0)), np.radians(3.0))
        for estimator, comb in (("ground cancelled", combos.interpolated(scene.acquisitions.kz_rad_m)),
                                ("single date", combos.single_date(scene.passes, 0))):
            yield f"{site} site, {estimator}, FR {fr_deg:g}+-5 deg", scene, fr, comb


def analytic_single(model, scene, sys_model, fr, correction):
    """Mean and variance (C,) of a single-pass model without noise, L -> infinity."""
    if model in ("hv_complete", "hv_paper"):
        m = hv_error_moments(scene, sys_model, fr, "complete" if model == "hv_complete" else "paper")
        return np.atleast_1d(m.mean), np.atleast_1d(m.variance)
    m = polarimetric_error_moments(scene, sys_model, fr, correction)
    return m.mean, m.variance


def analytic_stack(model, scene, errors, fr, comb):
    if model == "stack_hv":
        m = StackHVErrorModel(scene, errors, fr, comb, reference="population").current()
        return np.atleast_1d(m.mean), np.atleast_1d(m.variance)
    m = StackJointErrorModel(scene, errors, fr, comb, reference="population", correct_copol=True).current_joint()
    return m.mean, np.diagonal(m.covariance)


def scan(rows, model, case, direction, simulate, analytic, channels):
    """Departures at every level, and the edges: the last level before the first that fails each check."""
    edges = {check: None for check in CHECKS}
    failed = {check: False for check in CHECKS}
    for level in LEVELS_DB:
        vd, ve = direction_levels(level, direction)
        errors = simulate(vd, ve)
        mean, variance = analytic(vd, ve)
        idx = [1] if channels == ("hv",) else [0, 1, 2]
        d = departures(errors[:, idx], mean, variance)
        row = {"model": model, "case": case, "direction": direction, "level_db": level, "channels": channels,
               **{check: d.worst(check) for check in CHECKS},
               **{f"{check}_fails": [ch for ch, f in zip(channels, d.fails(check)) if f] for check in CHECKS},
               "departures": d.record()}
        rows.append(row)
        for check in CHECKS:
            if not failed[check] and row[f"{check}_fails"]:
                failed[check] = True
            elif not failed[check]:
                edges[check] = level
        print(f"{model:12s} {case:45s} {direction:13s} {level:7.2f} " + " ".join(
            f"{c} {row[c]:+.3f}{'!' if row[f'{c}_fails'] else ''}" for c in CHECKS), file=sys.stderr, flush=True)
    return edges


def measure() -> dict:
    rng = np.random.default_rng(SEED)
    rows, edges = [], []
    for case, scene, fr, correction in single_pass_cases():
        for direction in DIRECTIONS:
            cache = {}

            def simulate(vd, ve, scene=scene, fr=fr, correction=correction, cache=cache):
                if (vd, ve) not in cache:
                    sys_model = system(-30, -34, nesz_db=None).with_levels(crosstalk=vd, imbalance=ve)
                    cache[(vd, ve)] = single_pass_errors(scene, sys_model, fr, rng, REALISATIONS, correction)
                return cache[(vd, ve)]

            models = ("polarimetric",) if correction is not None else ("hv_complete", "hv_paper", "polarimetric")
            for model in models:
                def analytic(vd, ve, model=model, scene=scene, fr=fr, correction=correction):
                    sys_model = system(-30, -34, nesz_db=None).with_levels(crosstalk=vd, imbalance=ve)
                    return analytic_single(model, scene, sys_model, fr, correction)

                channels = ("hv",) if model.startswith("hv_") else ("hh", "hv", "vv")
                e = scan(rows, model, case, direction, simulate, analytic, channels)
                edges.append({"model": model, "case": case, "direction": direction, **e})
    for case, scene, fr, comb in stack_cases():
        for direction in DIRECTIONS:
            cache = {}

            def errors_at(vd, ve):
                return StackSystemErrors(system(-30, -34, nesz_db=None).with_levels(crosstalk=vd, imbalance=ve), 1.0)

            def simulate(vd, ve, scene=scene, fr=fr, comb=comb, cache=cache):
                if (vd, ve) not in cache:
                    cache[(vd, ve)] = stack_errors(scene, errors_at(vd, ve), fr, comb, rng, REALISATIONS // 4)
                return cache[(vd, ve)]

            for model in ("stack_hv", "stack_joint"):
                def analytic(vd, ve, model=model, scene=scene, fr=fr, comb=comb):
                    return analytic_stack(model, scene, errors_at(vd, ve), fr, comb)

                channels = ("hv",) if model == "stack_hv" else ("hh", "hv", "vv")
                e = scan(rows, model, case, direction, simulate, analytic, channels)
                edges.append({"model": model, "case": case, "direction": direction, **e})
    return {"tolerance": TOLERANCE, "levels_db": LEVELS_DB, "realisations": REALISATIONS, "seed": SEED,
            "rows": rows, "edges": edges}


MODEL_NAMES = {
    "hv_complete": "HV, Men et al. (2021) completed to O(V^2) (`hv_backscatter_error`, complete form)",
    "hv_paper": "HV, Men et al. (2021) eqs. (11)-(12) as published (`variance_form: paper`)",
    "polarimetric": "HH, HV, VV (`polarimetric_error`, exact covariance, co-pol eq. 3.6)",
    "stack_hv": "multi-pass HV (`stack_backscatter_error`)",
    "stack_joint": "multi-pass HH, HV, VV (`stack_backscatter_error`, `channels: all`)",
}


def _edge_text(edge) -> str:
    if edge is None:
        return "none"
    return f"≥ {edge:.2f}" if edge == LEVELS_DB[-1] else f"{edge:.0f}"


def _first_failure(rows, model, case, direction, checks) -> str:
    """"<check> <channels>" at the first level where one of ``checks`` fails."""
    for row in rows:
        if (row["model"], row["case"], row["direction"]) != (model, case, direction):
            continue
        for check in checks:
            if row[f"{check}_fails"]:
                return f"{check} {'/'.join(ch.upper() for ch in row[f'{check}_fails'])}"
    return ""


def _worst_case(group, key):
    """The edge entry with the lowest edge (None, failing at the first level, lowest of all)."""
    return min(group, key=lambda e: -1e9 if key(e) is None else key(e))


def table(result: dict) -> str:
    """The markdown table: per model and direction the lowest edge over the cases, the case that sets it and what
    departs there; and the largest quantile departure at the lowest level scanned (-30 dB)."""
    rows, lowest = result["rows"], result["levels_db"][0]
    lines = ["| model | direction | mean and variance within 5 % up to (dB, 3σ) | set by | Gaussian 99.865 % "
             f"quantiles within 5 % up to (dB, 3σ) | set by | largest quantile departure at {lowest:g} dB |",
             "|---|---|---|---|---|---|---|"]
    for model, variant in _variants(result):
        for direction in DIRECTIONS:
            group = [e for e in result["edges"] if e["model"] == model and e["direction"] == direction
                     and _variant_of(e["case"]) == variant]
            if not group:
                continue
            moments = _worst_case(group, _combined)
            quantile = _worst_case(group, lambda e: e["quantile"])
            at_lowest = [r["quantile"] for r in rows if r["model"] == model and r["direction"] == direction
                         and r["level_db"] == lowest and _variant_of(r["case"]) == variant]
            worst = max(at_lowest, key=abs)
            why_m = _first_failure(rows, model, moments["case"], direction, ("mean", "variance"))
            why_q = _first_failure(rows, model, quantile["case"], direction, ("quantile",))
            lines.append(f"| {MODEL_NAMES[model]}{variant} | {direction} | {_edge_text(_combined(moments))} | "
                         f"{(moments['case'] + ': ' + why_m) if why_m else '–'} | {_edge_text(quantile['quantile'])} | "
                         f"{(quantile['case'] + ': ' + why_q) if why_q else '–'} | {100 * worst:+.0f} % |")
    return "\n".join(lines)


def _variant_of(case: str) -> str:
    return ", co-polarised channels corrected" if case.endswith(", corrected") else ""


def _variants(result) -> list:
    """(model, variant) in table order: the polarimetric model uncorrected and corrected apart."""
    present = {(e["model"], _variant_of(e["case"])) for e in result["edges"]}
    return [(m, v) for m in MODEL_NAMES for v in ("", ", co-polarised channels corrected") if (m, v) in present]


def _combined(edge):
    values = [edge["mean"], edge["variance"]]
    return None if any(v is None for v in values) else min(values)


def write(text: str) -> None:
    doc = DOC.read_text()
    pattern = re.compile(re.escape(MARKERS[0]) + ".*?" + re.escape(MARKERS[1]), re.S)
    if not pattern.search(doc):
        raise SystemExit(f"{DOC}: no {MARKERS[0]} ... {MARKERS[1]} section")
    DOC.write_text(pattern.sub(lambda _: f"{MARKERS[0]}\n{text}\n{MARKERS[1]}", doc))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help=f"write the table into {DOC.relative_to(ROOT)}")
    ap.add_argument("--json", type=Path, help="keep every departure in this file")
    ap.add_argument("--from-json", type=Path, help="make the table from a file of --json, measuring nothing")
    args = ap.parse_args(argv)
    result = json.loads(args.from_json.read_text()) if args.from_json else measure()
    text = table(result)
    print(text)
    if args.json and not args.from_json:
        args.json.write_text(json.dumps(result, indent=1))
    if args.write:
        write(text)


if __name__ == "__main__":
    main()
