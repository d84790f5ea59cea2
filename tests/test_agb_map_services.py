"""The AGB map of a map sweep is read through the services handed to configuration (issue 27, Build 7: one
caching mechanism handed in through services): ``Scenario.resolve(services)`` gives them to the scene's map hook
(``AGBMapScene.map_cells``) and to its ``setup``, which read the map once through ``services.memo``; a plug-in
hook or set-up written without a ``services`` parameter keeps working; a run reads the map once."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from e2esim.api import run
from e2esim.case import KernelMemo, Services
from e2esim.maps import grid as map_grid_module
from e2esim.runner.scenario import Scenario
from e2esim.scene import agb_map
from e2esim.scene.map_modules import AGBMapScene


def _map_scenario(tmp_path, step_deg: float = 1.0) -> dict:
    """A map sweep at ``step_deg`` over a small AGB map of 1-degree pixels (latitude -5 to 5, longitude 10 to 16
    deg) written in ``tmp_path`` (a new file: no memo of this process holds it yet)."""
    lat, lon = np.arange(-4.5, 5.0, 1.0), np.arange(10.5, 16.0, 1.0)
    agb = 100.0 + 10.0 * np.arange(lat.size)[:, None] + np.arange(lon.size)[None, :]
    xr.Dataset({"agb": (("lat", "lon"), agb, {"units": "t/ha"})}, coords={"lat": lat, "lon": lon}).to_netcdf(
        tmp_path / "agb.nc", engine="netcdf4")
    return {"scene": {"type": "agb_map", "file": str(tmp_path / "agb.nc")}, "instrument": {"type": "biomass"},
            "ionosphere": {"type": "global_climatology", "grid_step_deg": step_deg},
            "sweep": {"map": {"step_deg": step_deg, "lat_range_deg": [-5, 5], "lon_range_deg": [10, 15], "months": [4],
                              "passes": ["dusk"]}}}


@pytest.fixture
def reads(monkeypatch) -> list:
    """The paths of the AGB maps read from disk from now on (``agb_map._read`` calls)."""
    paths, read = [], agb_map._read
    monkeypatch.setattr(agb_map, "_read", lambda path, variable: paths.append(path) or read(path, variable))
    return paths


def test_resolve_reads_the_map_once_through_the_memo_of_the_services_it_is_handed(tmp_path, reads):
    raw = _map_scenario(tmp_path, step_deg=5.0)
    memo = KernelMemo()
    resolved = Scenario(raw, "map.yaml").resolve(Services(memo=memo))
    assert len(reads) == 1 and len(resolved.cases) > 0  # the map hook's read, found again by the scene's setup
    Scenario(raw, "map.yaml").resolve(Services(memo=memo))
    assert len(reads) == 1  # a second resolve with the same memo (a solve's runs) reads nothing
    Scenario(raw, "map.yaml").resolve(Services(memo=None))
    assert len(reads) == 3  # no memo: the hook and the set-up each read the file (the memo handed in is used)


class OldStyleScene(AGBMapScene):
    """A plug-in scene whose hook and set-up have the signatures of before the services were handed in."""

    @classmethod
    def map_cells(cls, section, lat_deg, lon_deg, where):
        return (np.asarray(lat_deg) > 0)[:, None] & (np.asarray(lon_deg) > 12)[None, :]  # inside the map

    def setup(self):
        super().setup()


def test_a_plugin_hook_and_setup_without_services_keep_working(tmp_path, monkeypatch, reads):
    lookup = map_grid_module.registry.lookup  # the registry both the map grid and the plan builder ask
    monkeypatch.setattr(map_grid_module.registry, "lookup",
                        lambda kind, name: OldStyleScene if kind == "scene" else lookup(kind, name))
    raw = _map_scenario(tmp_path)
    resolved = Scenario(raw, "map.yaml").resolve(Services(memo=KernelMemo()))
    cells = {(c.inputs["scene.lat_deg"], c.inputs["scene.lon_deg"]) for c in resolved.cases}
    assert type(resolved.cases[0].modules[0]) is OldStyleScene
    assert cells and all(a > 0 and b > 12 for a, b in cells)  # the old hook's cells, set up by the old setup
    assert len(reads) == 1  # the old-style set-up reads the map itself (plainly); the old hook reads nothing


def test_a_map_run_reads_the_agb_map_once(tmp_path, reads):
    results = run(_map_scenario(tmp_path, step_deg=5.0), output=tmp_path / "out", progress=False)
    assert (tmp_path / "out" / "results.nc").exists() and len(results.run.cases) > 0
    assert reads == [str((tmp_path / "agb.nc").resolve())]  # resolve, run and results.nc share the one read
