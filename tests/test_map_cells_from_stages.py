"""A map sweep asks the scenario's stages which cells and latitudes they cover (issue 27, Build 5: the maps wing
reaches the physics through the stages, ``Stage.map_cells`` and ``Stage.map_latitudes_seen``), so a plug-in scene
or ionosphere restricts a map as the built-in ``agb_map`` and ``global_climatology`` do."""

from __future__ import annotations

import numpy as np

from e2esim.errors import Location
from e2esim.faraday.global_lookup import GlobalClimatologyLookup
from e2esim.maps import grid as map_grid_module
from e2esim.maps.grid import map_grid, map_table
from e2esim.runner.scenario import Scenario
from e2esim.scene.map_modules import AGBMapScene
from quick_runs import SCENARIOS

WHERE = Location("t.yaml", ("sweep", "map"))


class NorthernForest(AGBMapScene):
    """A plug-in scene with forest north of the equator only."""

    @classmethod
    def map_cells(cls, section, lat_deg, lon_deg, where):
        return np.broadcast_to((np.asarray(lat_deg) > 0)[:, None], (np.size(lat_deg), np.size(lon_deg)))


class DawnSouthOnly(GlobalClimatologyLookup):
    """A plug-in ionosphere whose dawn pass sees the southern hemisphere only."""

    @classmethod
    def map_latitudes_seen(cls, section, lat_deg, passes, where):
        return {p: np.asarray(lat_deg) < 0 if p == "dawn" else np.ones(np.size(lat_deg), bool) for p in passes}


def _scenario(monkeypatch, scene=None, ionosphere=None):
    raw = Scenario.load(SCENARIOS / "biomass_global_map.yaml").raw
    section = dict(raw["sweep"]["map"], forest_cover="none", step_deg=10, lat_range_deg=[-30, 30],
                   lon_range_deg=[0, 40], passes=["dawn", "dusk"])
    raw = dict(raw, ionosphere=dict(raw["ionosphere"], grid_step_deg=10))
    classes = {"scene": scene, "ionosphere": ionosphere}
    lookup = map_grid_module.registry.lookup
    monkeypatch.setattr(map_grid_module.registry, "lookup",
                        lambda kind, name: classes.get(kind) or lookup(kind, name))
    return section, raw


def test_a_plugin_scene_says_which_cells_are_forest(monkeypatch):
    section, raw = _scenario(monkeypatch, scene=NorthernForest)
    grid = map_grid(section, WHERE, raw)
    lat = np.broadcast_to(grid.lat_deg[:, None], grid.swept.shape)
    assert grid.swept.any() and np.all(lat[grid.swept] > 0)


def test_the_built_in_scene_keeps_southern_forest(monkeypatch):
    section, raw = _scenario(monkeypatch)
    grid = map_grid(section, WHERE, raw)
    lat = np.broadcast_to(grid.lat_deg[:, None], grid.swept.shape)
    assert np.any(lat[grid.swept] < 0) and np.any(lat[grid.swept] > 0)


def test_a_plugin_ionosphere_says_which_latitudes_each_pass_sees(monkeypatch):
    section, raw = _scenario(monkeypatch, ionosphere=DawnSouthOnly)
    grid = map_grid(section, WHERE, raw)
    assert np.array_equal(grid.seen["dawn"], grid.lat_deg < 0) and grid.seen["dusk"].all()
    groups, table = map_table(section, WHERE, raw)
    cells, passes = groups[0][1], [p for (p,) in groups[2][1]]
    dawn = table[table[:, 2] == passes.index("dawn")]
    assert len(dawn) and all(cells[c][0] < 0 for c in dawn[:, 0])
