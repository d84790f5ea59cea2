"""Module types that take a value from a BIOMASS L1 product instead of a climatology or a preset (issue 26, item
5): the Faraday rotation (kind ``ionosphere``), the noise (kind ``instrument``), the incidence and slant range of
the random-error budget (kind ``propagation``) and the RFI fraction (kind ``error_terms``). docs/real-data.md, "A
scenario driven by a product".

Each names the one file it reads (``lut_file``: the LUT NetCDF; ``annotation_file``: the annotation XML), declared
``input_file`` so that the file read is the file hashed into the run's provenance (``e2esim.input_files.
scenario_relative``). The pixel is the one nearest to ``lat_deg``/``lon_deg``; without them, a map sweep's cell, else
the product's scene centre. A site outside the product, a missing layer or other units end the run with a message
naming the file and the key (exit 2).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from e2esim import products as P
from e2esim.budget.modules import BackscatterErrorBudget
from e2esim.error_terms.modules import MAP_CELL_KEYS
from e2esim.error_terms.rfi_modules import RFITerm
from e2esim.errors import PhysicsInputError, UserError
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.input_files import scenario_relative
from e2esim.instrument.modules import BiomassInstrument
from e2esim.ionosphere.constants import SPEED_OF_LIGHT
from e2esim.module import Stage, fail
from e2esim.params import Param
from e2esim.product_inputs.biomass_site import read_lut_layers
from e2esim.products_io.biomass_annotation import read_annotation

BIOMASS_FREQUENCY_HZ = 435e6
"""The BIOMASS centre frequency (Quegan et al. 2018, Section 5), at which the product's Faraday rotation is given."""
FARADAY, FARADAY_SD = "ionosphereCorrection/faradayRotation", "ionosphereCorrection/faradayRotationStd"
INCIDENCE, TERRAIN_SLOPE = "geometry/incidenceAngle", "geometry/terrainSlope"
DENOISING = tuple(f"denoising/denoising{p}" for p in ("HH", "HV", "VV"))


def _site_params(file_key: str, what: str) -> tuple:
    return (
        Param(file_key, "str", f"the BIOMASS L1 product's {what}, relative to the scenario file", input_file=True),
        Param("lat_deg", "float", "latitude of the site whose pixel is read (null with lon_deg: a map sweep's cell, "
              "else the product's scene centre)", default=None, nullable=True, unit="deg", minimum=-90.0,
              maximum=90.0, convert=False),
        Param("lon_deg", "float", "longitude of the site whose pixel is read", default=None, nullable=True,
              unit="deg", minimum=-180.0, maximum=360.0, convert=False),
    )


class ProductPixel:
    """The pixel a product-driven module reads, for one case (module docstring)."""

    def read_layers(self, names) -> None:
        """Reads the layers ``names`` (``self.lut``) and the site's pixel (``self.site_pixel``; None without a site):
        a bad file or a site outside the product is refused before anything runs."""
        lat, lon = self.si["lat_deg"], self.si["lon_deg"]
        if (lat is None) != (lon is None):
            raise fail(self, "lat_deg and lon_deg go together", "give both, or neither (the scene centre or the "
                       "map sweep's cell)", key="lat_deg" if lat is None else "lon_deg")
        try:
            self.lut = read_lut_layers(scenario_relative(self.si["lut_file"], self.location.source), names)
        except UserError as exc:
            raise fail(self, str(exc), key="lut_file") from None
        self.site_pixel = None if lat is None else self.pixel_of(lat, lon, "lat_deg")

    def pixel_of(self, lat, lon, key):
        try:
            return self.lut.pixel_of(float(lat), float(lon))
        except UserError as exc:
            raise fail(self, str(exc), "a site inside the product, or lat_deg/lon_deg null for its scene centre",
                       key=key) from None

    def values_at(self, case, names) -> tuple:
        """The layers ``names`` at the case's pixel (NaN where the layer holds no data), and the pixel."""
        pixel = self.site_pixel
        if pixel is None:
            lat, lon = case.inputs.get(MAP_CELL_KEYS["lat"]), case.inputs.get(MAP_CELL_KEYS["lon"])
            pixel = self.lut.centre() if lat is None or lon is None else self.pixel_of(lat, lon, "lut_file")
        return tuple(float(self.lut.layers[n][pixel]) for n in names), pixel

    def no_data(self, name, pixel):
        return fail(self, f"{self.lut.path}: {name} holds no data at pixel (row {pixel[0]}, column {pixel[1]}), "
                    f"latitude {self.lut.latitude[pixel]:.6g}, longitude {self.lut.longitude[pixel]:.6g} deg",
                    "a site where the product holds data", key="lut_file")


class ProductFaraday(ProductPixel, Stage):
    """The one-way Faraday rotation Omega of a BIOMASS L1 product's LUT at one pixel: the processor's estimate
    (``ionosphereCorrection/faradayRotation``, rad) as the mean of a Gaussian (Men et al. 2021, Section III item 4,
    eq. 10) whose SD is the product's ``faradayRotationStd`` where it holds one, else ``sd_deg``. Given at 435 MHz;
    scaled by (435 MHz / f_radar)^2 to another instrument's frequency (Omega goes as 1/f^2, Quegan et al. 2018,
    eq. 3)."""

    kind = "ionosphere"
    type_name = "biomass_product_faraday"
    summary = "Faraday rotation from a BIOMASS L1 product's LUT at a site, its scene centre or a map cell"
    params = (*_site_params("lut_file", "LUT NetCDF"),
              Param("sd_deg", "float", "SD of Omega where the product's faradayRotationStd is empty (the BPS leaves it "
                    "empty): the rotation's spread about the product's estimate", default=0.0, unit="deg",
                    minimum=0.0, maximum=180.0))
    uses = ("instrument",)
    provides = (P.FARADAY,)

    def setup(self):
        self.read_layers((FARADAY, FARADAY_SD))

    def forward(self, case):
        (mean, sd), pixel = self.values_at(case, (FARADAY, FARADAY_SD))
        if not np.isfinite(mean):
            raise self.no_data(FARADAY, pixel)
        sd = sd if np.isfinite(sd) else self.si["sd_rad"]
        k = 1.0 if "instrument" not in case else (BIOMASS_FREQUENCY_HZ / case["instrument"].centre_frequency_hz) ** 2
        return {"faraday.geophysical": GaussianFaraday(k * mean, k * sd)}


class BiomassProductNoise(ProductPixel, BiomassInstrument):
    """The BIOMASS instrument preset with its noise from the product: the noise power the processor removed
    (LUT ``denoising/denoisingHH``, ``HV``, ``VV``, linear, as sigma0), the mean of the three channels as the NESZ
    sigma_n of every channel (as ``e2esim uncertainty`` takes it)."""

    type_name = "biomass_product_noise"
    summary = "BIOMASS instrument preset with the NESZ of a BIOMASS L1 product's denoising LUT at a site"
    params = (*(p for p in BiomassInstrument.params if getattr(p, "name", None) != "nesz_db"),
              *_site_params("lut_file", "LUT NetCDF"))

    def derive(self, si: dict) -> dict:
        return super().derive({**si, "nesz_linear": None})

    def setup(self):
        super().setup()
        self.read_layers(DENOISING)

    def forward(self, case):
        values, pixel = self.values_at(case, DENOISING)
        for name, value in zip(DENOISING, values):
            if not (np.isfinite(value) and value > 0):
                raise self.no_data(name, pixel)
        noise = float(np.mean(values))
        return {"system": dataclasses.replace(self.model, noise_power=noise),
                "instrument": dataclasses.replace(self.description, nesz_db=float(10 * np.log10(noise)))}


class ProductIncidenceBudget(ProductPixel, BackscatterErrorBudget):
    """The random-error budget of Ahmed et al. (2014) (``backscatter_error_budget``) at the local incidence of a
    BIOMASS L1 product's LUT (``geometry/incidenceAngle``, deg) at the pixel, the incidence theta_i of the looks
    (eq. 22) and of the area projection (eq. 37), and at its slant range rho = c tau / 2 (eq. 35), tau the pixel's
    two-way slant-range time (``slantRangeTimeRGC``, s). The BPS computes the incidence on the ellipsoid and
    ``geometry/terrainSlope`` as that incidence minus the incidence on the DEM (deg, ``compute_geometric_lut``): the
    slope tau_rho in the plane of incidence, towards the radar positive, which is the cross-track slope of eq. (37)
    (local incidence theta_i - tau_rho); with ``slope_range_from_product`` (the default) it replaces the scenario's
    or the preset's ``slope_range_deg``. The azimuth slope tau_s is not in the product: the scenario's or the
    preset's stays."""

    type_name = "backscatter_error_budget_from_product"
    summary = "random-error budget (Ahmed et al. 2014) at the incidence of a BIOMASS L1 product's LUT at a site"
    params = (*BackscatterErrorBudget.params, *_site_params("lut_file", "LUT NetCDF"),
              Param("slope_range_from_product", "bool", "take the cross-track slope tau_rho from the product's "
                    "geometry/terrainSlope (false: the scenario's or the preset's observation.slope_range_deg)",
                    default=True))
    forward_takes_blocks = False

    def setup(self):
        from_product = {"incidence_deg": "incidence_rad", "slant_range_km": "slant_range_m",
                        "altitude_km": "altitude_m"}
        if self.si["slope_range_from_product"]:
            from_product["slope_range_deg"] = "slope_range_rad"
        for key, si_key in from_product.items():
            if self.si["observation"][si_key] is not None:
                slope = key == "slope_range_deg"
                what = "the cross-track slope comes" if slope else "the incidence and slant range come"
                allowed = ", or slope_range_from_product: false" if slope else ""
                raise fail(self, f"observation.{key} is given, but {what} from the product",
                           f"leave it out{allowed}", key="observation")
        super().setup()
        self.layers = (INCIDENCE, TERRAIN_SLOPE) if self.si["slope_range_from_product"] else (INCIDENCE,)
        self.read_layers(self.layers)

    def forward(self, case):
        self.refuse_speckle_twice(case)
        (incidence_deg, *slope_deg), pixel = self.values_at(case, self.layers)
        if not 0.0 < incidence_deg < 90.0:
            raise self.no_data(INCIDENCE, pixel)
        changes = {"incidence_rad": float(np.radians(incidence_deg)),
                   "slant_range_m": SPEED_OF_LIGHT * float(self.lut.slant_range_time[pixel[1]]) / 2}
        if slope_deg:
            if not -90.0 < slope_deg[0] < incidence_deg:
                raise self.no_data(TERRAIN_SLOPE, pixel)
            changes["slope_range_rad"] = float(np.radians(slope_deg[0]))
        try:
            return {"backscatter.budget": self.budget_of(case["scene.covariance"],
                                                         self.inputs_for(case).replace(**changes))}
        except PhysicsInputError as exc:
            raise fail(self, f"case {case.index}: {exc}") from exc


class ProductRFI(RFITerm):
    """The ``rfi`` error term with the blanked share of the aperture time f_t from a BIOMASS L1 annotation: the
    largest ``rfiMitigation/rfiTMReportList/rfiTMReport/percentageAffectedLines`` over the polarisations (the lines
    the time-domain mitigation removed; the largest, since one estimate combines the channels). The rest is the
    ``rfi`` term's (e2esim.error_terms.rfi_modules)."""

    type_name = "rfi_from_product"
    summary = "RFI after mitigation with the blanked time fraction of a BIOMASS L1 annotation's RFI reports"
    params = (*(p for p in RFITerm.params if getattr(p, "name", None) != "time_fraction_percent"),
              Param("annotation_file", "str", "the BIOMASS L1 product's annotation XML, relative to the scenario "
                    "file", input_file=True))

    def derive(self, si: dict) -> dict:
        return super().derive({**si, "time_fraction_fraction": 0.0})

    def setup(self) -> None:
        super().setup()
        path = scenario_relative(self.si["annotation_file"], self.location.source)
        try:
            reports = read_annotation(path)["rfi_percent"]
        except UserError as exc:
            raise fail(self, str(exc), key="annotation_file") from None
        if not reports:
            raise fail(self, f"{path}: the annotation holds no RFI report (rfiMitigation/rfiTMReportList is empty: "
                       "the processor ran no time-domain mitigation)", "a product with RFI reports, or the rfi "
                       "term with time_fraction_percent", key="annotation_file")
        worst = max(reports.values())
        if not 0.0 <= worst < 100.0:
            raise fail(self, f"{path}: percentageAffectedLines {worst!r} %", "0 to below 100 %",
                       key="annotation_file")
        self.time_fraction_value = worst / 100.0

    def time_fraction(self, case) -> float:
        return self.time_fraction_value


__all__ = ["BiomassProductNoise", "ProductFaraday", "ProductIncidenceBudget", "ProductPixel", "ProductRFI"]
