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
from e2esim.module import Stage
from e2esim.params import Param
from e2esim.scene.agb_model import forest_covariance
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.map_forest import FOREST_PARAMS, ForestSource, check_forest_point
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

    def setup(self):
        c = self.si
        source = ForestSource.from_si(c, self.location.source)
        self.biome, self.agb_t_ha = check_forest_point(source, c["lat_deg"], c["lon_deg"])
        where = f"at {c['lat_deg']:g}N {c['lon_deg']:g}E"
        if source.agb_map is None:
            name = source.forest_name(self.biome)
            _, agb, hh, hv, vv, r, theta = TABLE1_FORESTS[name]
            self.covariance = ScatteringCovariance.from_powers(
                hh, hv, vv, r, np.radians(theta), agb_t_ha=agb, biome=self.biome,
                label=f"{name} {where} (latitude band; Men et al. 2021, Table I)")
        else:
            self.covariance = replace(forest_covariance(self.biome, self.agb_t_ha, c["exponent"]),
                                      label=f"{self.biome} {self.agb_t_ha:.4g} t/ha {where} (AGB map)")

    def forward(self, case):
        return {"scene.covariance": self.covariance}
