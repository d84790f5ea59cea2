"""The NISAR RSLC and GSLC product layouts that ``e2esim.products_io.nisar_slc`` reads: one place for the paths,
units and conventions it relies on (the test writer in tests/ checks its files against this module).

Sources (isce3 commit e065414, Apache-2.0):

* GSLC: the NISAR L2 GSLC product specification as isce3 ships it (``python/packages/nisar/products/XML/L2/
  nisar_L2_GSLC.xml``, specification 1.3.0), written by ``nisar/products/writers/BaseL2WriterSingleInput.py``
  (``populate_calibration_information``, ``populate_orbit``).
* RSLC: isce3 ships no XML specification of the L1 RSLC; its layout is the one its writer produces
  (``python/packages/nisar/products/writers/SLC.py``: ``create_image``, ``update_swath``,
  ``add_calibration_section``, ``set_calibration``, ``set_rfi_results``, ``set_nesz``, ``set_orbit``), which the
  L2 writer above reads back (``/science/LSAR/RSLC/...``).

Under ``/science/LSAR/<PRODUCT>``:

* the image: RSLC ``swaths/frequencyA/{HH,HV,VV}`` (complex, units "1") on ``swaths/zeroDopplerTime`` (units
  "seconds since YYYY-mm-ddTHH:MM:SS") x ``swaths/frequencyA/slantRange`` ("meters"), with
  ``numberOfSubSwaths`` and ``validSamplesSubSwath<i>`` ((lines, 2): the [first, last + 1) valid sample of each
  line); GSLC ``grids/frequencyA/{HH,HV,VV}`` on ``yCoordinates`` x ``xCoordinates`` ("meters") in the EPSG of
  ``projection``, with ``mask`` (uint8: 255 fill, 0 invalid);
* ``metadata/calibrationInformation/crosstalk/{tx,rx}{Horizontal,Vertical}Crosspol`` (complex, "1"): the RSLC
  writes them against ``crosstalk/slantRange`` ("meters"), all zero ("TODO Populate crosstalk with real values");
  the L2 writer copies the four tables but not their slant-range axis, so a GSLC's axis is optional (the XML gives
  the tables one complex value each: a table of any length is accepted);
* ``metadata/calibrationInformation/frequencyA/faradayRotation`` (scalar, "radians"): the correction applied,
  written as 0.0 by the RSLC writer (none);
* ``metadata/calibrationInformation/frequencyA/nes0/{HH,HV,VV}`` (float32, linear, "1"): noise-equivalent sigma0
  on its own grid, RSLC ``nes0/zeroDopplerTime`` x ``nes0/slantRange``, GSLC ``nes0/yCoordinates`` x
  ``nes0/xCoordinates``;
* ``metadata/calibrationInformation/frequencyA/{HH,HV,VV}/rfiLikelihood`` (scalar in [0, 1], NaN where RFI detection
  was skipped) and ``scaleFactor`` (scalar, "1");
* ``metadata/orbit``: ``time``, ``position``, ``velocity``, ``orbitType``, ``interpMethod`` (read by
  ``e2esim.orbit.real.nisar``).
"""

from __future__ import annotations

from dataclasses import dataclass

PRODUCTS = ("RSLC", "GSLC")
CHANNELS = ("HH", "HV", "VV")
TIME_UNITS_PREFIX = "seconds since "
"""The units of a zero-Doppler time axis begin so; the rest is the reference epoch (UTC)."""

RSLC_SWATH_MEMBERS = frozenset({
    "listOfPolarizations", "HH", "HV", "VH", "VV", "RH", "RV", "slantRange", "slantRangeSpacing",
    "processedCenterFrequency", "acquiredCenterFrequency", "acquiredRangeBandwidth", "nominalAcquisitionPRF",
    "processedAzimuthBandwidth", "processedRangeBandwidth", "sceneCenterAlongTrackSpacing",
    "sceneCenterGroundRangeSpacing", "numberOfSubSwaths", "rangeChirpWeighting", "azimuthChirpWeighting"})
"""What ``swaths/frequencyA`` of an RSLC may hold (SLC.py), besides ``validSamplesSubSwath<i>``."""
GSLC_GRID_MEMBERS = frozenset({
    "listOfPolarizations", "yCoordinateSpacing", "xCoordinateSpacing", "rangeBandwidth", "azimuthBandwidth",
    "centerFrequency", "slantRangeSpacing", "zeroDopplerTimeSpacing", "projection", "xCoordinates", "yCoordinates",
    "mask", "HH", "HV", "VH", "VV", "RH", "RV", "numberOfSubSwaths"})
"""What ``grids/frequencyA`` of a GSLC may hold (nisar_L2_GSLC.xml)."""
MASK_FILL, MASK_INVALID = 255, 0


@dataclass(frozen=True)
class SlcLayout:
    """The paths of one product type (module docstring; ``slc_layout`` builds it). rows, columns : the image's
    axes (RSLC: zero-Doppler time and slant range; GSLC: y and x); nes0_rows, nes0_columns : the axes of the nes0
    grid; mask, projection : GSLC only (None for an RSLC); crosstalk_axis_required : the RSLC writes the slant-range
    axis of the crosstalk tables, the L2 writer not."""

    product: str
    image: str
    members: frozenset
    rows: str
    columns: str
    mask: str | None
    projection: str | None
    calibration: str
    crosstalk_tables: tuple
    crosstalk_slant_range: str
    crosstalk_axis_required: bool
    faraday_rotation: str
    nes0_rows: str
    nes0_columns: str
    orbit: str

    def nes0(self, channel: str) -> str:
        return f"{self.calibration}/frequencyA/nes0/{channel}"

    def rfi_likelihood(self, channel: str) -> str:
        return f"{self.calibration}/frequencyA/{channel}/rfiLikelihood"

    def scale_factor(self, channel: str) -> str:
        return f"{self.calibration}/frequencyA/{channel}/scaleFactor"

    @property
    def units(self) -> dict:
        """Every variable the reader needs, with the units attribute the layout gives it (None: "seconds since"
        an epoch, checked by its prefix)."""
        time_or_m = None if self.product == "RSLC" else "meters"
        return {
            **{f"{self.image}/{c}": "1" for c in CHANNELS},
            self.rows: time_or_m, self.columns: "meters",
            **{t: "1" for t in self.crosstalk_tables}, self.crosstalk_slant_range: "meters",
            self.faraday_rotation: "radians",
            **{self.nes0(c): "1" for c in CHANNELS}, self.nes0_rows: time_or_m, self.nes0_columns: "meters",
            **{self.rfi_likelihood(c): "1" for c in CHANNELS}, **{self.scale_factor(c): "1" for c in CHANNELS},
        }


def slc_layout(product: str) -> SlcLayout:
    """The layout of "RSLC" or "GSLC"."""
    root = f"/science/LSAR/{product}"
    calibration = f"{root}/metadata/calibrationInformation"
    nes0 = f"{calibration}/frequencyA/nes0"
    tables = tuple(f"{calibration}/crosstalk/{n}" for n in (
        "txHorizontalCrosspol", "txVerticalCrosspol", "rxHorizontalCrosspol", "rxVerticalCrosspol"))
    common = {"product": product, "calibration": calibration, "crosstalk_tables": tables,
              "crosstalk_slant_range": f"{calibration}/crosstalk/slantRange",
              "faraday_rotation": f"{calibration}/frequencyA/faradayRotation", "orbit": f"{root}/metadata/orbit"}
    if product == "RSLC":
        image = f"{root}/swaths/frequencyA"
        return SlcLayout(image=image, members=RSLC_SWATH_MEMBERS, rows=f"{root}/swaths/zeroDopplerTime",
                         columns=f"{image}/slantRange", mask=None, projection=None, crosstalk_axis_required=True,
                         nes0_rows=f"{nes0}/zeroDopplerTime", nes0_columns=f"{nes0}/slantRange", **common)
    image = f"{root}/grids/frequencyA"
    return SlcLayout(image=image, members=GSLC_GRID_MEMBERS, rows=f"{image}/yCoordinates",
                     columns=f"{image}/xCoordinates", mask=f"{image}/mask", projection=f"{image}/projection",
                     crosstalk_axis_required=False, nes0_rows=f"{nes0}/yCoordinates",
                     nes0_columns=f"{nes0}/xCoordinates", **common)
