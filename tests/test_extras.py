"""Optional extras (issue 28, Build 3): the default install is the core; maps, AGB products and clusters are extras.
A missing extra ends in a message naming the extra and its pip command, from the API (``MissingExtraError``, an
e2esim ``UserError``) and from the command line (exit status 2, no traceback). The missing package is simulated:
``sys.modules[name] = None`` makes ``import name`` fail as it fails where the package is not installed."""

import re
from pathlib import Path

import numpy as np
import pytest
import tomllib

from e2esim.cli import main
from e2esim.errors import MissingExtraError, UserError
from e2esim.extras import EXTRAS, optional_import

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def _module_name(requirement: str) -> str:
    """``roaring-landmask>=0.11`` -> ``roaring_landmask``: the import name of a requirement of the extras."""
    return re.split(r"[<>=!~;\[ ]", requirement, maxsplit=1)[0].replace("-", "_").lower()


def _missing(monkeypatch, *modules):
    for name in modules:
        monkeypatch.setitem(__import__("sys").modules, name, None)


def _says_extra(text: str, extra: str) -> None:
    assert f"optional extra '{extra}'" in text and f"pip install 'e2esim[{extra}]'" in text, text
    assert "Traceback" not in text


def test_the_extras_of_pyproject_are_those_the_code_names():
    extras = PYPROJECT["optional-dependencies"]
    for extra, (_, modules) in EXTRAS.items():
        assert sorted(map(_module_name, extras[extra])) == sorted(m.lower() for m in modules), extra
    assert extras["all"] == [f"e2esim[{','.join(EXTRAS)}]"]
    assert "e2esim[all]" in extras["test"]  # make test installs every extra
    core = {_module_name(r) for r in PYPROJECT["dependencies"]}
    optional = {m.lower() for _, modules in EXTRAS.values() for m in modules}
    assert not core & optional


def test_the_readme_names_every_extra():
    readme = (ROOT / "README.md").read_text()
    for extra in EXTRAS:
        row = next((line for line in readme.splitlines() if line.startswith(f"| `{extra}` |")), "")
        for requirement in PYPROJECT["optional-dependencies"][extra]:
            assert _module_name(requirement).replace("_", "-") in row.lower(), (extra, requirement)


def test_a_missing_module_names_its_extra_and_the_pip_command(monkeypatch):
    _missing(monkeypatch, "rioxarray")
    with pytest.raises(MissingExtraError) as caught:
        optional_import("rioxarray", "products", "reading a GeoTIFF AGB map")
    assert isinstance(caught.value, UserError)
    assert str(caught.value).startswith("reading a GeoTIFF AGB map needs the optional extra 'products' (rioxarray "
                                        "is not installed): pip install 'e2esim[products]'")
    with pytest.raises(ValueError, match="unknown extra 'map'"):
        optional_import("xarray", "map", "x")


def test_a_present_module_is_returned():
    assert optional_import("numpy", "maps", "x") is np


@pytest.mark.parametrize(("module", "suffix"), [("rioxarray", ".tif"), ("xarray", ".nc"), ("netCDF4", ".nc")])
def test_products_missing_from_the_api_and_the_command_line(tmp_path, monkeypatch, capsys, module, suffix):
    from e2esim.scene.agb_map import read_agb_map

    path = tmp_path / f"map{suffix}"
    path.write_bytes(b"not read: the reader is missing")
    _missing(monkeypatch, module)
    with pytest.raises(MissingExtraError) as caught:
        read_agb_map(path)
    _says_extra(str(caught.value), "products")
    scenario = tmp_path / "s.yaml"
    scenario.write_text(f"scene: {{type: agb_map, lat_deg: -0.5, lon_deg: 12.5, file: {path.name}}}\n"
                        "instrument: {type: biomass}\npropagation: [{type: hv_backscatter_error}]\n"
                        "retrieval: {type: power_law}\nrequirements: [{type: agb_rmse, max_percent: 20}]\n"
                        "simulation: {mode: analytic}\n")
    assert main(["validate", str(scenario)]) == 2
    _says_extra(capsys.readouterr().err, "products")


@pytest.mark.parametrize("module", ["xarray", "netCDF4", "roaring_landmask"])
def test_maps_missing_from_the_command_line(tmp_path, monkeypatch, capsys, module):
    _missing(monkeypatch, module)
    status = main(["run", str(ROOT / "scenarios" / "biomass_global_map.yaml"), "-o", str(tmp_path / "run"),
                   "--no-progress", "--set", "sweep.map.step_deg=20", "--set", "ionosphere.grid_step_deg=20"])
    assert status == 2
    _says_extra(capsys.readouterr().err, "maps")
    assert not (tmp_path / "run" / "results.h5").exists()


def test_the_land_mask_missing_from_the_api(monkeypatch):
    from e2esim.scene import land_mask

    land_mask._mask.cache_clear()  # a mask loaded by an earlier test would hide the import
    _missing(monkeypatch, "roaring_landmask")
    with pytest.raises(MissingExtraError) as caught:
        land_mask.is_land(0.0, 0.0)
    _says_extra(str(caught.value), "maps")


def test_to_xarray_without_the_maps_extra(monkeypatch, tmp_path):
    import e2esim

    results = e2esim.run(ROOT / "scenarios" / "men2021_fig1.yaml", set={"simulation.mode": "analytic"},
                         output=tmp_path / "r")
    _missing(monkeypatch, "xarray")
    with pytest.raises(MissingExtraError) as caught:
        results.to_xarray()
    _says_extra(str(caught.value), "maps")
    assert len(results.to_dataframe()) == results.n_cases  # pandas is in the core


def test_cluster_missing_from_the_command_line(tmp_path, monkeypatch, capsys):
    _missing(monkeypatch, "distributed")
    status = main(["run", str(ROOT / "scenarios" / "men2021_fig1.yaml"), "-o", str(tmp_path / "run"),
                   "--no-progress", "--set", "simulation.mode=analytic", "--scheduler", "tcp://127.0.0.1:8786"])
    assert status == 2
    _says_extra(capsys.readouterr().err, "cluster")
