"""The resume journal and the climatology cache are plain data (issue 15, defect 1): a planted payload in
either never runs, a corrupt or foreign journal is exit status 2, and what the journal stores comes back
exactly."""

import datetime as dt
import gc
import json
import pickle
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from test_parallel_and_resume import _scenario as _sweep

from e2esim.cli import main
from e2esim.errors import JournalError
from e2esim.runner import plaindata
from e2esim.runner.journal import JOURNAL, Journal, count_finished
from e2esim.runner.run import run_block, run_scenario
from e2esim.runner.scenario import Scenario


class Payload:
    """Unpickling this writes a marker file: proof that a file's content ran as code."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (Path.write_text, (Path(self.marker), "pwned"))


@pytest.fixture
def scenario(tmp_path):
    return _sweep(tmp_path, looks=500, realisations=200)


def _run(scenario, out, *extra, capsys=None):
    status = main(["run", str(scenario), "-o", str(out), "--no-progress", *extra])
    err = capsys.readouterr().err if capsys else ""
    return status, err


def _plant_old_pickle_journal(out: Path, marker: Path) -> None:
    journal = out / JOURNAL
    journal.mkdir(parents=True)
    (journal / "manifest.json").write_text(json.dumps({"fingerprint": "x"}))
    data = pickle.dumps(Payload(marker))
    (journal / "cases.journal").write_bytes(struct.pack("<Q", len(data)) + data)


@pytest.mark.parametrize("flags", [(), ("--resume",), ("--force",)])
def test_a_planted_pickle_journal_never_runs(scenario, tmp_path, capsys, flags):
    out, marker = tmp_path / "out", tmp_path / "MARKER"
    _plant_old_pickle_journal(out, marker)
    status, err = _run(scenario, out, *flags, capsys=capsys)
    assert not marker.exists()
    if flags == ("--force",):  # discarded unread, the run goes on
        assert status == 0 and (out / "summary.json").exists() and not (out / JOURNAL).exists()
    else:
        assert status == 2 and "the resume journal is corrupt or foreign" in err and "--force" in err
        assert err.count("\n") == 1


def _valid_journal(scenario, out) -> tuple:
    resolved = Scenario.load(scenario).resolve()
    journal = Journal(out, resolved)
    journal.start(resume=False)
    blocks = [run_block(resolved, [0, 1], keep_products=True), run_block(resolved, [2], keep_products=True)]
    for block in blocks:
        journal.record(block)
    journal.close()
    return resolved, blocks


def _frame(cases: int, header: bytes, payload: bytes = b"") -> bytes:
    crc = zlib.crc32(payload, zlib.crc32(header))
    return struct.pack("<4sQQQI", b"E2J2", cases, len(header), len(payload), crc) + header + payload


@pytest.mark.parametrize("record", ["pickle", "foreign class", "bad json", "bad checksum", "wrong case", "bad dtype"])
def test_a_corrupt_record_in_a_valid_journal_is_exit_2(scenario, tmp_path, capsys, record):
    out, marker = tmp_path / "out", tmp_path / "MARKER"
    _valid_journal(scenario, out)
    records = out / JOURNAL / "cases.journal"
    good = records.read_bytes()
    header = {"tree": {"$": "o", "c": "os:_wrap_close", "f": [], "id": 0}, "arrays": []}
    planted = {
        "pickle": pickle.dumps(Payload(marker)),
        "foreign class": _frame(2, json.dumps(header).encode()),
        "bad json": _frame(2, b"{not json"),
        "bad checksum": _frame(2, b"{}")[:-2] + b"}}",
        "wrong case": b"",  # below: the first block again, claiming another number of cases
        "bad dtype": _frame(2, json.dumps({"tree": {"$": "a", "a": 0, "id": 0}, "arrays": [["|O", [1]]]}).encode(),
                            b"\0" * 8),
    }[record]
    if record == "wrong case":  # a valid record of cases 0 and 1 presented as a block of 3 cases
        first = good[: struct.calcsize("<4sQQQI") + sum(struct.unpack_from("<4sQQQI", good)[2:4])]
        planted = first[:4] + struct.pack("<Q", 3) + first[12:]
    records.write_bytes(good + planted)
    status, err = _run(scenario, out, "--resume", capsys=capsys)
    assert status == 2 and "the resume journal is corrupt or foreign" in err, err
    assert err.count("\n") == 1 and not marker.exists()


def test_foreign_manifest_is_exit_2(scenario, tmp_path, capsys):
    out = tmp_path / "out"
    _valid_journal(scenario, out)
    (out / JOURNAL / "manifest.json").write_text(json.dumps({"format": "e2esim-journal", "version": 99}))
    status, err = _run(scenario, out, "--resume", capsys=capsys)
    assert status == 2 and "journal version 99" in err
    with pytest.raises(JournalError, match="it is not an e2esim journal"):
        (out / JOURNAL / "manifest.json").write_text("[1, 2]")
        count_finished(out)


def test_journal_records_come_back_exactly(scenario, tmp_path):
    out = tmp_path / "out"
    resolved, blocks = _valid_journal(scenario, out)
    finished = list(Journal(out, resolved).start(resume=True))
    assert [list(b.indices) for b in finished] == [[0, 1], [2]]
    for block, back in zip(blocks, finished):
        for k in range(len(block)):
            r, got = block.case(k, {}, ""), back.case(k, {}, "")
            assert got.scalars == r.scalars and got.verdicts == r.verdicts and got.notes == r.notes
            assert list(got.products) == list(r.products)
            samples = got.get("backscatter.error").samples()
            assert samples.size > 100 and np.array_equal(samples, r.get("backscatter.error").samples())
    resumed = run_scenario(resolved, progress=False, finished=finished)
    fresh = run_scenario(resolved, progress=False)
    assert [c.scalars for c in resumed.cases] == [c.scalars for c in fresh.cases]


def test_journal_is_created_with_the_first_finished_block(scenario, tmp_path):
    resolved = Scenario.load(scenario).resolve()
    journal = Journal(tmp_path / "out", resolved)
    assert journal.start(resume=False) == []
    assert not (tmp_path / "out" / JOURNAL).exists()


def test_plain_data_round_trip_keeps_values_types_and_sharing():
    shared = np.arange(6, dtype=np.int32).reshape(2, 3)
    frozen = np.linspace(0, 1, 4)
    frozen.flags.writeable = False
    value = {
        "floats": [0.1, -0.0, float("nan"), float("inf"), -float("inf"), 5e-324, 1.7976931348623157e308],
        "numpy": [np.float64(0.3), np.float32(1.5), np.int64(-7), np.bool_(True), np.complex128(1 - 2j)],
        "arrays": [shared, shared, np.array(["a", "bc"]), np.array(["2026-01-01"], dtype="datetime64[s]"),
                   np.zeros((0, 3)), np.asfortranarray(np.eye(3)), frozen],
        "python": (1, "x", None, True, 2 + 3j, frozenset({1}), {2}, dt.datetime(2026, 1, 2, 3, 4, 5),
                   dt.date(2026, 1, 2), dt.timedelta(days=1, seconds=2)),
        (1, 2): "tuple key",
    }
    packages = frozenset({"e2esim"})
    back = plaindata.decode(*plaindata.encode(value, packages), packages)
    assert back["arrays"][0] is back["arrays"][1]  # one array, referenced twice
    assert back[(1, 2)] == "tuple key" and back["python"] == value["python"]
    for a, b in zip(value["floats"], back["floats"]):
        assert repr(a) == repr(b)
    for a, b in zip(value["numpy"], back["numpy"]):
        assert type(a) is type(b) and a == b
    for a, b in zip(value["arrays"], back["arrays"]):
        assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)
        assert b.flags.writeable == a.flags.writeable


@pytest.mark.parametrize("bad", [lambda: None, np.array([object()]), open, np.ma.masked_array([1.0]),
                                 __import__("collections").OrderedDict(a=1.0), np.array([(1, 2.0)], "i4,f8")])
def test_what_is_not_plain_data_is_refused_when_writing(bad):
    with pytest.raises(plaindata.NotPlainData):
        plaindata.encode({"x": bad}, frozenset({"e2esim"}))


def test_encoding_pauses_the_garbage_collector_and_gives_it_back_as_it_was():
    """The tree of a block that keeps its cases' products has a million nodes and no cycles: the collector's passes
    over them cost more than the encoding (issue 28, the 10 deg scintillation/RFI map). It is paused meanwhile and
    left as it was found, also when the value cannot be stored."""
    seen = []

    class Noting(dict):  # a module's noting values: read through items(), which tells us the collector's state
        plain_as_dict = True

        def items(self):
            seen.append(gc.isenabled())
            return super().items()

    packages = frozenset({"e2esim"})
    try:
        assert gc.isenabled()
        header, payload = plaindata.encode([Noting(a=1.0)], packages)
        assert seen == [False] and gc.isenabled()
        assert plaindata.decode(header, payload, packages) == [{"a": 1.0}]
        with pytest.raises(plaindata.NotPlainData):
            plaindata.encode([Noting(a=open)], packages)
        assert seen == [False, False] and gc.isenabled()
        gc.disable()  # a caller's own pause stays
        plaindata.encode([Noting(a=1.0)], packages)
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_decoding_never_calls_the_class():
    from e2esim.faraday.distribution import GaussianFaraday

    packages = frozenset({"e2esim"})
    header, payload = plaindata.encode(GaussianFaraday(0.5, 0.1), packages)
    doc = json.loads(header)
    doc["tree"]["f"] = [["mean", 0.5], ["sd", -1.0]]  # GaussianFaraday(0.5, -1.0) would raise: no code runs
    back = plaindata.decode(json.dumps(doc).encode(), payload, packages)
    assert type(back) is GaussianFaraday and back.sd == -1.0
    doc["tree"]["c"] = "builtins:eval"
    with pytest.raises(plaindata.BadPlainData, match="not of e2esim"):
        plaindata.decode(json.dumps(doc).encode(), payload, packages)


def test_a_planted_climatology_cache_file_never_runs(tmp_path):
    import h5py

    from e2esim.io import array_cache as cache

    marker = tmp_path / "MARKER"
    pickled = tmp_path / "faraday_site_x.h5"
    pickled.write_bytes(pickle.dumps(Payload(marker)))
    assert cache.read(pickled) is None and not marker.exists()

    with h5py.File(tmp_path / "odd.h5", "w") as f:  # a group and text where arrays belong
        f.create_group("vtec")
        f.create_dataset("stec", data=np.array([b"x"], dtype=object), dtype=h5py.string_dtype())
    assert cache.read(tmp_path / "odd.h5") is None

    cache.write(tmp_path / "ok.h5", {"vtec": np.ones(3)}, {"year": 2026})
    assert cache.read(tmp_path / "ok.h5", ("vtec",))["vtec"].tolist() == [1.0, 1.0, 1.0]
    assert cache.read(tmp_path / "ok.h5", ("vtec", "stec")) is None  # a required array missing: recomputed
