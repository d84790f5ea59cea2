"""Structure-aware fuzzing of results.h5 files (issue 22): whatever a crafted results.h5 holds, ``open_results``
and ``compare`` end with the results or with a one-line message, never with a traceback or a hang, and never show
a byte of a file outside the crafted one.

Each example starts from the results.h5 of a quick run (tests/hostile_files.py) and applies a few seeded changes
where they hurt: datasets of other types and shapes, unwritten and compressed datasets, gzip bombs, external
storage pointing at a secret file, virtual datasets, soft and external links, odd attributes and codes, YAML
bombs and edits in the stored scenario, missing and extra members, truncation. An accepted file is compared
with the real one and turned into a data frame and an xarray Dataset. As in tests/test_fuzz_scenarios.py,
Hypothesis draws one seed per example and a seeded ``random.Random`` makes the changes; the default suite runs a
fixed, derandomised budget (with tests/test_fuzz_journals.py, 500 examples) and ``-m slow`` a larger one seeded
by E2ESIM_TEST_SEED.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import random
import zlib
from pathlib import Path

import h5py
import numpy as np
import pytest
from hostile_files import COMMON, FUZZ_FOLDER, SECRET, SECRET_FILE, SEEDS, expect_clean, hang_guard, make_results
from hypothesis import given, note, seed, settings

from e2esim.errors import UserError
from helpers import TEST_SEED

HANG_S = 30
_FOLDER = FUZZ_FOLDER
_SECRET = SECRET_FILE


class _Made:
    """The real file, made once per process when the first example needs it."""

    results: Path | None = None
    read = None
    data: bytes | None = None

    @classmethod
    def results_file(cls) -> Path:
        if cls.results is None:
            cls.results = make_results(_FOLDER / "good")
        return cls.results

    @classmethod
    def results_bytes(cls) -> bytes:
        """The real file's bytes, read once (each example starts from them)."""
        if cls.data is None:
            cls.data = cls.results_file().read_bytes()
        return cls.data

    @classmethod
    def good_results(cls):
        import e2esim

        if cls.read is None:
            cls.read = e2esim.open_results(cls.results_file())
        return cls.read

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
    path.write_bytes(_Made.results_bytes())
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
    from e2esim.compare import compare_report

    with hang_guard(HANG_S):
        try:
            results = e2esim.open_results(path)
        except UserError as exc:
            expect_clean(exc, path)
            return
        text, _ = compare_report(results, _Made.good_results(), str(path), "good")
        shown = text + repr(results.inputs) + repr(results.label_list()) + repr(results.provenance)
        assert SECRET not in shown
        results.to_dataframe()
        try:
            results.to_xarray()
        except UserError:
            pass




_CHECKED_CLEAN: set = set()
"""Digests of the crafted files this process has already seen end cleanly: about one example in thirteen crafts,
byte for byte, a file an earlier example made (its changes were not made or changed nothing), and the same bytes
take the same path. A file that failed is never added, so Hypothesis's replay of a failing example checks it
again."""


def check_results_once(path: Path) -> None:
    """``check_results(path)``, unless this process has checked the same bytes clean before."""
    digest = hashlib.sha256(path.read_bytes()).digest()
    if digest not in _CHECKED_CLEAN:
        check_results(path)
        _CHECKED_CLEAN.add(digest)


@settings(max_examples=250, derandomize=True, **COMMON)
@given(case_seed=SEEDS)
def test_crafted_results_files_end_cleanly(case_seed):
    path, changes = make_results_case(case_seed)
    note(f"changes: {changes}")
    check_results_once(path)


@pytest.mark.slow
@seed(TEST_SEED)
@settings(max_examples=3000, **COMMON)
@given(case_seed=SEEDS)
def test_crafted_results_files_end_cleanly_large_budget(case_seed):
    path, changes = make_results_case(case_seed)
    note(f"changes: {changes}")
    check_results_once(path)
