"""The forest of a map cell: biome and AGB at a latitude and longitude, from the default latitude bands
(``e2esim.scene.biome_bands``) or from a user's AGB map (``e2esim.scene.agb_map``).

``FOREST_PARAMS`` declare the source once; the scene module ``agb_map`` (one cell) and the map sweep (every
cell, to leave out those without forest) read them through ``ForestSource``, vectorised over cells, so both
agree on which cells are forest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.input_files import scenario_relative
from e2esim.params import Ordered, Param
from e2esim.scene.agb_map import AGBMap, read_agb_map
from e2esim.scene.biome_bands import BOREAL_LAT_RANGE_DEG, DEFAULT_FORESTS, NO_FOREST, TROPIC_LAT_DEG, band_biome
from e2esim.scene.biome_power_laws import BIOME_EXPONENTS
from e2esim.scene.table1 import TABLE1_FORESTS

_TROPICAL = tuple(k for k, v in TABLE1_FORESTS.items() if v[0] == "tropical")
_BOREAL = tuple(k for k, v in TABLE1_FORESTS.items() if v[0] == "boreal")

FOREST_PARAMS = (
    Param("file", "str", "AGB map (NetCDF or GeoTIFF on a lat/lon grid, t/ha; e2esim.scene.agb_map), relative to the "
          "scenario file; null: the default forest of each latitude band (its Table I forest)", default=None,
          nullable=True, input_file=True),
    Param("variable", "str", "the AGB variable of a NetCDF map", default="agb"),
    Param("tropical_lat_deg", "float", "tropical band: |latitude| up to this (the Tropics, 23.44 deg)",
          default=TROPIC_LAT_DEG, unit="deg", minimum=0.0, maximum=90.0, convert=False),
    Param("boreal_lat_range_deg", "float", "boreal band: these northern latitudes (circumboreal forest, about "
          "50-70 deg N)", default=BOREAL_LAT_RANGE_DEG, unit="deg", length=2, minimum=-90.0, maximum=90.0,
          convert=False),
    Param("tropical_forest", "str", "Table I forest of the tropical band (its AGB and covariance without a map)",
          default=DEFAULT_FORESTS["tropical"], choices=_TROPICAL),
    Param("boreal_forest", "str", "Table I forest of the boreal band (its AGB and covariance without a map)",
          default=DEFAULT_FORESTS["boreal"], choices=_BOREAL),
    Param("temperate_biome", "str", "biome whose model stands in for forest outside both bands (null: such cells "
          "have no forest class)", default=None, nullable=True, choices=tuple(BIOME_EXPONENTS)),
    Param("exponent", "float", "power-law exponent p of sigma_hv(AGB) with an AGB map; null: the biome's (2.2, 1.9)",
          default=None, exclusive_minimum=0.0, nullable=True),
    Ordered("boreal_lat_range_deg"),
)


@dataclass(frozen=True)
class ForestSource:
    """Where a cell's forest comes from: the bands, and an AGB map or the bands' Table I forests."""

    tropical_lat_deg: float = TROPIC_LAT_DEG
    boreal_lat_range_deg: tuple = BOREAL_LAT_RANGE_DEG
    forests: tuple = tuple(DEFAULT_FORESTS.items())  # ((biome, Table I forest), ...)
    temperate_biome: str | None = None
    agb_map: AGBMap | None = None

    @classmethod
    def from_si(cls, si, scenario_file: str = "", memo=None) -> ForestSource:
        """From the SI values of ``FOREST_PARAMS`` (reads the AGB map, once per file version with ``memo``, the
        process's ``KernelMemo``; a relative path is relative to ``scenario_file``'s folder when that file
        exists)."""
        agb_map = None
        if si["file"]:
            agb_map = read_agb_map(scenario_relative(si["file"], scenario_file), si["variable"], memo)
        return cls(float(si["tropical_lat_deg"]), tuple(si["boreal_lat_range_deg"]),
                   (("tropical", si["tropical_forest"]), ("boreal", si["boreal_forest"])), si["temperate_biome"],
                   agb_map)

    def forest_name(self, biome: str) -> str:
        """The Table I forest of ``biome`` (that of its band)."""
        return dict(self.forests)[biome]

    def biome(self, lat_deg) -> np.ndarray:
        """Biome of each latitude (strings, "" for none)."""
        return band_biome(lat_deg, self.tropical_lat_deg, self.boreal_lat_range_deg, self.temperate_biome)

    def forest(self, lat_deg, lon_deg) -> tuple:
        """(biome, AGB in t/ha) of each point (deg, broadcast): biome "" and AGB NaN where no forest (outside the
        bands, outside the AGB map, or no forest in it)."""
        lat, lon = np.broadcast_arrays(np.asarray(lat_deg, float), np.asarray(lon_deg, float))
        biome = self.biome(lat)
        if self.agb_map is None:
            table_agb = {b: TABLE1_FORESTS[name][1] for b, name in self.forests}
            agb = np.array([table_agb.get(b, np.nan) for b in biome.ravel()], float).reshape(lat.shape)
        else:
            agb = self.agb_map.lookup(lat, lon)
        none = (biome == NO_FOREST) | ~np.isfinite(agb)
        biome = np.where(none, NO_FOREST, biome)
        return biome, np.where(none, np.nan, agb)

    def why_no_forest(self, lat_deg: float, lon_deg: float) -> str:
        """Why the point has no forest class (for messages)."""
        if self.biome(lat_deg)[()] == NO_FOREST:
            low, high = self.boreal_lat_range_deg
            return (f"latitude {lat_deg:g} deg is in no forest band (tropical: |latitude| <= {self.tropical_lat_deg:g} "
                    f"deg; boreal: {low:g} to {high:g} deg N) and temperate_biome is null")
        m = self.agb_map
        if m is not None and not m.covers(lat_deg, lon_deg)[()]:
            return (f"({lat_deg:g}, {lon_deg:g}) deg is outside the AGB map {m.source} (latitude {m.lat_deg[0]:g} to "
                    f"{m.lat_deg[-1]:g}, longitude {m.lon_deg[0]:g} to {m.lon_deg[-1]:g} deg, pixel centres)")
        return f"the AGB map {m.source} has no forest (no value, or AGB <= 0) at ({lat_deg:g}, {lon_deg:g}) deg"


def check_forest_point(source: ForestSource, lat_deg: float, lon_deg: float) -> tuple:
    """(biome, AGB in t/ha) at one point; ``PhysicsInputError`` (key ``lat_deg``) saying why if it has none."""
    biome, agb = source.forest(lat_deg, lon_deg)
    if biome[()] == NO_FOREST:
        raise PhysicsInputError(f"no forest class here: {source.why_no_forest(lat_deg, lon_deg)}", key="lat_deg")
    return str(biome[()]), float(agb[()])
