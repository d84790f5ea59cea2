"""Crafted results.h5 files given to ``e2esim compare`` and ``open_results`` (issue 22, items 2 and 7): a file
never makes e2esim read outside it (external storage, virtual datasets, external and soft links), never
expands beyond what it stores (fill values, gzip bombs) and never ends in a traceback or a hang: exit status
2 with one line naming the file and the dataset. A legitimately gzip-compressed copy reads the same."""

import os
import zlib

import h5py
import numpy as np
import pytest
from hostile_files import SECRET, cli, make_results

import e2esim
from e2esim.errors import UserError


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    return make_results(tmp_path_factory.mktemp("good") / "run")


@pytest.fixture
def secret(tmp_path):
    path = tmp_path / "outside.txt"
    path.write_text((SECRET + "\n") * 40)
    return path


def _crafted(tmp_path, good, change) -> str:
    path = tmp_path / "crafted.h5"
    path.write_bytes(good.read_bytes())
    with h5py.File(path, "r+") as f:
        change(f)
    return path


def _refused(tmp_path, capsys, path, good, *expect):
    """``compare`` and ``open_results`` both refuse ``path`` with a message containing ``expect``."""
    report = tmp_path / "comparison.md"
    status, out, err = cli(capsys, "compare", path, good, "--report", report)
    assert status == 2, (out, err)
    assert str(path) in err and SECRET not in out + err and not report.exists()
    for part in expect:
        assert part in err, (part, err)
    with pytest.raises(UserError) as caught:
        e2esim.open_results(path)
    assert SECRET not in str(caught.value)
    return err


def _replace(f, name, **kw):
    """Dataset ``name`` made anew from ``kw``, with the attributes of the one it replaces."""
    attrs = dict(f[name].attrs)
    del f[name]
    ds = f.create_dataset(name, **kw)
    ds.attrs.update(attrs)
    return ds


# --------------------------------------------------------------------------------- reading outside the file
@pytest.mark.parametrize("dataset", ["cases/inputs/scene.forest_text", "cases/results/scene.agb_t_ha",
                                     "provenance/resolved_scenario", "requirements/names"])
def test_external_storage_is_never_read(tmp_path, capsys, good, secret, dataset):
    size = secret.stat().st_size

    def change(f):
        old = f[dataset]
        shape = old.shape or (1,)  # HDF5 keeps no external storage for a scalar
        text = h5py.check_string_dtype(old.dtype) is not None
        _replace(f, dataset, shape=shape, dtype=f"S{size // shape[0]}" if text else old.dtype,
                 external=[(str(secret), 0, h5py.h5f.UNLIMITED)])

    _refused(tmp_path, capsys, _crafted(tmp_path, good, change), good, "external storage", dataset)


def test_virtual_datasets_are_refused(tmp_path, capsys, good, secret):
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = np.arange(4.0)

    def change(f):
        layout = h5py.VirtualLayout(shape=(4,), dtype="f8")
        layout[:] = h5py.VirtualSource(str(other), "x", shape=(4,))
        del f["cases/results/scene.agb_t_ha"]
        f.create_virtual_dataset("cases/results/scene.agb_t_ha", layout)

    _refused(tmp_path, capsys, _crafted(tmp_path, good, change), good, "virtual dataset")


@pytest.mark.parametrize("link", ["external", "external missing", "soft", "soft dangling"])
def test_links_are_never_followed(tmp_path, capsys, good, link):
    target = "/cases/results/scene.agb_t_ha"

    def change(f):
        del f[target]
        f[target] = {"external": h5py.ExternalLink(str(good), target),
                     "external missing": h5py.ExternalLink(str(tmp_path / "gone.h5"), target),
                     "soft": h5py.SoftLink("/cases/results/scene.sigma_hh"),
                     "soft dangling": h5py.SoftLink("/nowhere")}[link]

    _refused(tmp_path, capsys, _crafted(tmp_path, good, change), good, target, "link")


# ------------------------------------------------------------------------------------------- size bombs
def test_fill_value_bomb_is_refused_before_allocation(tmp_path, capsys, good):
    def declared_only(f):  # 5 million cases declared, nothing stored: 40 MB of fill values per column
        del f["cases/label"]
        g = f.create_group("cases/label")
        g.create_dataset("parts", data=["a"], dtype=h5py.string_dtype())
        g.create_dataset("codes", shape=(5_000_000, 1), dtype="u1")
        g.create_dataset("numbered", shape=(5_000_000,), dtype=bool)

    _refused(tmp_path, capsys, _crafted(tmp_path, good, declared_only), good, "/cases/label/codes", "stores 0")

    def unwritten(f):  # the right shape, chunked, never written
        _replace(f, "cases/results/scene.agb_t_ha", shape=(4,), dtype="f8", chunks=(1,))

    _refused(tmp_path, capsys, _crafted(tmp_path, good, unwritten), good, "fill values")

    def beyond_the_case_limit(f):
        _replace(f, "cases/label/codes", shape=(6_000_000, 2), dtype="u1", chunks=(1000, 2))

    _refused(tmp_path, capsys, _crafted(tmp_path, good, beyond_the_case_limit), good, "5,000,000 cases")


def test_gzip_bomb_is_refused_before_it_inflates(tmp_path, capsys, good):
    bomb = zlib.compress(bytes(64 * 2**20), 9)  # 64 MiB of zeros in about 64 kB, in a chunk declared as 32 bytes

    def change(f):
        ds = _replace(f, "cases/results/scene.agb_t_ha", data=np.zeros(4), chunks=(4,), compression="gzip")
        ds.id.write_direct_chunk((0,), bomb)

    _refused(tmp_path, capsys, _crafted(tmp_path, good, change), good, "inflates past its declared 32 bytes")


def test_a_gzip_compressed_copy_reads_the_same(tmp_path, good):
    """What ``h5repack -f GZIP=9`` makes of a results.h5 is read, with the same content."""
    packed = tmp_path / "packed.h5"
    with h5py.File(good, "r") as src, h5py.File(packed, "w") as dst:
        src.visititems(lambda name, obj: _copy_compressed(name, obj, dst))
        dst.attrs.update(src.attrs)
    a, b = e2esim.open_results(good), e2esim.open_results(packed)
    assert list(a.labels) == list(b.labels) and a.inputs == b.inputs and a.requirements == b.requirements
    assert set(a.scalars) == set(b.scalars) and all(np.array_equal(a.scalars[k], b.scalars[k]) for k in a.scalars)
    assert np.array_equal(a.status, b.status) and np.array_equal(a.margin, b.margin)


def _copy_compressed(name, obj, dst):
    if isinstance(obj, h5py.Group):
        dst.require_group(name).attrs.update(obj.attrs)
        return
    data = obj[()]
    ds = dst.create_dataset(name, data=data, dtype=obj.dtype, **({} if obj.shape == () else
                                                                 {"compression": "gzip", "shuffle": True}))
    ds.attrs.update(obj.attrs)


def test_other_compression_filters_are_refused(tmp_path, capsys, good):
    def change(f):
        _replace(f, "cases/results/scene.agb_t_ha", data=np.zeros(4), chunks=(4,), compression="lzf")

    _refused(tmp_path, capsys, _crafted(tmp_path, good, change), good, "filter number 32000", "gzip")


# --------------------------------------------------------------------------- wrong types, shapes, contents
def _set(name, data, **kw):
    return lambda f: _replace(f, name, data=data, **kw)


def _attr(path, key, value):
    def change(f):
        f[path].attrs[key] = value
    return change


def _delete(name):
    def change(f):
        del f[name]
    return change


def _group_for_dataset(name):
    def change(f):
        del f[name]
        f.create_group(name)
    return change


TEXT = h5py.string_dtype()
WRONG = {
    "scalar as text": (_set("cases/results/scene.agb_t_ha", ["a"] * 4, dtype=TEXT), "expected numbers"),
    "scalar of 3 cases": (_set("cases/results/scene.agb_t_ha", np.zeros(3)), "expected (4,)"),
    "scalar as a table": (_set("cases/results/scene.agb_t_ha", np.zeros((4, 2))), "expected (4,)"),
    "scalar as records": (_set("cases/results/scene.agb_t_ha", np.zeros(4, dtype=[("a", "f8"), ("b", "i4")])),
                          "compound"),
    "scalar as a group": (_group_for_dataset("cases/results/scene.agb_t_ha"), "not a dataset"),
    "value of 3 requirements": (_set("requirements/value", np.zeros((4, 3))), "expected (4, 2)"),
    "passed as text": (_set("requirements/passed", [["x", "y"]] * 4, dtype=TEXT), "expected booleans"),
    "code beyond its table": (_set("requirements/status", np.full((4, 2), 7, dtype="u1")), "expected codes 0 to 2"),
    "negative code": (_set("cases/inputs/scene.forest", np.full(4, -1, dtype="i1")), "expected codes 0 to 1"),
    "code as a float": (_set("requirements/dominant", np.zeros((4, 2))), "expected integers"),
    "unknown status": (_set("requirements/status_text", ["maybe", "fail", "not_applicable"], dtype=TEXT),
                       "'maybe'"),
    "table outside the group": (_attr("requirements/dominant", "text", "../cases/index"), "not the name of a dataset"),
    "table missing": (_attr("requirements/dominant", "text", "nothing_here"), "is missing"),
    "table attribute a number": (_attr("requirements/dominant", "text", 3), "not a short text"),
    "label codes of 3 groups beyond parts": (_set("cases/label/codes", np.full((4, 3), 200, dtype="u1")),
                                             "expected codes 0 to"),
    "numbered of 2 cases": (_set("cases/label/numbered", np.zeros(2, bool)), "expected (4,)"),
    "names as numbers": (_set("requirements/names", np.arange(2)), "expected text"),
    "n_cases attribute": (_attr("/", "n_cases", 7), "says 7 cases"),
    "no requirements": (_delete("requirements"), "/requirements: is missing"),
    "no results": (_delete("cases/results"), "/cases/results: is missing"),
    "no provenance": (_delete("provenance"), "not an e2esim results file"),
    "scenario as a number": (_set("provenance/resolved_scenario", 3.0), "expected text"),
    "scenario a list": (_set("provenance/resolved_scenario", "[1, 2]", dtype=TEXT), "not a scenario"),
    "scenario malformed": (_set("provenance/resolved_scenario", "a: [", dtype=TEXT), "malformed YAML"),
    "scenario with a python tag": (_set("provenance/resolved_scenario", "a: !!python/object/apply:os.getcwd []",
                                        dtype=TEXT), "is not allowed"),
    "scenario nested deeply": (_set("provenance/resolved_scenario", "a: " + "[" * 500 + "]" * 500, dtype=TEXT),
                               "nested deeper"),
}


@pytest.mark.parametrize("case", sorted(WRONG))
def test_wrong_types_shapes_and_contents(tmp_path, capsys, good, case):
    change, expect = WRONG[case]
    _refused(tmp_path, capsys, _crafted(tmp_path, good, change), good, expect)


def test_yaml_alias_bomb_in_the_stored_scenario(tmp_path, capsys, good):
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 12)]
    change = _set("provenance/resolved_scenario", "\n".join(lines), dtype=TEXT)
    _refused(tmp_path, capsys, _crafted(tmp_path, good, change), good, "/provenance/resolved_scenario",
             "more than the limit of 200,000 values")


def test_odd_attributes_are_left_out(tmp_path, good):
    """Provenance attributes e2esim did not write, large or of odd types, are not read (and do not fail)."""
    def change(f):
        f.attrs["big"] = np.zeros(20_000, dtype="u1")
        f.attrs["records"] = np.zeros(2, dtype=[("a", "f8")])
        f.attrs["deep_json"] = "[" * 100_000
    results = e2esim.open_results(_crafted(tmp_path, good, change))
    assert "big" not in results.provenance and "records" not in results.provenance
    assert results.provenance["deep_json"] == "[" * 100_000 and results.n_cases == 4


# ------------------------------------------------------------------------------------ special files, report
def test_fifo_and_devices_are_refused_without_waiting(tmp_path, capsys, good):
    fifo = tmp_path / "results.h5"
    os.mkfifo(fifo)  # opened by HDF5 it would wait for a writer for ever
    _refused(tmp_path, capsys, fifo, good, "FIFO")
    _refused(tmp_path, capsys, tmp_path, good, "FIFO")  # the run folder's results.h5
    _refused(tmp_path, capsys, "/dev/zero", good, "character device")


def test_not_hdf5_and_truncated_files(tmp_path, capsys, good):
    text = tmp_path / "text.h5"
    text.write_text("not HDF5\n")
    _refused(tmp_path, capsys, text, good, "not an HDF5 file")
    cut = tmp_path / "cut.h5"
    cut.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    _refused(tmp_path, capsys, cut, good)


@pytest.mark.parametrize("where", ["folder", "below a file", "too long"])
def test_a_report_that_cannot_be_written(tmp_path, capsys, good, where):
    (tmp_path / "file").write_text("x")
    report = {"folder": tmp_path, "below a file": tmp_path / "file" / "c.md",
              "too long": tmp_path / ("x" * 300 + ".md")}[where]
    status, _, err = cli(capsys, "compare", good, good, "--report", report)
    assert status == 2 and f"--report {report}: cannot write the comparison" in err
