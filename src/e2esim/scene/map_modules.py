"""Scene module ``agb_map``: the forest of one map cell (kind ``scene``; the scene of map sweeps).

The cell's biome comes from the latitude bands of ``e2esim.scene.biome_bands`` (tropical within the Tropics,
boreal 50-70 deg N: an assumption, documented there) and its AGB from a user's AGB map (NetCDF or GeoTIFF,
``e2esim.scene.agb_map``) or, without one, from the band's Table I forest, whose covariance is then used exactly
(Men et al. 2021, Table I). With a map, the covariance is that of ``forest_agb_model`` at the cell's AGB: sigma_hv
on the biome's power law (eq. 15), the co-polarised terms interpolated from Table I (e2esim.scene.agb_model). A
cell with no forest class (outside the bands, outside the map, or no forest in it) is refused with the reason;
a map sweep leaves such cells out beforehand.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from e2esim import products as P
from e2esim.block import Catalog, Factor, Values
from e2esim.errors import ConfigError, PhysicsInputError
from e2esim.module import Stage, fail
from e2esim.params import Param, to_si, validate_section
from e2esim.scene.agb_model import forest_covariance
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.map_forest import FOREST_PARAMS, NO_FOREST, ForestSource, check_forest_point
from e2esim.scene.table1 import TABLE1_FORESTS


class AGBMapScene(Stage):
    """The forest of a latitude/longitude cell: biome by latitude band, AGB from a map or the band's Table I
    forest (module docstring)."""

    kind = "scene"
    type_name = "agb_map"
    summary = ("forest of a lat/lon cell: biome by latitude band, AGB from a NetCDF/GeoTIFF map or the band's "
               "Table I forest (map sweeps)")
    params = (
        Param("lat_deg", "float", "latitude of the cell centre (a map sweep sets it)", unit="deg", minimum=-90.0,
              maximum=90.0, convert=False),
        Param("lon_deg", "float", "east longitude of the cell centre (a map sweep sets it)", unit="deg",
              minimum=-180.0, maximum=360.0, convert=False),
        *FOREST_PARAMS,
    )
    provides = (P.SCENE,)

    case_params = ("lat_deg", "lon_deg")  # a map sweep's cells

    @classmethod
    def map_cells(cls, section, lat_deg, lon_deg, where, services=None):
        """The cells (n_lat, n_lon) this section's latitude bands and AGB map give a forest class (the map read
        through ``services.memo``, the resolve's, which ``setup`` asks again)."""
        config = validate_section(FOREST_PARAMS, section, where, ignore=("type", "lat_deg", "lon_deg"))
        try:
            source = ForestSource.from_si(to_si(FOREST_PARAMS, config), where.source, getattr(services, "memo", None))
        except PhysicsInputError as exc:
            raise ConfigError(exc.location(where), str(exc)) from exc
        biome, _ = source.forest(np.asarray(lat_deg)[:, None], np.asarray(lon_deg)[None, :])
        return biome != ""

    def setup(self, services=None):
        """The forest source (the AGB map read through ``services.memo``, the resolve's; a plain read without
        services) and the scene of the configured cell."""
        c = self.si
        self.source = ForestSource.from_si(c, self.location.source, getattr(services, "memo", None))
        self._scenes, self._codes = Catalog(), {}  # the scene of every forest met so far, and its number there
        self.covariance = self.scene_at(c["lat_deg"], c["lon_deg"])

    def scene_at(self, lat_deg: float, lon_deg: float) -> ScatteringCovariance:
        """The covariance of the cell at (lat, lon) (deg). Raises ``PhysicsInputError`` for a cell without
        forest."""
        return self._scenes[self._code(*check_forest_point(self.source, lat_deg, lon_deg))]

    def _code(self, biome: str, agb_t_ha: float) -> int:
        """The number of the scene of a biome and AGB (t/ha) in ``_scenes``, made once: cells of the same
        forest share it."""
        code = self._codes.get((biome, agb_t_ha))
        if code is None:
            code = self._codes[(biome, agb_t_ha)] = self._scenes.add(self._covariance(biome, agb_t_ha))
        return code

    def _covariance(self, biome: str, agb_t_ha: float) -> ScatteringCovariance:
        if self.source.agb_map is None:
            name = self.source.forest_name(biome)
            _, agb, hh, hv, vv, r, theta = TABLE1_FORESTS[name]
            return ScatteringCovariance.from_powers(hh, hv, vv, r, np.radians(theta), agb_t_ha=agb, biome=biome,
                                                    label=f"{name} (latitude band; Men et al. 2021, Table I)")
        return replace(forest_covariance(biome, agb_t_ha, self.si["exponent"]),
                       label=f"{biome} {agb_t_ha:.4g} t/ha (AGB map)")

    forward_takes_blocks = True

    def forward(self, case):
        """The forest of the case's cell; of every cell of a block at once, each forest's scene made once per run
        (a ``Factor``)."""
        v = self.block_values(case)
        lat, lon = v["lat_deg"].astype(float), v["lon_deg"].astype(float)
        biome, agb = self.source.forest(lat, lon)
        none = np.flatnonzero(biome == NO_FOREST)
        if none.size:  # the message of the first such cell
            try:
                check_forest_point(self.source, lat[none[0]], lon[none[0]])
            except PhysicsInputError as exc:
                raise fail(self, str(exc), key=exc.key) from exc
        forests = Values.of(list(zip(biome.tolist(), agb.tolist())))
        codes = np.array([self._code(b, a) for b, a in forests.values], dtype=np.int64)
        return {"scene.covariance": case.product_of(Factor(self._scenes, codes[forests.index]))}
