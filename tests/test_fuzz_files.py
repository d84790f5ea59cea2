"""Structure-aware fuzzing of results.h5 and resume journals (issue 22): whatever a crafted file holds,
``open_results`` and ``compare`` (a results.h5) and ``--resume`` (a journal) end with the results or with a
one-line message, never with a traceback or a hang, and never show a byte of a file outside the crafted one.

Each example starts from real files of a quick run (tests/hostile_files.py) and applies a few seeded changes
where they hurt: a results.h5 gets datasets of other types and shapes, unwritten and compressed datasets,
gzip bombs, external storage pointing at a secret file, virtual datasets, soft and external links, odd
attributes and codes, YAML bombs and edits in the stored scenario, missing and extra members, truncation;
a journal gets its decoded records changed (values and classes of nodes swapped, fields dropped, array
dtypes and shapes, payload bytes, numbers of cases), frames dropped, repeated, torn or garbled, and its
manifest changed. A journal that is accepted is then used as a resumed run uses it: its cases' results,
summary, results.h5 and report. As in tests/test_fuzz_scenarios.py, Hypothesis draws one seed per example
and a seeded ``random.Random`` makes the changes; the default suite runs a fixed, derandomised budget and
``-m slow`` a larger one seeded by E2ESIM_TEST_SEED.
"""

from __future__ import annotations

import contextlib
import json
import random
import shutil
import struct
import tempfile
import zlib
from pathlib import Path

import h5py
import numpy as np
import pytest
from hostile_files import SECRET, hang_guard, make_journal, make_results
from hypothesis import HealthCheck, given, note, seed, settings
from hypothesis import strategies as st

from e2esim.errors import UserError, one_line
from helpers import TEST_SEED

HANG_S = 30
_FOLDER = Path(tempfile.mkdtemp(prefix="e2esim-fuzz-files-"))
_SECRET = _FOLDER / "outside.txt"
_SECRET.write_text((SECRET + "\n") * 50)


class _Made:
    """The real files, made once per process when the first example needs them."""

    results: Path | None = None
    read = None
    journal: tuple | None = None

    @classmethod
    def results_file(cls) -> Path:
        if cls.results is None:
            cls.results = make_results(_FOLDER / "good")
        return cls.results

    @classmethod
    def good_results(cls):
        import e2esim

        if cls.read is None:
            cls.read = e2esim.open_results(cls.results_file())
        return cls.read

    @classmethod
    def journal_run(cls) -> tuple:
        if cls.journal is None:
            scenario, resolved, out = make_journal(_FOLDER / "journal")
            cls.journal = (scenario, resolved, out / ".e2esim-partial")
        return cls.journal


def _expect_clean(exc: UserError, path: Path) -> None:
    message = one_line(exc)
    assert SECRET not in message and (str(path) in message or "journal" in message), message


# ============================================================================================ results.h5
TEXT = h5py.string_dtype()
SCENARIO_EDITS = [
    "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "\n".join(f"b{i}: &b{i} [" + ", ".join(
        [f"*{'a' if i == 0 else f'b{i - 1}'}"] * 10) + "]" for i in range(9)),
    "[" * 300 + "]" * 300, "x: !!python/object/apply:os.getcwd []", "- 1\n- 2", "", "{", "x: *nothing", "3",
    "sweep: {parameters: {scene.forest: {linspace: [0, 1, 5000001]}}}",
    "sweep: {parameters: {'a,b': [[1, 2], [3]]}}", "sweep: {cases: [{a: 1}, 7]}",
    "sweep: {map: {step_deg: 0.001}}", "sweep: {parameters: {scene.forest: []}}", "sweep: 5",
    "name: x\nsweep: {parameters: {instrument.crosstalk.level_db: [1, 2], scene.forest: [a, b]}, mode: zip}",
]
VALUES = [np.nan, np.inf, -np.inf, 1e308, -1, 0, 2**31, 255, 7, -(2**40)]


def _members(kind) -> list:
    """The paths of the datasets (or groups) of the real results.h5 (listed once: h5py is slow at it)."""
    if kind not in _MEMBERS:
        with h5py.File(_Made.results_file(), "r") as f:
            for cls in (h5py.Dataset, h5py.Group):
                _MEMBERS[cls] = []
                f.visititems(lambda name, obj, cls=cls: _MEMBERS[cls].append(name) if isinstance(obj, cls) else None)
    return _MEMBERS[kind]


_MEMBERS: dict = {}


def _new_data(rnd, old):
    """Data of another kind or shape than ``old``: (kwargs of create_dataset, post-creation action)."""
    shape = old.shape
    kind = rnd.randrange(16)
    n = shape[0] if shape else 1
    if kind == 0:
        return {"data": np.array(rnd.sample(VALUES, 1) * max(1, int(np.prod(shape)))).reshape(shape or ())}, None
    if kind == 1:
        return {"data": np.full(shape, rnd.choice([-1, 0, 1, 3, 200, 2**31 - 1]), dtype=rnd.choice(
            ["i1", "u1", "i4", "u8", "i8"]))}, None
    if kind == 2:
        return {"data": np.full(shape, rnd.choice(["", "x", "pass", "\udcff".encode("utf-8", "surrogatepass")
                                                   .decode("latin-1"), "é" * 300])), "dtype": TEXT}, None
    if kind == 3:
        return {"data": np.zeros(rnd.choice([(), (0,), (n + 1,), (n, 3), (1, 1, 1), (max(0, n - 1),)]))}, None
    if kind == 4:
        return {"data": np.zeros(shape, dtype=[("a", "f8"), ("b", "i4")])}, None
    if kind == 5:
        return {"data": np.zeros(shape, dtype=complex)}, None
    if kind == 6:
        return {"shape": rnd.choice([shape, (10**6,), (5_000_000, 2), (n, 10**7)]), "dtype": "f8",
                "chunks": True}, None
    if kind == 7 and shape:
        return {"data": np.ones(shape), "compression": "gzip", "shuffle": rnd.random() < 0.5,
                "fletcher32": rnd.random() < 0.5}, None
    if kind == 8 and shape:
        bomb = zlib.compress(bytes(rnd.choice([2**12, 2**20, 2**24])), 9)
        return {"shape": shape, "dtype": "f8", "chunks": shape, "compression": "gzip"}, \
            lambda ds: ds.id.write_direct_chunk((0,) * len(shape), bomb)
    if kind == 9 and shape:
        return {"data": np.ones(shape), "compression": "lzf"}, None
    if kind == 10:
        return {"shape": shape or (1,), "dtype": "S8", "external": [(str(_SECRET), 0, h5py.h5f.UNLIMITED)]}, None
    if kind == 11:
        return {"data": h5py.Empty("f8")}, None
    if kind == 12:
        return {"data": np.zeros(shape, dtype=bool)}, None
    if kind == 13 and old.dtype.kind in "iu":
        return {"data": np.random.default_rng(rnd.randrange(2**32)).integers(-3, 300, shape).astype(old.dtype)}, None
    if kind == 14:
        return {"data": np.full(shape, rnd.choice(VALUES), dtype=float)}, None
    return {"data": np.zeros(shape, dtype=rnd.choice(["f2", "f4", "i2", "u2"]))}, None


def _mutate_results(rnd, f) -> list:
    """Apply one change to the open file; return its description."""
    datasets, groups = _members(h5py.Dataset), _members(h5py.Group)
    action = rnd.randrange(10)
    name = rnd.choice(datasets)
    if action <= 2:
        old = f[name]
        kwargs, after = _new_data(rnd, old)
        attrs = dict(old.attrs)
        del f[name]
        ds = f.create_dataset(name, **kwargs)
        ds.attrs.update(attrs)
        if after is not None:
            after(ds)
        return [f"replace {name} ({sorted(kwargs)})"]
    if action == 3:
        del f[name]
        f[name] = rnd.choice([h5py.SoftLink("/" + rnd.choice(datasets)), h5py.SoftLink("/nowhere"),
                              h5py.ExternalLink(str(_Made.results_file()), name),
                              h5py.ExternalLink(str(_SECRET), "/x"), h5py.ExternalLink(str(_FOLDER / "no.h5"), name)])
        return [f"link {name}"]
    if action == 4:
        target = rnd.choice(datasets + groups + [""])
        key = rnd.choice(["units", "text", "n_cases", "scenario_name", "format_version", "description", "x"])
        value = rnd.choice([3, -1, 2**40, 1.5, "", "../x", "/cases", "nothing", "text_text", b"\xff\xfe",
                            np.arange(3), np.zeros(20_000, "u1"), "[" * 5000, json.dumps({"a": [1]})])
        obj = f[target] if target else f
        if rnd.random() < 0.2 and key in obj.attrs:
            del obj.attrs[key]
        else:
            obj.attrs[key] = value
        return [f"attribute {target or '/'}:{key} = {str(value)[:40]!r}"]
    if action == 5:
        text = rnd.choice(SCENARIO_EDITS)
        if rnd.random() < 0.5:  # an edit of the stored text itself
            old = f["provenance/resolved_scenario"][()].decode()
            pos = rnd.randrange(len(old) + 1)
            text = old[:pos] + rnd.choice(SCENARIO_EDITS + ["&a ", "*a", ": ", "\t", "- ", "!!binary "]) + old[pos:]
        del f["provenance/resolved_scenario"]
        f.create_dataset("provenance/resolved_scenario", data=text, dtype=TEXT)
        return [f"scenario {text[:60]!r}"]
    if action == 6:
        group = rnd.choice(groups)
        if rnd.random() < 0.5:
            del f[group]
            if rnd.random() < 0.5:
                f.create_dataset(group, data=np.zeros(4))
            return [f"delete group {group}"]
        member = f"{group}/{rnd.choice(['zz', 'x_text', '0', 'new'])}"
        if member not in f:
            data = rnd.choice([np.zeros(4), np.zeros((4, 2)), np.array(["a"] * 4, dtype=object)])
            f.create_dataset(member, data=data, dtype=None if rnd.random() < 0.7 else TEXT)
        return [f"add {member}"]
    if action == 7:
        del f[name]
        return [f"delete {name}"]
    if action == 8:
        other = f"/tmp_{rnd.randrange(10)}"
        with contextlib.suppress(Exception):
            other_file = h5py.File(_FOLDER / "vds_source.h5", "a")
            if "x" not in other_file:
                other_file["x"] = np.arange(4.0)
            other_file.close()
        layout = h5py.VirtualLayout(shape=(4,), dtype="f8")
        layout[:] = h5py.VirtualSource(str(_FOLDER / "vds_source.h5"), "x", shape=(4,))
        del f[name]
        f.create_virtual_dataset(name, layout)
        return [f"virtual {name} {other}"]
    return ["no change"]


def make_results_case(seed: int) -> tuple:
    """(path of a crafted results.h5, the changes made) from ``seed``."""
    rnd = random.Random(seed)
    path = _FOLDER / "crafted.h5"
    path.write_bytes(_Made.results_file().read_bytes())
    changes = []
    with h5py.File(path, "r+") as f:
        for _ in range(rnd.randint(1, 3)):
            try:
                changes += _mutate_results(rnd, f)
            except Exception as exc:  # h5py or numpy refused to make it: the file holds the changes before
                changes.append(f"(not made: {type(exc).__name__})")
    if rnd.random() < 0.05:
        data = path.read_bytes()
        path.write_bytes(data[: rnd.randrange(len(data))])
        changes.append("truncated")
    return path, changes


def check_results(path: Path) -> None:
    import e2esim
    from e2esim.io.compare import compare_report

    with hang_guard(HANG_S):
        try:
            results = e2esim.open_results(path)
        except UserError as exc:
            _expect_clean(exc, path)
            return
        text, _ = compare_report(results, _Made.good_results(), str(path), "good")
        shown = text + repr(results.inputs) + repr(results.label_list()) + repr(results.provenance)
        assert SECRET not in shown
        results.to_dataframe()
        try:
            results.to_xarray()
        except UserError:
            pass


COMMON = dict(deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
SEEDS = st.integers(min_value=0, max_value=2**64 - 1)


@settings(max_examples=250, derandomize=True, **COMMON)
@given(case_seed=SEEDS)
def test_crafted_results_files_end_cleanly(case_seed):
    path, changes = make_results_case(case_seed)
    note(f"changes: {changes}")
    check_results(path)


@pytest.mark.slow
@seed(TEST_SEED)
@settings(max_examples=3000, **COMMON)
@given(case_seed=SEEDS)
def test_crafted_results_files_end_cleanly_large_budget(case_seed):
    path, changes = make_results_case(case_seed)
    note(f"changes: {changes}")
    check_results(path)


# ============================================================================================== journals
FRAME = struct.Struct("<4sQQQI")
DTYPES = ["<f8", "<f4", "<i8", "<i4", "|u1", "|b1", "<c16", "<U3", "|S2", "<M8[s]", "|S0", "|O", "<V8", "x"]
NODES = [None, 0, -1, 1, 2**70, 1.5, "x", "", [], {}, {"$": "x"}, {"$": "a", "a": 0, "id": 9001},
         {"$": "a", "a": 999}, {"$": "r", "r": 0}, {"$": "r", "r": 99999}, {"$": "l", "i": [], "id": 9002},
         {"$": "t", "i": [1, "a"]}, {"$": "d", "i": [[1, 2]], "id": 9003}, {"$": "s", "i": [[1]]},
         {"$": "oa", "s": [2**40, 8], "i": []}, {"$": "oa", "s": [1], "i": [1], "id": 9004},
         {"$": "f", "v": "nan"}, {"$": "c", "v": ["1", "x"]}, {"$": "dt", "v": "2026-13-01"},
         {"$": "td", "v": [10**12, 0, 0]}, {"$": "o", "c": "builtins:eval", "f": [], "id": 9005},
         {"$": "o", "c": "e2esim.runner.columns:Column", "f": [], "id": 9006},
         {"$": "mp", "i": [["a", 1]]}, {"$": "n", "a": 0}]


def _nodes(tree) -> list:
    """Every (container, key) in a decoded record tree."""
    out, stack = [], [tree]
    while stack:
        node = stack.pop()
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        for key, value in items:
            out.append((node, key))
            stack.append(value)
    return out


def _mutate_record(rnd, doc: dict, payload: bytes) -> tuple:
    """One change of a decoded record: (payload, description)."""
    nodes = _nodes(doc["tree"])
    objects = [node for node, key in nodes if isinstance(node, dict) and node.get("$") == "o" and key == "c"]
    classes = sorted({o["c"] for o in objects if isinstance(o["c"], str)})
    action = rnd.randrange(9)
    if action == 7:  # every float array, or one, set to one awkward value: zeros, NaN, infinities
        value, data, pos = rnd.choice(VALUES), bytearray(payload), 0
        every = rnd.random() < 0.5
        for spec in doc["arrays"]:
            size = int(np.prod(spec[1])) * np.dtype(spec[0]).itemsize
            if spec[0] == "<f8" and (every or rnd.random() < 0.2):
                data[pos:pos + size] = np.full(size // 8, value).tobytes()
            pos += size
        return bytes(data), f"floats = {value}"
    if action == 0:
        node, key = rnd.choice(nodes)
        node[key] = json.loads(json.dumps(rnd.choice(NODES)))
        return payload, f"node {key!r} = {str(node[key])[:60]}"
    if action == 1 and objects:
        obj = rnd.choice(objects)
        obj["c"] = rnd.choice(classes + ["e2esim.case:Products", "e2esim.block:Values", "e2esim.errors:Location"])
        return payload, f"class {obj['c']}"
    if action == 2 and objects:
        obj = rnd.choice(objects)
        if obj["f"]:
            k = rnd.randrange(len(obj["f"]))
            change = rnd.randrange(3)
            if change == 0:
                del obj["f"][k]
            elif change == 1:
                obj["f"][k][0] = rnd.choice(["x", "_values", "values", "index", "__class__", "1a"])
            else:
                obj["f"].append(obj["f"][k])
        return payload, "field changed"
    if action == 3 and doc["arrays"]:
        spec = rnd.choice(doc["arrays"])
        if rnd.random() < 0.5:
            spec[0] = rnd.choice(DTYPES)
        else:
            spec[1] = rnd.choice([[], [0], [1], [2], [3], [0, 2**61], [2**40], spec[1] + [1], spec[1][:-1],
                                  [d + 1 for d in spec[1]], [1] * 40])
        return payload, f"array spec {spec}"
    if action == 4 and payload:
        data = bytearray(payload)
        for _ in range(rnd.randint(1, 8)):
            pos = rnd.randrange(len(data))
            data[pos:pos + 8] = struct.pack("<d", rnd.choice(VALUES + [rnd.uniform(-1e9, 1e9)]))[: len(data) - pos]
        return bytes(data), "payload numbers"
    if action == 5:
        cut = rnd.randrange(len(payload) + 1)
        return payload[:cut] + bytes(rnd.randrange(16)), "payload length"
    if action == 6:
        node, key = rnd.choice(nodes)
        other, other_key = rnd.choice(nodes)
        node[key], other[other_key] = other[other_key], node[key]
        return payload, "subtrees swapped"
    return payload, "no change"


def _frames(data: bytes) -> list:
    out, pos = [], 0
    while pos < len(data):
        _, count, n_header, n_payload, _ = FRAME.unpack_from(data, pos)
        start = pos + FRAME.size
        end = start + n_header + n_payload
        out.append([count, json.loads(data[start:start + n_header]), data[start + n_header:end]])
        pos = end
    return out


def _frame(count, doc, payload) -> bytes:
    header = json.dumps(doc).encode()
    crc = zlib.crc32(payload, zlib.crc32(header))
    return FRAME.pack(b"E2J2", count, len(header), len(payload), crc) + header + payload


def make_journal_case(seed: int) -> tuple:
    """(output folder holding a crafted journal, changes) from ``seed``."""
    rnd = random.Random(seed)
    _, _, source = _Made.journal_run()
    out = _FOLDER / "resume"
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(source, out / ".e2esim-partial")
    records, manifest = out / ".e2esim-partial" / "cases.journal", out / ".e2esim-partial" / "manifest.json"
    frames = _frames(records.read_bytes())
    changes = []
    for _ in range(rnd.randint(1, 3)):
        if not frames:
            break
        k = rnd.randrange(len(frames))
        kind = rnd.randrange(10)
        if kind <= 5:
            try:
                frames[k][2], what = _mutate_record(rnd, frames[k][1], frames[k][2])
            except Exception as exc:  # an earlier change left a node this one cannot take: not made
                what = f"(not made: {type(exc).__name__})"
        elif kind == 6:
            frames[k][0] = rnd.choice([0, 1, 2, 3, 2**63])
            what = f"count {frames[k][0]}"
        elif kind == 7:
            choice = rnd.randrange(3)
            frames = ([f for i, f in enumerate(frames) if i != k] if choice == 0 else
                      frames + [frames[k]] if choice == 1 else frames[::-1])
            what = ["drop", "repeat", "reverse"][choice] + " frames"
        elif kind == 8:
            try:
                doc = json.loads(manifest.read_text())
            except (ValueError, RecursionError):  # changed before
                doc = {}
            doc = doc if isinstance(doc, dict) else {}
            key = rnd.choice(["fingerprint", "version", "format", "cases"])
            doc[key] = rnd.choice([None, 3, "x", [], 10**30])
            manifest.write_text(rnd.choice([json.dumps(doc), "[" * 10_000, "{", json.dumps(doc) * 2]))
            what = f"manifest {key}"
        else:
            what = "no change"
        changes.append(what)
    data = b"".join(_frame(*f) for f in frames)
    tail = rnd.random()
    if tail < 0.1:
        data = data[: rnd.randrange(len(data) + 1)]
        changes.append("torn")
    elif tail < 0.15:
        data += bytes(rnd.randrange(100))
        changes.append("garbage appended")
    elif tail < 0.2 and data:
        pos = rnd.randrange(len(data))
        data = data[:pos] + bytes([data[pos] ^ 0xFF]) + data[pos + 1:]
        changes.append("a byte flipped")
    records.write_bytes(data)
    return out, changes


def check_journal(out: Path) -> None:
    from e2esim.io.results_h5 import write_results
    from e2esim.io.summary import summary_json
    from e2esim.report.document import build_report
    from e2esim.report.render import to_markdown
    from e2esim.results import results_of
    from e2esim.runner.journal import Journal
    from e2esim.runner.run import ScenarioResult, run_scenario

    _, resolved, _ = _Made.journal_run()
    with hang_guard(HANG_S):
        try:
            blocks = Journal(out, resolved).start(resume=True)
        except UserError as exc:
            _expect_clean(exc, out)
            return
        covered = sum(len(b) for b in blocks)
        if covered == len(resolved.cases):
            result = ScenarioResult(resolved, sorted(blocks, key=lambda b: int(b.indices[0])))
        else:
            result = run_scenario(resolved, progress=False, finished=blocks)
        results_of(result)
        summary_json(result)
        write_results(result, out / "results.h5")
        to_markdown(build_report(result, [], []))


@settings(max_examples=250, derandomize=True, **COMMON)
@given(case_seed=SEEDS)
def test_crafted_journals_end_cleanly(case_seed):
    out, changes = make_journal_case(case_seed)
    note(f"changes: {changes}")
    check_journal(out)


@pytest.mark.slow
@seed(TEST_SEED)
@settings(max_examples=3000, **COMMON)
@given(case_seed=SEEDS)
def test_crafted_journals_end_cleanly_large_budget(case_seed):
    out, changes = make_journal_case(case_seed)
    note(f"changes: {changes}")
    check_journal(out)
