"""The TEC of a BIOMASS L1 product as the ionosphere of a scenario (issue 26, item 5): module type
``biomass_product_tec`` (kind ``ionosphere``). docs/real-data.md, "A scenario driven by a product".

What the layer is (BioPAL BPS v4.3.0, ``bps-transcoder/bps/transcoder/sarproduct/l1_lut_writer.py``):
``ionosphereCorrection/tec`` is ``_phase_screen_to_tec`` of the Bickel-Bates phase screen ``phaseScreen`` (rad, the
two-way ionospheric phase of the radar signal, on the SLC axes): ``tec = TEC_FACTOR / PHI_FACTOR / 1e16 * phi``
with ``TEC_FACTOR / PHI_FACTOR = c f / (4 pi zeta)``, f = 435 MHz and ``zeta = c h / (4 pi^2 m_e alpha^-1)
= e^2 / (8 pi^2 eps0 m_e) = 40.31 m^3/s^2``. That inverts the two-way phase advance phi = 4 pi zeta STEC / (c f)
along the radar's line of sight, so the layer is the **slant** TEC of the line of sight, in **TECU** (10^16
electrons/m^2; the writer's units attribute "TECU").

How the chain takes it: the thin-shell model of ``user_tec`` (``e2esim.faraday.climatology_modules``), with the
vertical TEC at the product's pierce point from the product's own line of sight, VTEC = STEC cos z', where
sin z' = (R + h) sin theta / (R + H) (the single-layer mapping function: r sin z is constant along a straight ray
in a spherically symmetric shell geometry; R the mean Earth radius, as ``ray_points``; h the pixel's height,
``geometry/height``; theta its incidence on the ellipsoid, ``geometry/incidenceAngle``; H the shell height). Each
acquisition of the scenario's geometry then sees STEC_i = VTEC / cos z_i and Omega_i = K B.k_i STEC_i / f^2 at its
own pierce point (Quegan et al. 2018, eq. 3, thin shell); an acquisition along the product's line of sight gets the
product's STEC back. One product is one acquisition: the day-to-day variability about it is 0 unless
``tec_variability`` gives one.
"""

from __future__ import annotations

import numpy as np

from e2esim.faraday.climatology_modules import UserTECModule
from e2esim.orbit.frames import EARTH_MEAN_RADIUS
from e2esim.params import Param, with_defaults
from e2esim.product_inputs.modules import INCIDENCE, ProductPixel

TEC, HEIGHT = "ionosphereCorrection/tec", "geometry/height"
TECU_EL_M2 = 1e16
"""Electrons/m^2 in one TECU."""


def vertical_from_slant(stec, incidence_rad, height_m, shell_height_m):
    """VTEC = STEC cos z', sin z' = (R + h) sin theta / (R + H): the thin-shell (single-layer) mapping of a slant TEC
    along a line of sight of incidence theta at a point of height h, to the vertical at the shell height H
    (module docstring). Any consistent TEC unit."""
    sin_z = (EARTH_MEAN_RADIUS + np.asarray(height_m)) * np.sin(incidence_rad) / (EARTH_MEAN_RADIUS + shell_height_m)
    return np.asarray(stec) * np.sqrt(1.0 - sin_z ** 2)


class ProductTEC(ProductPixel, UserTECModule):
    """Faraday rotation from a BIOMASS L1 product's slant TEC (LUT ``ionosphereCorrection/tec``, TECU) at one pixel:
    mapped to the vertical with the pixel's incidence and height (LUT ``geometry``), then along each acquisition of
    the scenario's geometry by the thin shell, as ``user_tec`` (module docstring)."""

    type_name = "biomass_product_tec"
    summary = "Faraday rotation from the slant TEC of a BIOMASS L1 product's LUT at a site, along each line of sight"
    params = (
        Param("lut_file", "str", "the BIOMASS L1 product's LUT NetCDF, relative to the scenario file", input_file=True),
        Param("lat_deg", "float", "latitude of the site whose pixel is read (null with lon_deg: a map sweep's cell, "
              "else the product's scene centre)", default=None, nullable=True, unit="deg", minimum=-90.0,
              maximum=90.0, convert=False),
        Param("lon_deg", "float", "longitude of the site whose pixel is read", default=None, nullable=True,
              unit="deg", minimum=-180.0, maximum=360.0, convert=False),
        *with_defaults((p for p in UserTECModule.params if getattr(p, "name", None) != "vtec_tecu"),
                       {"tec_variability": 0.0}),
    )

    def setup(self):
        super().setup()
        self.read_layers((TEC, INCIDENCE, HEIGHT))

    def case_integrals(self, case):
        """The thin-shell integrals with the vertical TEC of the case's pixel, handed to ``integrals`` (nothing of
        the case is kept on the module: cases may run interleaved, e.g. in threads)."""
        (stec_tecu, incidence_deg, height_m), pixel = self.values_at(case, (TEC, INCIDENCE, HEIGHT))
        if not (np.isfinite(stec_tecu) and stec_tecu >= 0):
            raise self.no_data(TEC, pixel)
        if not 0.0 <= incidence_deg < 90.0:
            raise self.no_data(INCIDENCE, pixel)
        if not np.isfinite(height_m):
            raise self.no_data(HEIGHT, pixel)
        vtec = float(vertical_from_slant(stec_tecu * TECU_EL_M2, np.radians(incidence_deg), height_m,
                                         self.si["shell_height_m"]))
        return self.integrals(case["geometry"], case.services.cache_for(self.cache_setting),
                              vertical_tec=lambda geometry, lat, lon: np.full(np.shape(lat), vtec))

    def vertical_tec(self, geometry, lat, lon):
        raise TypeError("biomass_product_tec: the vertical TEC depends on the case's pixel; it is handed to "
                        "integrals by case_integrals")


__all__ = ["ProductTEC", "vertical_from_slant"]
