"""Crafted resume journals (issue 22, item 6): whatever a journal holds, ``e2esim run --resume`` ends with exit
status 2 and one line saying the journal is corrupt, within seconds: array shapes of zero or absurd sizes, an
object array declaring terabytes, records naming the wrong classes or holding the wrong field types (which
used to decode and then crash the run), a journal that is /dev/zero, a sparse 64 GiB file or a FIFO, and a
journal folder that is a symbolic link."""

import json
import os
import shutil
import struct
import zlib

import numpy as np
import pytest
from hostile_files import cli, make_journal

from e2esim.runner.journal import JOURNAL, Journal, encode_block
from e2esim.runner.journal_check import check_block
from e2esim.runner.plaindata import allowed_packages, decode
from quick_runs import scenario_names

FRAME = struct.Struct("<4sQQQI")


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    return make_journal(tmp_path_factory.mktemp("journal"))


@pytest.fixture
def run(made, tmp_path):
    """(scenario, output folder holding a copy of the journal of both cases)."""
    scenario, _, out = made
    shutil.copytree(out, tmp_path / "out")
    return scenario, tmp_path / "out"


def read_frames(path) -> list:
    """[(cases, header as JSON, payload)] of a journal's records file."""
    data, pos, out = path.read_bytes(), 0, []
    while pos < len(data):
        _, count, n_header, n_payload, _ = FRAME.unpack_from(data, pos)
        start = pos + FRAME.size
        end = start + n_header + n_payload
        out.append([count, json.loads(data[start:start + n_header]), data[start + n_header:end]])
        pos = end
    return out


def frame_bytes(count: int, doc, payload: bytes) -> bytes:
    header = doc if isinstance(doc, bytes) else json.dumps(doc).encode()
    crc = zlib.crc32(payload, zlib.crc32(header))
    return FRAME.pack(b"E2J2", count, len(header), len(payload), crc) + header + payload


def write_frames(path, frames) -> None:
    path.write_bytes(b"".join(frame_bytes(*f) for f in frames))


def _resume_refused(capsys, scenario, out, *expect):
    status, _, err = cli(capsys, "run", scenario, "-o", out, "--resume", "--no-progress")
    assert status == 2, err
    assert "the resume journal is corrupt or foreign" in err and "--force" in err
    for part in expect:
        assert part in err, (part, err)
    return err


def _field(node, name):
    return next(value for key, value in node["f"] if key == name)


def _set_field(node, name, value):
    node["f"] = [[key, value if key == name else v] for key, v in node["f"]]


def _first_object(tree, cls):
    """The first object node of class ``cls`` ("module:Class") in a decoded record tree."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            if node.get("$") == "o" and node.get("c") == cls:
                return node
            stack += list(node.values())
        elif isinstance(node, list):
            stack += node
    raise LookupError(cls)


def _mutate(run, change):
    """Apply ``change(doc, payload) -> payload or None`` to the first record, with a valid checksum."""
    scenario, out = run
    records = out / JOURNAL / "cases.journal"
    frames = read_frames(records)
    new = change(frames[0][1], frames[0][2])
    if new is not None:
        frames[0][2] = new
    write_frames(records, frames)
    return scenario, out


# ----------------------------------------------------------------------------------------------- arrays
def _array_spec(index, spec):
    def change(doc, payload):
        doc["arrays"][index] = spec
    return change


def _indices_spec(doc):
    """The position of the block's case numbers among the record's arrays."""
    return _field(doc["tree"], "indices")["a"]


@pytest.mark.parametrize("spec, expect", [
    (["<i8", [0]], "belong to no array"),
    (["<i8", [0, 2**70]], "malformed"),
    (["<i8", [0, 2**61]], "too large"),
    (["<i8", [2**40, 2**40]], "longer than the record"),
    (["|S0", [1]], "not plain data"),
    (["<i8", [1] * 40], "malformed"),
    (["<f8", [1]], "integers"),
    (["<U1", [2]], "integers"),
])
def test_array_shapes_and_dtypes(run, capsys, spec, expect):
    def change(doc, payload):
        doc["arrays"][_indices_spec(doc)] = spec
    _resume_refused(capsys, *_mutate(run, change), expect)


def test_an_object_array_declaring_terabytes(run, capsys):
    def change(doc, payload):  # 2**40 items of 8 bytes: 8 TiB, with no item stored
        _set_field(doc["tree"], "products", {"$": "oa", "s": [2**40], "i": [], "id": 10**6})
    _resume_refused(capsys, *_mutate(run, change), "wrong number of items")


# ---------------------------------------------------------------------------------- classes and fields
def _swap_class(path, cls):
    def change(doc, payload):
        _first_object(doc["tree"], path)["c"] = cls
    return change


def _field_value(path, name, value):
    def change(doc, payload):
        _set_field(_first_object(doc["tree"], path), name, value)
    return change


def _drop_field(path, name):
    def change(doc, payload):
        node = _first_object(doc["tree"], path)
        node["f"] = [pair for pair in node["f"] if pair[0] != name]
    return change


BLOCK_RESULT = "e2esim.runner.case_results:BlockResult"
COLUMN, VALUES, REQ = "e2esim.runner.columns:Column", "e2esim.block:Values", "e2esim.runner.columns:RequirementColumns"
CRAFTED = {
    "a column that is a Values": (_swap_class(COLUMN, VALUES), "not a column of values"),
    "verdicts that are a column": (_swap_class(REQ, COLUMN), "not requirement columns"),
    "a scene that is a distribution": (_swap_class("e2esim.scene.covariance:ScatteringCovariance",
                                                   "e2esim.faraday.distribution:GaussianFaraday"),
                                       "must be a ScatteringCovariance"),
    "the block a Column": (_swap_class(BLOCK_RESULT, COLUMN), "not a block of results"),
    "a column without values": (_drop_field(COLUMN, "values"), "lack their field values"),
    "a product without a field": (_drop_field("e2esim.distortion.error_model:HVErrorModel", "faraday"),
                                  "without its field faraday"),
    "column values as text": (_field_value(COLUMN, "values", "text"), "not a one-dimensional array"),
    "notes that are numbers": (_field_value(BLOCK_RESULT, "notes", 3), "not a column of values"),
    "requirements a mapping": (_field_value(BLOCK_RESULT, "requirements",
                                            {"$": "d", "i": [], "id": 10**6}), "2 requirements"),
    "one requirement": (lambda doc, p: _first_object(doc["tree"], BLOCK_RESULT)["f"].__setitem__(
        2, ["requirements", {"$": "l", "i": [], "id": 10**6}]), "2 requirements"),
    "a field of the wrong type": (_field_value("e2esim.distortion.montecarlo:MonteCarloErrors", "looks", "many"),
                                  "the field looks of a MonteCarloErrors is a str"),
    "a set of objects without fields": (_field_value(BLOCK_RESULT, "notes", {"$": "s", "i": [
        {"$": "o", "c": "e2esim.faraday.distribution:GaussianFaraday", "f": [], "id": 10**6}]}), "does not decode"),
    "a code pointing nowhere": (lambda doc, payload: None, None),  # set below: needs the payload
}


def _code_nowhere(doc, payload):
    """The notes' codes of the block point past their table."""
    notes = _field(doc["tree"], "notes")
    index = _field(notes, "index")["a"]
    start = sum(int(np.prod(s[1])) * np.dtype(s[0]).itemsize for s in doc["arrays"][:index])
    return payload[:start] + np.array([99], dtype=doc["arrays"][index][0]).tobytes() + payload[start + 8:]


CRAFTED["a code pointing nowhere"] = (_code_nowhere, "code points to no value")


@pytest.mark.parametrize("case", sorted(CRAFTED))
def test_records_of_the_wrong_classes_and_fields(run, capsys, case):
    change, expect = CRAFTED[case]
    _resume_refused(capsys, *_mutate(run, change), expect)


def test_a_record_claiming_another_number_of_cases(run, capsys):
    scenario, out = run
    records = out / JOURNAL / "cases.journal"
    frames = read_frames(records)
    frames[0][0] = 5
    write_frames(records, frames)
    _resume_refused(capsys, scenario, out, "claims 5 cases")
    frames[0][0] = 2**63
    write_frames(records, frames)
    _resume_refused(capsys, scenario, out, "claims 9,223,372,036,854,775,808 cases")


def test_a_record_claiming_more_than_the_limit_is_not_read(run, capsys):
    scenario, out = run
    records = out / JOURNAL / "cases.journal"
    records.write_bytes(FRAME.pack(b"E2J2", 1, 2**40, 2**40, 0))
    _resume_refused(capsys, scenario, out, "more than the limit")


# --------------------------------------------------------------------------------------- special files
def test_dev_zero_as_the_journal(run, capsys):
    scenario, out = run
    records = out / JOURNAL / "cases.journal"
    records.unlink()
    records.symlink_to("/dev/zero")
    _resume_refused(capsys, scenario, out, "symbolic link")


def test_a_sparse_64_gib_journal(run, capsys):
    scenario, out = run
    with open(out / JOURNAL / "cases.journal", "r+b") as fh:
        fh.truncate(64 * 2**30)  # the first record's mark is zeros: refused before the rest is read
    _resume_refused(capsys, scenario, out, "mark")


@pytest.mark.parametrize("name", ["cases.journal", "manifest.json"])
def test_a_fifo_as_the_journal_or_its_manifest(run, capsys, name):
    scenario, out = run
    (out / JOURNAL / name).unlink()
    os.mkfifo(out / JOURNAL / name)  # opened for reading, it would wait for a writer for ever
    _resume_refused(capsys, scenario, out, "FIFO")
    status, _, err = cli(capsys, "run", scenario, "-o", out, "--no-progress")  # without --resume: the same
    assert status == 2 and "FIFO" in err


def test_a_journal_folder_that_is_a_link(run, capsys, tmp_path):
    scenario, out = run
    elsewhere = tmp_path / "elsewhere"
    (out / JOURNAL).rename(elsewhere)
    (out / JOURNAL).symlink_to(elsewhere)
    size = (elsewhere / "cases.journal").stat().st_size
    with open(elsewhere / "cases.journal", "ab") as fh:
        fh.write(b"E2J2")  # a torn frame: resuming would cut the file outside the output folder
    status, _, err = cli(capsys, "run", scenario, "-o", out, "--resume", "--no-progress")
    assert status == 2 and "symbolic link" in err and "not used" in err, err  # the output folder's own check
    assert (elsewhere / "cases.journal").stat().st_size == size + 4


def test_a_huge_manifest(run, capsys):
    scenario, out = run
    (out / JOURNAL / "manifest.json").write_text(" " * 100_000 + "{}")
    _resume_refused(capsys, scenario, out, "larger than")


def test_the_journal_still_resumes(made, run):
    """The checks pass what the run itself wrote: both blocks come back, with their products."""
    _, resolved, _ = made
    blocks = list(Journal(run[1], resolved).start(resume=True))
    assert [list(b.indices) for b in blocks] == [[0], [1]] and all(len(b.products) == 1 for b in blocks)


@pytest.mark.parametrize("name", scenario_names())
def test_the_checks_pass_every_block_of_every_shipped_scenario(name, quick_run):
    """What the run writes is what the checks expect: every block of every shipped scenario's quick run, with
    its products, comes back from its journal frame and passes ``check_block`` (the checks hold e2esim's own
    annotations to the objects its modules really make)."""
    result, _ = quick_run(name)
    packages = allowed_packages()
    for block in result.blocks:
        frame = encode_block(block, packages)
        _, count, n_header, _, _ = FRAME.unpack_from(frame)
        header, payload = frame[FRAME.size:FRAME.size + n_header], frame[FRAME.size + n_header:]
        check_block(decode(header, payload, packages), result.scenario, packages)
        assert count == len(block)
