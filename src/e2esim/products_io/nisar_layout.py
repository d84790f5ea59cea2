"""The NISAR GCOV product layout that ``e2esim.products_io.nisar_gcov`` reads: one place for the names, units and
conventions it relies on (the test writer in tests/ checks its file against this module, not against the reader).

Source: the NISAR L2 GCOV product specification as the isce3 repository ships it
(``python/packages/nisar/products/XML/L2/nisar_L2_GCOV.xml``, isce3 commit e065414, Apache-2.0), written by
``nisar/products/writers/GcovWriter.py``:

* ``/science/LSAR/GCOV/grids/frequencyA``: ``HHHH``, ``HVHV``, ``VVVV`` (float32, units "1": the diagonal of the
  geocoded covariance, gamma0 or sigma0 as the product's radiometric terrain correction chose), ``HHVV`` (complex,
  units "1"), ``numberOfLooks`` (float32, units "1"), ``mask`` (uint8, 255 = fill, 0 = invalid, otherwise the
  valid subswath), ``xCoordinates``, ``yCoordinates`` (float64, units "meters") and ``projection`` (EPSG code as
  its value and attribute ``epsg_code``). Fill of the float grids: NaN.
* ``/science/LSAR/GCOV/metadata/calibrationInformation``: ``crosstalk/txHorizontalCrosspol``,
  ``txVerticalCrosspol``, ``rxHorizontalCrosspol``, ``rxVerticalCrosspol`` (complex, units "1", against
  ``crosstalk/slantRange`` in meters where it is present: the L2 writer, ``BaseL2WriterSingleInput.
  populate_calibration_information``, copies the RSLC's four tables but not their axis, and the XML gives each
  table one complex value, so the axis is optional), ``frequencyA/faradayRotation`` (scalar, units "radians":
  the correction applied in processing; 0.0 in the operational products = none applied), ``frequencyA/nes0/HH``,
  ``HV``, ``VV`` (noise-equivalent sigma0, linear, units "1", on the grid
  ``nes0/xCoordinates`` x ``nes0/yCoordinates``),
  ``frequencyA/{HH,HV,VV}/rfiLikelihood`` (scalar in [0, 1], NaN where RFI detection was skipped) and
  ``frequencyA/{HH,HV,VV}/scaleFactor`` (scalar, units "1").
"""

from __future__ import annotations

ROOT = "/science/LSAR/GCOV"
GRIDS = f"{ROOT}/grids/frequencyA"
CALIBRATION = f"{ROOT}/metadata/calibrationInformation"

COVARIANCE_TERMS = ("HHHH", "HVHV", "VVVV", "HHVV")
CHANNELS = ("HH", "HV", "VV")
GRID_VARIABLES = {
    # path: (units attribute, complex?)
    **{f"{GRIDS}/{t}": ("1", t == "HHVV") for t in COVARIANCE_TERMS},
    f"{GRIDS}/numberOfLooks": ("1", False),
    f"{GRIDS}/xCoordinates": ("meters", False),
    f"{GRIDS}/yCoordinates": ("meters", False),
}
MASK = f"{GRIDS}/mask"
MASK_FILL = 255
MASK_INVALID = 0
PROJECTION = f"{GRIDS}/projection"

CROSSTALK_TABLES = tuple(f"{CALIBRATION}/crosstalk/{n}" for n in (
    "txHorizontalCrosspol", "txVerticalCrosspol", "rxHorizontalCrosspol", "rxVerticalCrosspol"))
CROSSTALK_SLANT_RANGE = f"{CALIBRATION}/crosstalk/slantRange"
FARADAY_ROTATION = f"{CALIBRATION}/frequencyA/faradayRotation"
NES0 = {c: f"{CALIBRATION}/frequencyA/nes0/{c}" for c in CHANNELS}
NES0_X = f"{CALIBRATION}/frequencyA/nes0/xCoordinates"
NES0_Y = f"{CALIBRATION}/frequencyA/nes0/yCoordinates"
RFI_LIKELIHOOD = {c: f"{CALIBRATION}/frequencyA/{c}/rfiLikelihood" for c in CHANNELS}
SCALE_FACTOR = {c: f"{CALIBRATION}/frequencyA/{c}/scaleFactor" for c in CHANNELS}

UNITS = {
    **{p: u for p, (u, _) in GRID_VARIABLES.items()},
    **{p: "1" for p in CROSSTALK_TABLES}, CROSSTALK_SLANT_RANGE: "meters", FARADAY_ROTATION: "radians",
    **{p: "1" for p in NES0.values()}, NES0_X: "meters", NES0_Y: "meters",
    **{p: "1" for p in RFI_LIKELIHOOD.values()}, **{p: "1" for p in SCALE_FACTOR.values()},
}
"""Every variable the reader needs, with the units attribute the specification gives it."""
