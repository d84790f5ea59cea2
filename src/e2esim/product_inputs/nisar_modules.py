"""Module types that take a value from a NISAR product (GCOV, GSLC or RSLC; ``e2esim.product_inputs.nisar_site``)
instead of a climatology or a preset (issue 26, item 5): the instrument's noise and crosstalk (kind
``instrument``), the Faraday rotation (kind ``ionosphere``) and the RFI term's blanked time (kind
``error_terms``). docs/real-data.md, "A scenario driven by a product".

Each names the HDF5 file it reads (``product_file``, relative to the scenario file; declared ``input_file`` so it is
hashed into the run's provenance). The pixel is the one nearest to ``lat_deg``/``lon_deg`` (a GCOV or GSLC); without
them, the product's scene centre. The product is read once, when the module is set up: a bad file, a site outside the
product or a correction the product did not apply where the module needs its value ends the run before anything runs,
with a message naming the file and the key (exit 2).
"""

from __future__ import annotations

import dataclasses

from e2esim import products as P
from e2esim.error_terms.rfi_modules import RFITerm
from e2esim.errors import UserError
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.input_files import scenario_relative
from e2esim.instrument.modules import NisarInstrument
from e2esim.module import Stage, fail
from e2esim.params import Param
from e2esim.product_inputs.nisar_site import read_nisar_pixel
from e2esim.units import level_db_from_variance, linear_to_db

PRODUCT_FILE = Param("product_file", "str", "the NISAR GCOV, GSLC or RSLC HDF5 file, relative to the scenario file",
                     input_file=True)


SITE_PARAMS = tuple(
    Param(name, "float", what, default=None, nullable=True, unit="deg", minimum=low, maximum=high, convert=False)
    for name, what, low, high in (
        ("lat_deg", "latitude of the site whose pixel is read (null with lon_deg: the product's scene centre; an "
         "RSLC: only its scene centre)", -90.0, 90.0),
        ("lon_deg", "longitude of the site whose pixel is read", -180.0, 360.0)))


def _site_params() -> tuple:
    return (PRODUCT_FILE, *SITE_PARAMS)


class _NisarPixel:
    """Reads the product's pixel once (``self.pixel``), refusing a bad file or site as the module's error."""

    def read_pixel(self, site: bool = True) -> None:
        lat, lon = (self.si["lat_deg"], self.si["lon_deg"]) if site else (None, None)
        if (lat is None) != (lon is None):
            raise fail(self, "lat_deg and lon_deg go together", "give both, or neither (the scene centre)",
                       key="lat_deg" if lat is None else "lon_deg")
        try:
            self.pixel = read_nisar_pixel(scenario_relative(self.si["product_file"], self.location.source), lat, lon)
        except UserError as exc:
            raise fail(self, str(exc), key="lat_deg" if "lies outside" in str(exc) else "product_file") from None


class NisarProductInstrument(_NisarPixel, NisarInstrument):
    """The NISAR instrument preset with the product's noise and crosstalk at the pixel: the NESZ sigma_n of every
    channel the mean of the product's ``nes0`` HH, HV and VV; the crosstalk variance V_delta the mean |delta_k|^2 of
    its four crosstalk tables (equal terms, the preset's correlations), the level of the crosstalk in the data before
    calibration. Tables of zeros (the processor measured and applied none): the preset's crosstalk stays, its full
    error counted."""

    type_name = "nisar_product_instrument"
    summary = "NISAR instrument preset with the NESZ and crosstalk of a NISAR product (GCOV, GSLC, RSLC) at a site"
    params = (*(p for p in NisarInstrument.params if getattr(p, "name", None) != "nesz_db"), *_site_params())

    def derive(self, si: dict) -> dict:
        return super().derive({**si, "nesz_linear": None})

    def setup(self):
        super().setup()
        self.read_pixel()
        px = self.pixel
        model = dataclasses.replace(self.model, noise_power=px.noise_power)
        description = dataclasses.replace(self.description, nesz_db=float(linear_to_db(px.noise_power)))
        if px.crosstalk_variance is not None:
            model = dataclasses.replace(model, crosstalk_level=px.crosstalk_variance,
                                        crosstalk_relative=(1.0, 1.0, 1.0, 1.0))
            description = dataclasses.replace(description, crosstalk_db=float(level_db_from_variance(
                px.crosstalk_variance, self.si["crosstalk"]["convention"])))
        self.model, self.description = model, description


class NisarProductFaraday(_NisarPixel, Stage):
    """The one-way Faraday rotation a NISAR product's processor removed (``faradayRotation``, rad, at 1257.5 MHz) as
    the mean of a Gaussian (Men et al. 2021, Section III item 4, eq. 10) of SD ``sd_deg``, scaled by
    (1257.5 MHz / f_radar)^2 to another instrument's frequency (Omega goes as 1/f^2, Quegan et al. 2018, eq. 3).
    A product that applied no correction (0.0, as the operational products carry it) holds no rotation: refused."""

    kind = "ionosphere"
    type_name = "nisar_product_faraday"
    summary = "Faraday rotation removed by a NISAR product's processor (calibrationInformation faradayRotation)"
    params = (*_site_params(),
              Param("sd_deg", "float", "SD of Omega about the product's value (one product is one acquisition)",
                    default=0.0, unit="deg", minimum=0.0, maximum=180.0))
    uses = ("instrument",)
    provides = (P.FARADAY,)

    def setup(self):
        self.read_pixel()
        if self.pixel.faraday_rad == 0.0:
            raise fail(self, f"{self.pixel.path}: faradayRotation is 0.0: the processor applied no Faraday-rotation "
                       "correction, so the product holds no rotation (0.0 means 'not applied', not 'none')",
                       "a product whose processor removed a rotation, or a climatology (global_climatology)",
                       key="product_file")

    def forward(self, case):
        f = self.pixel.frequency_hz
        k = 1.0 if "instrument" not in case else (f / case["instrument"].centre_frequency_hz) ** 2
        return {"faraday.geophysical": GaussianFaraday(k * self.pixel.faraday_rad, k * self.si["sd_rad"])}


class NisarProductRFI(_NisarPixel, RFITerm):
    """The ``rfi`` error term with the blanked share of the aperture time f_t the largest finite ``rfiLikelihood``
    of a NISAR product over its polarisations (``e2esim.products_io.nisar_budget_terms``: the likelihood read as the
    share of time whose interference was mitigated, an upper bound), a figure of the whole product. The rest is the
    ``rfi`` term's (its lat_deg/lon_deg place a fraction_map, as there)."""

    type_name = "rfi_from_nisar_product"
    summary = "RFI after mitigation with the blanked time fraction from a NISAR product's rfiLikelihood"
    params = (*(p for p in RFITerm.params if getattr(p, "name", None) != "time_fraction_percent"), PRODUCT_FILE)

    def derive(self, si: dict) -> dict:
        return super().derive({**si, "time_fraction_fraction": 0.0})

    def setup(self) -> None:
        super().setup()
        self.read_pixel(site=False)
        if self.pixel.rfi_fraction is None:
            raise fail(self, f"{self.pixel.path}: every rfiLikelihood is NaN: the processor skipped RFI detection, "
                       "so the product says nothing of the interference", "a product with RFI detection, or the rfi "
                       "term with time_fraction_percent", key="product_file")
        if not 0.0 <= self.pixel.rfi_fraction < 1.0:
            raise fail(self, f"{self.pixel.path}: rfiLikelihood {self.pixel.rfi_fraction!r}", "0 to below 1",
                       key="product_file")

    def time_fraction(self, case) -> float:
        return self.pixel.rfi_fraction


__all__ = ["NisarProductFaraday", "NisarProductInstrument", "NisarProductRFI"]
