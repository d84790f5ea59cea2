"""Numbers are locked across refactors: save every number e2esim computes, and compare two saves.

Before a restructuring, save the numbers of the code as it is; afterwards, save again and compare:

    python benchmarks/number_lock.py save /tmp/numbers-before
    ... restructure ...
    python benchmarks/number_lock.py save /tmp/numbers-after
    python benchmarks/number_lock.py compare /tmp/numbers-before /tmp/numbers-after

``save`` writes ``reproduce.json`` (``e2esim reproduce --json``), ``summaries/<scenario>.json`` (the
summary.json of every shipped scenario, run at its own sizes, or with the overrides of ``--set``: a smaller
map, say) and ``results/<scenario>.json`` (the content of
its results.h5: the labels as ``e2esim.open_results`` reads them, and every dataset, text given as codes
read back as its text; ``results_h5_content``). ``compare`` checks every number of the first save against
the second: reproduce records by id (computed value and status), in each summary every per-case scalar,
every requirement verdict (passed, value, limit, margin, dominant contributor, details) and the requirement
overview, and in each results.h5 every label and dataset value (not the attributes). Numbers must agree to a
relative 1e-12 (floating-point reordering); text and booleans exactly. Provenance (time, command line,
versions) is not compared. Keys that exist only in the second save are listed but are not failures (a
refactor may add outputs); keys that disappear are. Exit status 0 when everything matches, 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROVENANCE = {"created_utc", "command", "python", "numpy", "e2esim_version", "scenario_file", "executor",
              "resumed_cases", "versions", "source_commit", "scipy", "h5py", "PyIRI", "ppigrf"}
"""summary.json keys that describe the run rather than its results."""


def _e2esim() -> list:
    return [sys.executable, "-m", "e2esim"]


def save(folder: Path, scenarios: list | None = None, overrides: list | None = None) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "summaries").mkdir(exist_ok=True)
    out = subprocess.run(_e2esim() + ["reproduce", "--json"], capture_output=True, text=True, cwd=ROOT)
    if out.returncode not in (0, 1):
        raise SystemExit(f"e2esim reproduce failed:\n{out.stderr}")
    (folder / "reproduce.json").write_text(out.stdout)
    files = sorted((ROOT / "scenarios").glob("*.yaml"))
    for path in files:
        if scenarios and path.stem not in scenarios:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            sets = [arg for value in overrides or () for arg in ("--set", value)]
            run = subprocess.run(_e2esim() + ["run", str(path), "-o", tmp, "--force", "--no-progress", *sets],
                                 capture_output=True, text=True, cwd=ROOT)
            if run.returncode != 0:
                raise SystemExit(f"{path.name} failed:\n{run.stderr}")
            (folder / "summaries" / f"{path.stem}.json").write_text((Path(tmp) / "summary.json").read_text())
            (folder / "results").mkdir(exist_ok=True)
            (folder / "results" / f"{path.stem}.json").write_text(json.dumps(results_h5_content(Path(tmp))))
        print(f"saved {path.stem}", file=sys.stderr)


def results_h5_content(run_folder: Path) -> dict:
    """{"labels": [...], "datasets": {path: value}} of a run's results.h5, in a form that does not depend on how
    text is stored: a dataset of integer codes with a ``text`` attribute (format 3) reads as the text of its
    codes, so files written before and after that change compare like with like. The label datasets
    (``/cases/label*``) are compared through ``e2esim.open_results``."""
    import h5py
    import numpy as np

    from e2esim.io.results_reader import read_results
    from e2esim.results import Results

    out: dict = {}

    def text(x):
        return x.decode() if isinstance(x, bytes) else x

    def visit(name, obj):
        if not isinstance(obj, h5py.Dataset) or name.startswith("cases/label") or name in tables:
            return
        data = obj[()]
        if "text" in obj.attrs:  # codes into the sibling table of distinct texts
            table = np.array([text(t) for t in obj.parent[text(obj.attrs["text"])][()]], dtype=object)
            data = table[data]
        data = np.asarray(data)
        out[name] = np.vectorize(text, otypes=[object])(data).tolist() if data.dtype.kind in "OS" else data.tolist()

    with h5py.File(run_folder / "results.h5", "r") as f:
        tables = set()
        f.visititems(lambda name, obj: tables.add(f"{name.rpartition('/')[0]}/{text(obj.attrs['text'])}")
                     if isinstance(obj, h5py.Dataset) and "text" in obj.attrs else None)
        f.visititems(visit)
    return {"labels": list(read_results(run_folder, Results).labels), "datasets": out}


class Comparison:
    def __init__(self, rtol: float):
        self.rtol = rtol
        self.failures: list = []
        self.added: list = []
        self.checked = 0

    def value(self, where: str, a, b) -> None:
        if isinstance(a, dict) and isinstance(b, dict):
            for key in a:
                if key not in b:
                    self.failures.append(f"{where}.{key}: missing in the new numbers")
                else:
                    self.value(f"{where}.{key}", a[key], b[key])
            self.added.extend(f"{where}.{key}" for key in b if key not in a)
            return
        if isinstance(a, list) and isinstance(b, list):
            if len(a) != len(b):
                self.failures.append(f"{where}: {len(a)} items before, {len(b)} now")
                return
            for i, (x, y) in enumerate(zip(a, b)):
                self.value(f"{where}[{i}]", x, y)
            return
        self.checked += 1
        if (
            isinstance(a, bool)
            or isinstance(b, bool)
            or not isinstance(a, (int, float))
            or not isinstance(b, (int, float))
        ):
            if a != b:
                self.failures.append(f"{where}: {a!r} before, {b!r} now")
            return
        if math.isnan(a) and math.isnan(b):
            return
        if a == b:
            return
        if not math.isclose(a, b, rel_tol=self.rtol, abs_tol=0.0):
            self.failures.append(f"{where}: {a!r} before, {b!r} now (relative {abs(a - b) / max(abs(a), abs(b)):.2e})")


def compare(old: Path, new: Path, rtol: float) -> int:
    cmp = Comparison(rtol)
    before = {r["id"]: r for r in json.loads((old / "reproduce.json").read_text())}
    after = {r["id"]: r for r in json.loads((new / "reproduce.json").read_text())}
    for rid, rec in before.items():
        if rid not in after:
            cmp.failures.append(f"reproduce {rid}: missing")
            continue
        cmp.value(f"reproduce {rid}.computed", rec["computed"], after[rid]["computed"])
        cmp.value(f"reproduce {rid}.status", rec["status"], after[rid]["status"])
    for path in sorted((old / "summaries").glob("*.json")):
        other = new / "summaries" / path.name
        if not other.exists():
            cmp.failures.append(f"{path.stem}: no summary in the new numbers")
            continue
        a, b = json.loads(path.read_text()), json.loads(other.read_text())
        for key in a:
            if key not in PROVENANCE:
                cmp.value(f"{path.stem}.{key}", a[key], b.get(key))
    for path in sorted((old / "results").glob("*.json")):
        other = new / "results" / path.name
        if not other.exists():
            cmp.failures.append(f"{path.stem}: no results.h5 content in the new numbers")
            continue
        cmp.value(f"{path.stem} results.h5", json.loads(path.read_text()), json.loads(other.read_text()))
    for line in cmp.failures:
        print("DIFFERS  " + line)
    if cmp.added:
        print(f"{len(cmp.added)} new output keys (not compared), e.g. {', '.join(cmp.added[:5])}")
    print(f"{cmp.checked} values compared, {len(cmp.failures)} differ (relative tolerance {rtol:g})")
    return 1 if cmp.failures else 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    s = sub.add_parser("save", help="save every number into FOLDER")
    s.add_argument("folder", type=Path)
    s.add_argument("--scenario", action="append", help="only this scenario (repeatable)")
    s.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="run the scenarios with this override (repeatable; e2esim run --set), e.g. a smaller map")
    c = sub.add_parser("compare", help="compare two saves")
    c.add_argument("old", type=Path)
    c.add_argument("new", type=Path)
    c.add_argument("--rtol", type=float, default=1e-12)
    args = parser.parse_args(argv)
    if args.command == "save":
        save(args.folder, args.scenario, args.set)
        return 0
    return compare(args.old, args.new, args.rtol)


if __name__ == "__main__":
    sys.exit(main())
