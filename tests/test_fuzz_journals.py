"""Structure-aware fuzzing of resume journals (issue 22): whatever a crafted journal holds, ``e2esim run
--resume`` resumes from it or ends with a one-line message, never with a traceback or a hang.

Each example starts from the journal of a quick run (tests/hostile_files.py: two blocks with every product
kept) and applies a few seeded changes where they hurt: its decoded records changed (nodes replaced, classes
swapped, fields dropped, renamed or repeated, array dtypes and shapes, payload numbers, every float set to an
awkward value, subtrees swapped), the numbers of cases, frames dropped, repeated, reordered, torn or garbled,
and its manifest. A journal that is accepted is then used as a resumed run uses it: its cases' results,
summary, results.h5 and report. As in tests/test_fuzz_scenarios.py, Hypothesis draws one seed per example and a
seeded ``random.Random`` makes the changes; the default suite runs a fixed, derandomised budget (with
tests/test_fuzz_results.py, 500 examples) and ``-m slow`` a larger one seeded by E2ESIM_TEST_SEED.
"""

from __future__ import annotations

import hashlib
import json
import random
import struct
import warnings
import zlib
from itertools import repeat
from pathlib import Path

import numpy as np
import pytest
from hostile_files import COMMON, FUZZ_FOLDER, SEEDS, expect_clean, hang_guard, make_journal
from hypothesis import given, note, seed, settings

from e2esim.errors import UserError
from helpers import TEST_SEED

HANG_S = 30
_FOLDER = FUZZ_FOLDER
VALUES = [np.nan, np.inf, -np.inf, 1e308, -1, 0, 2**31, 255, 7, -(2**40)]


class _Made:
    """The real journal, made once per process when the first example needs it."""

    journal: tuple | None = None
    files: tuple | None = None

    @classmethod
    def journal_run(cls) -> tuple:
        if cls.journal is None:
            scenario, resolved, out = make_journal(_FOLDER / "journal")
            cls.journal = (scenario, resolved, out / ".e2esim-partial")
        return cls.journal

    @classmethod
    def journal_files(cls) -> tuple:
        """(manifest.json, cases.journal) of the real journal, as bytes, read once (each example starts from them)."""
        if cls.files is None:
            source = cls.journal_run()[2]
            cls.files = ((source / "manifest.json").read_bytes(), (source / "cases.journal").read_bytes())
        return cls.files

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
    """Every (container, key) in a decoded record tree (JSON: its containers are exactly dicts and lists), depth
    first, the last child first. Only containers go on the stack (a scalar has no children to list): a record
    holds thousands of nodes, and this walk was a third of the test's time."""
    out, stack = [], [tree]
    while stack:
        node = stack.pop()
        if type(node) is dict:
            out += zip(repeat(node), node)
            stack += [value for value in node.values() if type(value) in _CONTAINERS]
        elif type(node) is list:
            out += zip(repeat(node), range(len(node)))
            stack += [value for value in node if type(value) in _CONTAINERS]
    return out


_CONTAINERS = (dict, list)


def _mutate_record(rnd, doc: dict, payload: bytes) -> tuple:
    """One change of a decoded record: (payload, description)."""
    nodes = _nodes(doc["tree"])
    objects = [node for node, key in nodes if key == "c" and type(node) is dict and node.get("$") == "o"]
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
    """[[cases, header (bytes until a change parses it), payload]] of a records file."""
    out, pos = [], 0
    while pos < len(data):
        _, count, n_header, n_payload, _ = FRAME.unpack_from(data, pos)
        start = pos + FRAME.size
        end = start + n_header + n_payload
        out.append([count, data[start:start + n_header], data[start + n_header:end]])
        pos = end
    return out


def _frame(count, doc, payload) -> bytes:
    header = doc if isinstance(doc, bytes) else json.dumps(doc).encode()
    crc = zlib.crc32(payload, zlib.crc32(header))
    return FRAME.pack(b"E2J2", count, len(header), len(payload), crc) + header + payload


def make_journal_case(seed: int) -> tuple:
    """(output folder holding a crafted journal, changes) from ``seed``."""
    rnd = random.Random(seed)
    manifest_bytes, journal_bytes = _Made.journal_files()
    out = _FOLDER / "resume"
    (out / ".e2esim-partial").mkdir(parents=True, exist_ok=True)
    records, manifest = out / ".e2esim-partial" / "cases.journal", out / ".e2esim-partial" / "manifest.json"
    manifest.write_bytes(manifest_bytes)
    frames = _frames(journal_bytes)
    changes = []
    for _ in range(rnd.randint(1, 3)):
        if not frames:
            break
        k = rnd.randrange(len(frames))
        kind = rnd.randrange(10)
        if kind <= 5:
            try:
                if isinstance(frames[k][1], bytes):
                    frames[k][1] = json.loads(frames[k][1])
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
    from e2esim.results import Results
    from e2esim.runner.journal import Journal
    from e2esim.runner.run import ScenarioResult, run_scenario

    _, resolved, _ = _Made.journal_run()
    with hang_guard(HANG_S), warnings.catch_warnings():
        try:
            blocks = list(Journal(out, resolved).start(resume=True))  # an iterator: records are checked as read
        except UserError as exc:
            expect_clean(exc, out)
            return
        # crafted numbers (infinities, NaN) may make numpy warn while the outputs are made: wrong numbers at
        # worst, which is what a journal can do (docs/security.md); the test suite turns warnings into errors
        warnings.simplefilter("ignore", RuntimeWarning)
        covered = sum(len(b) for b in blocks)
        if covered == len(resolved.cases):
            result = ScenarioResult(resolved, sorted(blocks, key=lambda b: int(b.indices[0])))
        else:
            result = run_scenario(resolved, progress=False, finished=blocks)
        Results.from_run(result)
        summary_json(result)
        write_results(result, out / "results.h5")
        to_markdown(build_report(result, [], []))


_CHECKED_CLEAN: set = set()
"""Digests of the crafted journals (records and manifest, read before the check: a resume cuts a torn record off)
this process has already seen end cleanly. About one example in twelve crafts, byte for byte, a journal an earlier
example made (most often the real one: its changes were not made or changed nothing), and the same bytes take the
same path. A journal that failed is never added, so Hypothesis's replay of a failing example checks it again."""


def check_journal_once(out: Path) -> None:
    """``check_journal(out)``, unless this process has checked the same bytes clean before."""
    partial = out / ".e2esim-partial"
    records = (partial / "cases.journal").read_bytes()
    digest = hashlib.sha256(len(records).to_bytes(8, "little") + records
                            + (partial / "manifest.json").read_bytes()).digest()
    if digest not in _CHECKED_CLEAN:
        check_journal(out)
        _CHECKED_CLEAN.add(digest)


@settings(max_examples=250, derandomize=True, **COMMON)
@given(case_seed=SEEDS)
def test_crafted_journals_end_cleanly(case_seed):
    out, changes = make_journal_case(case_seed)
    note(f"changes: {changes}")
    check_journal_once(out)


@pytest.mark.slow
@seed(TEST_SEED)
@settings(max_examples=3000, **COMMON)
@given(case_seed=SEEDS)
def test_crafted_journals_end_cleanly_large_budget(case_seed):
    out, changes = make_journal_case(case_seed)
    note(f"changes: {changes}")
    check_journal_once(out)
