"""results.h5 is written through h5py's low-level API (``e2esim.io.h5_datasets.put``) and the scenario's YAML by
libyaml's emitter: the file must be what h5py's ``create_dataset`` and ``attrs[...] = text`` and PyYAML's
``safe_dump`` make, byte for byte."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
import yaml

from e2esim.io.h5_datasets import STRING, put, put_coded, put_text
from e2esim.io.results_h5 import scenario_yaml
from e2esim.runner.scenario import Scenario
from quick_runs import SCENARIOS, quick_overrides, scenario_names

_DATA = {  # name: (data, dtype given to put): every kind of dataset results.h5 holds
    "floats": (np.array([1.5, np.nan, -np.inf]), None),
    "grid": (np.arange(6.0).reshape(2, 3), None),
    "index": (np.arange(4, dtype=np.int64), None),
    "passed": (np.array([[True, False]]), None),
    "codes": (np.array([[0, 2], [1, 0]], dtype=np.uint8), None),
    "small": (np.array([-1, 0, 1], dtype=np.int8), None),
    "empty": (np.zeros(0), None),
    "none_per_case": (np.zeros((3, 0), dtype=np.int64), None),
    "from_list": ([0.25, 4.0], None),
    "one_text": ("a: 1\nb: [x, y]\n", STRING),
    "texts": (["pass", "fail", "naïve °C"], STRING),
    "no_texts": ([], STRING),
    "1/nested": (np.array([2.0]), None),
}


def _write(path, make) -> bytes:
    with h5py.File(path, "w") as f:
        make(f.create_group("g"))
    return path.read_bytes()


def test_put_writes_the_bytes_of_h5py_create_dataset_and_attrs(tmp_path):
    def fast(g):
        for name, (data, dtype) in _DATA.items():
            put(g, name, data, "m", f"about {name} (µ)", dtype)
        put(g, "coded", np.array([1, 0]), "text", "codes", table="coded_text")

    def reference(g):
        for name, (data, dtype) in _DATA.items():
            ds = g.create_dataset(name, data=data, dtype=dtype)
            ds.attrs["units"] = "m"
            ds.attrs["description"] = f"about {name} (µ)"
        ds = g.create_dataset("coded", data=np.array([1, 0]))
        ds.attrs["units"], ds.attrs["description"], ds.attrs["text"] = "text", "codes", "coded_text"

    written = _write(tmp_path / "fast.h5", fast)
    assert written == _write(tmp_path / "reference.h5", reference)
    assert written != _write(tmp_path / "other.h5", lambda g: put(g, "floats", np.array([1.5]), "m", "x"))


def test_text_attributes_and_datasets_are_variable_length_utf8(tmp_path):
    """What a reader of results.h5 sees: scalar variable-length UTF-8 strings, the codes' table named."""
    with h5py.File(tmp_path / "t.h5", "w") as f:
        put_text(f, "names", ["a", "b"], "names")
        put_coded(f, "status", ["pass", "fail"], np.array([[1], [0]]), "status")
    with h5py.File(tmp_path / "t.h5", "r") as f:
        for name in ("names", "status_text", "status"):
            for key in f[name].attrs:
                t = f[name].attrs.get_id(key).get_type()
                assert (t.get_class(), t.is_variable_str(), t.get_cset()) == (h5py.h5t.STRING, True,
                                                                              h5py.h5t.CSET_UTF8)
                assert f[name].attrs.get_id(key).shape == ()
        assert dict(f["status"].attrs) == {"units": "text", "description": "status (codes into status_text)",
                                           "text": "status_text"}
        assert f["status"].dtype == np.uint8 and f["status"][()].tolist() == [[1], [0]]
        assert f["names"].id.get_type().get_cset() == h5py.h5t.CSET_UTF8 and f["names"].chunks is None
        assert [x.decode() for x in f["status_text"][()]] == ["pass", "fail"]


def test_a_dataset_after_a_failed_name_is_not_made(tmp_path):
    with h5py.File(tmp_path / "t.h5", "w") as f:
        put(f, "x", np.zeros(2), "1", "x")
        with pytest.raises(ValueError):
            put(f, "x", np.zeros(2), "1", "again")
        assert list(f) == ["x"] and f["x"].attrs["description"] == "x"


@pytest.mark.parametrize("name", scenario_names())
def test_the_stored_scenario_yaml_is_what_safe_dump_writes(name):
    """libyaml's emitter writes the text of PyYAML's for every shipped scenario, as given and resolved, at full
    and quick sizes."""
    for overrides in ((), quick_overrides(name)):
        scenario = Scenario.load(SCENARIOS / f"{name}.yaml", overrides)
        for data in (scenario.raw, scenario.resolve().resolved):
            text = scenario_yaml(data)
            assert text == yaml.safe_dump(data, sort_keys=False)
            assert yaml.safe_load(text) == data


def test_every_dataset_of_a_run_has_its_text_attributes_and_no_storage_options(quick_run):
    """A walk of a whole results.h5: each dataset contiguous and unfiltered, with exactly ``units``,
    ``description`` (and ``text`` for codes) as scalar variable-length UTF-8 strings."""
    _, folder = quick_run("biomass_default")
    seen = []

    def visit(name, obj):
        if not isinstance(obj, h5py.Dataset):
            return
        plist = obj.id.get_create_plist()
        assert (plist.get_layout(), plist.get_nfilters(), obj.chunks) == (h5py.h5d.CONTIGUOUS, 0, None), name
        assert set(obj.attrs) in ({"units", "description"}, {"units", "description", "text"}), name
        for key in obj.attrs:
            aid = obj.attrs.get_id(key)
            t = aid.get_type()
            assert (aid.shape, t.get_class(), t.is_variable_str(), t.get_cset()) == ((), h5py.h5t.STRING, True,
                                                                                      h5py.h5t.CSET_UTF8), name
        seen.append(name)

    with h5py.File(folder / "results.h5", "r") as f:
        f.visititems(visit)
        assert f["provenance/resolved_scenario"].dtype.kind == "O" and f["cases/results"].attrs.get("units") is None
    assert len(seen) > 100 and "cases/index" in seen and "requirements/status" in seen
