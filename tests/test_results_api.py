"""The Python API, results that describe themselves and `e2esim compare` (issue 11, Build items 7 and 8)."""

import json
import runpy
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

import e2esim
from e2esim.cli import main
from e2esim.io.h5_datasets import read_text
from e2esim.io.results_h5 import write_results
from e2esim.runner.scenario import Scenario
from e2esim.runner.sweep import case_labels
from quick_runs import scenario_names

ROOT = Path(__file__).resolve().parents[1]

SMALL = {  # analytic only, a 2 x 3 grid: fast
    "name": "small_grid",
    "scene": {"type": "table1_forest"},
    "instrument": {"type": "biomass"},
    "ionosphere": {"type": "gaussian_faraday", "mean_deg": 60.0, "sd_deg": 5.0},
    "requirements": [{"type": "agb_error_bound", "bound_percent": 20}],
    "simulation": {"mode": "analytic", "seed": 3, "looks": 100000},
    "sweep": {"parameters": {"scene.forest": ["boreal_50", "boreal_200"],
                             "instrument.crosstalk.level_db": [-34.0, -30.0, -26.0]}},
}


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    folder = tmp_path_factory.mktemp("api") / "run"
    results = e2esim.run(SMALL, set={"simulation.seed": 4})
    folder.mkdir()
    write_results(results.run, folder / "results.h5")  # the report and plots are the example's test
    return results, folder


def test_run_returns_results_with_overrides_applied(small):
    results, _ = small
    assert results.n_cases == 6 and results.provenance["seed"] == 4
    assert results.sweep_keys == ("scene.forest", "instrument.crosstalk.level_db")
    # the verdict's value is the scalar the requirement wrote, and its margin is limit - value
    np.testing.assert_allclose(results.value[:, 0], results.scalars["requirement0.value"])
    np.testing.assert_allclose(results.margin[:, 0], 20.0 - results.value[:, 0])


def test_dataframe_has_one_row_per_case_and_the_sweep_keys(small):
    df = small[0].to_dataframe()
    assert list(df.index) == list(range(6))
    assert list(df["instrument.crosstalk.level_db"]) == [-34.0, -30.0, -26.0] * 2
    assert df.attrs["units"]["agb.analytic.q99865_percent"] == "%"
    # worse crosstalk, larger AGB error: the numbers are the run's, in sweep order
    q = df["agb.analytic.q99865_percent"].to_numpy().reshape(2, 3)
    assert np.all(np.diff(q, axis=1) > 0)


def test_xarray_grid_is_n_dimensional_with_sweep_coordinates(small):
    ds = small[0].to_xarray()
    var = ds["agb.analytic.q99865_percent"]
    assert var.dims == ("scene.forest", "instrument.crosstalk.level_db") and var.shape == (2, 3)
    assert list(ds["scene.forest"].values) == ["boreal_50", "boreal_200"]
    assert var.attrs["units"] == "%"
    df = small[0].to_dataframe()
    value = var.sel({"scene.forest": "boreal_200", "instrument.crosstalk.level_db": -30.0}).item()
    assert value == df.loc[4, "agb.analytic.q99865_percent"]


def test_open_results_reads_back_the_same_numbers(small):
    results, folder = small
    again = e2esim.open_results(folder)
    assert again.labels == results.labels and again.inputs == results.inputs
    assert again.sweep_keys == results.sweep_keys
    for name, values in results.scalars.items():
        np.testing.assert_array_equal(again.scalars[name], values)
    np.testing.assert_array_equal(again.passed, results.passed)
    assert again.to_xarray()["agb.analytic.rmse_percent"].shape == (2, 3)
    with pytest.raises(ValueError, match="read from a file"):
        again.write(folder / "again")


def test_text_over_cases_is_written_as_codes_and_reads_back_the_same(small):
    results, folder = small
    table = results.run.table
    with h5py.File(folder / "results.h5") as f:
        assert f.attrs["format_version"] == 4
        for name in ("dominant", "basis", "status", "reason", "coverage_sources", "coverage_text"):
            assert f[f"requirements/{name}"].dtype.kind == "u" and f[f"requirements/{name}"].shape == (6, 1)
        assert read_text(f["requirements/dominant"]).tolist() == results.dominant.tolist()
        assert read_text(f["requirements/basis"])[:, 0].tolist() == table.requirements[0].basis.tolist()
        assert read_text(f["requirements/status"]).tolist() == results.status.tolist()
        assert read_text(f["requirements/coverage_text"]).tolist() == results.coverage_text.tolist()
        assert read_text(f["cases/inputs/scene.forest"]).tolist() == ["boreal_50"] * 3 + ["boreal_200"] * 3
        labels = f["cases/label"]  # factored: one part per group of sweep keys
        assert labels["codes"].shape == (6, 2) and len(labels["parts"]) == 5 and not labels["numbered"][()].any()
    again = e2esim.open_results(folder)
    assert again.labels.tolist() == results.labels.tolist() == [
        f"forest={f}, crosstalk.level_db={x}" for f in ("boreal_50", "boreal_200") for x in (-34, -30, -26)]
    assert again.dominant.tolist() == results.dominant.tolist()
    for name in ("status", "reason", "coverage", "coverage_text"):
        assert getattr(again, name).tolist() == getattr(results, name).tolist()


def test_case_sweeps_with_repeats_and_missing_keys_read_back_the_same(tmp_path):
    cases = [{"scene.forest": "boreal_50"}, {"scene.forest": "boreal_200", "instrument.crosstalk.level_db": -30.0},
             {"scene.forest": "boreal_50"}]
    results = e2esim.run({**SMALL, "sweep": {"cases": cases}})
    write_results(results.run, tmp_path / "results.h5")
    again = e2esim.open_results(tmp_path)
    assert list(again.labels) == list(results.labels) == [  # the crosstalk goes with the forest: not named
        "forest=boreal_50 (#0)", "forest=boreal_200", "forest=boreal_50 (#2)"]
    assert again.inputs == results.inputs == {"scene.forest": ["boreal_50", "boreal_200", "boreal_50"],
                                              "instrument.crosstalk.level_db": [None, -30.0, None]}


def test_results_h5_of_format_2_text_as_strings_still_reads(small, tmp_path):
    results, folder = small
    old = tmp_path / "results.h5"
    old.write_bytes((folder / "results.h5").read_bytes())
    string = h5py.string_dtype("utf-8")
    with h5py.File(old, "r+") as f:  # the layout before format 3: every text column as strings
        for path, values in (("cases/label", results.labels.tolist()),
                             ("cases/inputs/scene.forest", results.inputs["scene.forest"]),
                             ("requirements/dominant", results.dominant.tolist())):
            del f[path]
            f.create_dataset(path, data=values, dtype=string)
        f.attrs["format_version"] = 2
    again = e2esim.open_results(old)
    assert again.labels == results.labels.tolist() and again.inputs == results.inputs
    assert again.dominant.tolist() == results.dominant.tolist()


def test_results_h5_every_dataset_has_units_and_description(small):
    missing = []
    with h5py.File(small[1] / "results.h5") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and not ({"units", "description"} <= set(obj.attrs)):
                missing.append(name)
            elif isinstance(obj, h5py.Dataset) and obj.attrs["units"] == "unknown":
                missing.append(name + " (unit unknown)")
        f.visititems(visit)
        assert f["cases/results/scene.sigma_hv"].attrs["units"] == "m^2/m^2"
        assert f["cases/results/analytic.variance"].attrs["units"] == "(m^2/m^2)^2"
        versions = json.loads(f.attrs["versions"])
    assert missing == []
    import scipy

    assert versions["scipy"] == scipy.__version__ and {"PyIRI", "ppigrf", "h5py", "xarray"} <= set(versions)


def test_compare_reports_inputs_verdicts_and_numbers(small, tmp_path, capsys):
    _, folder = small
    other = tmp_path / "other.h5"
    write_results(e2esim.run(SMALL, **{"simulation.seed": 4, "instrument.nesz_db": -20.0}).run, other)
    report = tmp_path / "cmp.md"
    assert main(["compare", str(folder), str(other), "--report", str(report)]) == 1
    text = report.read_text()
    assert "| instrument.nesz_db | -27 | -20 |" in text  # the input that differs, with both values
    assert "analytic.bias_noise" in text and "6 of 6" in text
    assert "# Comparison of two runs" in capsys.readouterr().out
    assert main(["compare", str(folder), str(folder), "--report", str(tmp_path / "same.md")]) == 0
    assert main(["compare", str(folder), str(tmp_path / "nothing"), "--report", str(report)]) == 2


def test_case_labels_are_unique_and_name_what_differs():
    resolved = Scenario.load(ROOT / "scenarios" / "biomass_calibration.yaml").resolve()
    labels = [c.label for c in resolved.cases]
    assert len(set(labels)) == len(labels) == 8
    # cases 1 and 2 differ only in the second calibration step: the labels say so
    assert "calibration.1.type=none" in labels[1] and "calibration.1.type=distributed_target_calibration" in labels[2]
    assert case_labels([{"a.x": 1, "b.y": "p"}, {"a.x": 1, "b.y": "p"}]) == ["base case (#0)", "base case (#1)"]
    # a key fixed by an earlier one (the biome of a latitude) is left out
    assert case_labels([{"lat_deg": 0, "biome": "t"}, {"lat_deg": 60, "biome": "b"}]) == ["lat_deg=0", "lat_deg=60"]


def test_api_example_runs(tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "argv", ["api_sweep.py", str(tmp_path)])
    namespace = runpy.run_path(str(ROOT / "examples" / "api_sweep.py"))
    png = namespace["main"](tmp_path / "again")
    assert png.is_file() and (tmp_path / "again" / "run" / "report.html").is_file()


@pytest.mark.parametrize("scenario", scenario_names())
def test_to_xarray_works_on_every_shipped_scenario(scenario, quick_run):
    # issue 21 item 11: men2021_fig1 (instrument.nesz_db) and nisar_lband (scene.agb_t_ha, scene.sigma_*) sweep keys
    # that are output scalars too raised "found in both data_vars and coords"
    result, folder = quick_run(scenario)
    for results in (e2esim.Results.from_run(result), e2esim.open_results(folder)):
        ds = results.to_xarray()
        if results.resolved_scenario.get("sweep", {}).get("map") is not None:
            continue  # a map: its grid (test_map_sweep.py)
        for key in results.sweep_keys:  # every sweep key is a coordinate, every output scalar is in the dataset
            assert key in ds.coords
        for name, values in results.scalars.items():
            held = ds[name] if name in ds.data_vars or name in ds.coords else ds[name + ".output"]
            if held.dims == ds["label"].dims:
                np.testing.assert_allclose(held.values.ravel(), values, rtol=1e-12)
            assert held.attrs["units"] == results.units[name]


def test_to_xarray_keeps_an_output_scalar_that_differs_from_its_swept_key(small):
    results, _ = small
    shifted = dict(results.scalars, **{"instrument.crosstalk.level_db": results.scalars["agb.exponent"]})
    again = e2esim.Results(**{**results.__dict__, "scalars": shifted})
    ds = again.to_xarray()
    assert list(ds["instrument.crosstalk.level_db"].values) == [-34.0, -30.0, -26.0]  # the swept input
    np.testing.assert_array_equal(ds["instrument.crosstalk.level_db.output"].values.ravel(), shifted["agb.exponent"])
