"""The documented default forest of a map cell: a biome by latitude band, with a Table I forest.

Men et al. (2021), Table I, gives P-band covariances of two biomes only, boreal and tropical, so the default
assigns one of them by latitude and leaves every other latitude without a forest class:

* **tropical**: |latitude| <= 23.44 deg, between the Tropics of Cancer and Capricorn (the obliquity of the
  ecliptic, 23.44 deg for 2000-2030). The tropical moist and dry forests of the FAO Global Ecological Zones
  (FAO 2012, *Global ecological zones for FAO forest reporting: 2010 update*, Forest Resources Assessment
  Working Paper 179) lie within about this band.
* **boreal**: 50 deg N to 70 deg N, the approximate latitudinal extent of the circumboreal forest (taiga)
  (Brandt et al. 2013, *An introduction to Canada's boreal zone*, Environ. Rev. 21, 207-226; Gauthier et al.
  2015, *Boreal forest health and global change*, Science 349, 819-822). There is no boreal forest in the
  southern hemisphere.
* the temperate latitudes between these bands, the far north beyond 70 deg N and the south beyond 23.44 deg S
  have no Table I preset: no forest class (the cell is left out of a map), unless ``temperate_biome`` names a
  biome whose Table I model stands in for them.

The bands are an **assumption** of e2esim about which biome a forest stands for, not a forest map: on their
own they call every land cell in a band forest, deserts and tundra included. Map sweeps take where forest is
from a land-cover product (``sweep.map.forest_cover``, the MODIS 2019 IGBP classes of
``e2esim.scene.forest_cover``), or from an AGB map (``e2esim.scene.agb_map``). The default AGB of a band is
that of its Table I forest (boreal_200: 200 t/ha; tropical_338: 338 t/ha, TropiSAR), whose covariance is used
exactly.
"""

from __future__ import annotations

import numpy as np

TROPIC_LAT_DEG = 23.44
"""Latitude of the Tropics of Cancer and Capricorn (deg), the obliquity of the ecliptic for 2000-2030."""

BOREAL_LAT_RANGE_DEG = (50.0, 70.0)
"""Northern latitudes of the boreal band (deg): the approximate extent of the circumboreal forest."""

DEFAULT_FORESTS = {"tropical": "tropical_338", "boreal": "boreal_200"}
"""The Table I forest of each band by default (Men et al. 2021, Table I)."""

NO_FOREST = ""
"""The biome of a cell without a forest class."""


def band_biome(lat_deg, tropical_lat_deg: float = TROPIC_LAT_DEG, boreal_lat_range_deg=BOREAL_LAT_RANGE_DEG,
               other_biome: str | None = None) -> np.ndarray:
    """The biome of each latitude (deg, any shape): "tropical" within ``tropical_lat_deg`` of the equator,
    "boreal" within ``boreal_lat_range_deg`` (north), ``other_biome`` elsewhere, or ``NO_FOREST`` ("") where
    ``other_biome`` is None. An array of strings of the shape of ``lat_deg``."""
    lat = np.asarray(lat_deg, float)
    out = np.full(lat.shape, other_biome or NO_FOREST, dtype=object)
    low, high = boreal_lat_range_deg
    out[(lat >= low) & (lat <= high)] = "boreal"
    out[np.abs(lat) <= tropical_lat_deg] = "tropical"
    return out
