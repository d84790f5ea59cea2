"""Finished blocks kept on disk (``e2esim.runner.spill``, issue 14: memory bounded by the block size): a run whose
blocks are spilled gives exactly the columns, verdicts, cases and results.h5 of one that keeps them in memory."""

from __future__ import annotations

import os

import numpy as np
import pytest
import yaml
from test_batched_engine import SWEEP

from e2esim import open_results
from e2esim.io.results_h5 import write_results
from e2esim.runner import run as run_module
from e2esim.runner.run import BlockResult, ScenarioResult, run_block, run_scenario
from e2esim.runner.scenario import Scenario
from e2esim.runner.spill import SpilledBlock, SpillFile, spill_block

FIELDS = ("name", "passed", "value", "limit", "margin", "unit", "basis", "dominant", "notes", "applicable", "reason",
          "coverage", "coverage_text")


def _resolved():
    return Scenario(yaml.safe_load(SWEEP), "spill.yaml").resolve()


def _same(a, b) -> bool:
    """Equal arrays (NaN equal to NaN) or equal lists of values."""
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
    if isinstance(a, np.floating):  # a not-applicable verdict's passed and margin scalars are NaN
        return bool(a == b or (np.isnan(a) and np.isnan(b)))
    return a == b


def assert_same_tables(got, expected) -> None:
    assert got.n == expected.n and list(got.scalars) == list(expected.scalars)
    for name in expected.scalars:
        assert _same(got.scalar(name), expected.scalar(name)), name
        assert _same(got.has(name), expected.has(name)), name
    assert got.notes.tolist() == expected.notes.tolist() and got.groups.tolist() == expected.groups.tolist()
    assert len(got.requirements) == len(expected.requirements) == 3
    for j, (r, s) in enumerate(zip(got.requirements, expected.requirements)):
        for f in FIELDS:
            x, y = getattr(r, f), getattr(s, f)
            assert _same(x, y) if isinstance(y, np.ndarray) else x.tolist() == y.tolist(), (j, f)
        assert list(r.details) == list(s.details)
        for key in s.details:
            assert _same(got.detail(j, key), expected.detail(j, key)), (j, key)
        assert _same(got.applies(j), expected.applies(j))
        if s.curves is None:
            assert r.curves is None
        else:
            for x, y in zip(r.curves.tolist(), s.curves.tolist()):
                assert list(x) == list(y) and all(_same(x[k], y[k]) for k in y)


def assert_same_cases(got, expected) -> None:
    assert len(got) == len(expected)
    for a, b in zip(got, expected):
        assert (a.index, a.label, a.inputs, a.notes, a.groups) == (b.index, b.label, b.inputs, b.notes, b.groups)
        assert list(a.scalars) == list(b.scalars)
        assert all(_same(np.float64(a.scalars[k]), np.float64(b.scalars[k])) for k in b.scalars)
        for v, w in zip(a.verdicts, b.verdicts):
            assert (v.name, v.status, v.reason, v.unit, v.basis, v.dominant, v.notes, v.coverage) == (
                w.name, w.status, w.reason, w.unit, w.basis, w.dominant, w.notes, w.coverage)
            assert _same(np.array([v.value, v.limit, v.margin]), np.array([w.value, w.limit, w.margin]))
            assert list(v.details) == list(w.details) and list(v.curves) == list(w.curves)


def test_a_spill_file_gives_back_each_array_as_written_and_refuses_what_is_not_numeric(tmp_path):
    spill = SpillFile(tmp_path)
    arrays = [np.array([1.5, np.nan, -np.inf]), np.array([True, False]), np.arange(12, dtype=np.int32).reshape(3, 4),
              np.zeros(0), np.arange(7, dtype=np.int64)[::2]]  # strided: written contiguously
    refs = [spill.put(a) for a in arrays]
    for a, ref in reversed(list(zip(arrays, refs))):  # any order
        back = spill.get(ref)
        assert back.dtype == a.dtype and back.shape == a.shape and _same(back, a)
        back[...] = 0  # a copy of its own, writable
    assert _same(spill.get(refs[0]), arrays[0])
    with pytest.raises(TypeError, match="only numeric arrays are spilled, not object"):
        spill.put(np.array(["a", None], dtype=object))
    if os.name == "posix":  # an unnamed file: a killed run leaves nothing behind
        assert list(tmp_path.iterdir()) == []
    spill.close()



def test_rows_written_one_after_the_other_read_back_as_the_stacked_array(tmp_path):
    """``put_rows`` (a block's columns, without stacking them first) lays them out as ``put(np.stack(rows))``."""
    spill = SpillFile(tmp_path)
    rows = [np.array([1.0, np.nan, 3.0]), np.arange(9.0)[::3], np.array([-0.0, np.inf, 2.5])]
    before = spill.put(np.array([7, 8], dtype=np.int16))  # an array before: offsets count from it
    ref = spill.put_rows(rows)
    stacked = spill.put(np.stack(rows))
    assert ref.shape == stacked.shape == (3, 3) and ref.dtype == stacked.dtype
    assert _same(spill.get(ref), np.stack(rows)) and _same(spill.get(before), np.array([7, 8], dtype=np.int16))
    assert stacked.offset - ref.offset == np.stack(rows).nbytes
    with pytest.raises(TypeError, match="one dtype and shape"):
        spill.put_rows([np.zeros(3), np.zeros(4)])
    spill.close()

def test_a_spilled_run_gives_the_numbers_cases_and_results_file_of_one_kept_in_memory(tmp_path):
    resolved = _resolved()
    memory = run_scenario(resolved, progress=False, keep_products=False, spill=False)
    disk = run_scenario(resolved, progress=False, keep_products=False, spill=True, spill_folder=tmp_path)
    assert all(isinstance(b, BlockResult) for b in memory.blocks)
    assert all(isinstance(b, SpilledBlock) for b in disk.blocks) and disk.blocks
    assert_same_tables(disk.table, memory.table)
    assert_same_cases(disk.cases, memory.cases)
    for result, name in ((memory, "memory.h5"), (disk, "disk.h5")):
        write_results(result, tmp_path / name)
    a, b = open_results(tmp_path / "memory.h5"), open_results(tmp_path / "disk.h5")
    assert a.to_dataframe().equals(b.to_dataframe())
    assert _same(a.margin, b.margin) and _same(a.passed, b.passed)


def test_blocks_of_consecutive_or_interleaved_cases_read_back_in_case_order(tmp_path):
    resolved = _resolved()
    expected = run_scenario(resolved, progress=False, keep_products=False, spill=False)
    spill = SpillFile(tmp_path)
    odd, even = np.arange(1, 24, 2), np.arange(0, 24, 2)  # interleaved: no block is a run of consecutive cases
    blocks = [spill_block(run_block(resolved, cases), spill) for cases in (even, odd)]
    interleaved = ScenarioResult(resolved, blocks)
    assert_same_tables(interleaved.table, expected.table)
    assert_same_cases(interleaved.cases, expected.cases)
    assert [interleaved.cases[i].index for i in (23, 0, 12)] == [23, 0, 12]


def test_a_run_spills_its_blocks_when_it_has_more_cases_than_the_limit(monkeypatch, tmp_path):
    resolved = _resolved()  # 24 cases
    monkeypatch.setattr(run_module, "SPILL_ABOVE_CASES", 23)
    spilled = run_scenario(resolved, progress=False, keep_products=False, spill_folder=tmp_path)
    assert all(isinstance(b, SpilledBlock) for b in spilled.blocks)
    monkeypatch.setattr(run_module, "SPILL_ABOVE_CASES", 24)
    assert all(isinstance(b, BlockResult) for b in run_scenario(resolved, progress=False, keep_products=False).blocks)
    with pytest.raises(ValueError, match="keeps its cases' products keeps its blocks in memory"):
        run_scenario(resolved, progress=False, keep_products=True, spill=True)


def test_a_forked_reader_and_this_process_read_the_spill_at_once(tmp_path):
    # the report's plots are drawn by this process and a forked helper at once, both reading the run's spill file:
    # they share its open file, so a read must not go through the file's shared offset (seek, then read), or one
    # process reads where the other has just sought (a 1 deg map's plot read another array's bytes as indices)
    import multiprocessing

    spill = SpillFile(tmp_path)
    refs = [spill.put(np.full(20_000, k, dtype=np.int64)) for k in range(8)]
    fd = spill._file.fileno()
    before = os.lseek(fd, 0, os.SEEK_CUR)
    spill.get(refs[3])
    assert os.lseek(fd, 0, os.SEEK_CUR) == before  # a positional read leaves the shared offset alone

    def read_many(out):
        bad = sum(int(np.any(spill.get(refs[k % 8]) != k % 8)) for k in range(400))
        out.put(bad)

    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=read_many, args=(queue,))
    child.start()
    read_many(queue)
    child.join()
    assert queue.get() == 0 and queue.get() == 0
