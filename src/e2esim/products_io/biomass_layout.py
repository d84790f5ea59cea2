"""The BIOMASS L1 product layout that ``e2esim.products_io.biomass_l1`` reads: one place for the names, units and
conventions it relies on (the test writers in tests/ check their files against this module, not against the reader).

Sources (BioPAL BPS, the BIOMASS Processing Suite, v4.3.0, MIT licence):

* the LUT NetCDF: ``bps-transcoder/bps/transcoder/sarproduct/l1_lut_writer.py`` (``write_lut_file``): a NETCDF4
  file with groups ``ionosphereCorrection`` (``faradayRotation``, ``faradayRotationStd``, ``tec``, ``phaseScreen``
  on the SLC axes ``relativeAzimuthTimeSLC`` x ``slantRangeTimeSLC``), ``denoising`` (``denoisingHH`` ...: the
  noise power removed, linear, no units attribute; SLC axes), ``geometry`` (``latitude``, ``longitude`` in deg,
  ``height`` in m, ``incidenceAngle``, ``elevationAngle`` in deg, ``terrainSlope``; RGC axes
  ``relativeAzimuthTimeRGC`` x ``slantRangeTimeRGC``), ``radiometry`` (``sigmaNought``, ``gammaNought``: the
  conversion factors sin and tan of the incidence, no units; RGC axes) and ``rfiMitigation`` (masks on the RAW
  axes). Axes are 1-D variables in s (slant-range time and azimuth time relative to the global attribute
  ``referenceAzimuthTime``). The global attribute ``noDataValueFloat`` is the fill of every float layer; the
  writer fills ``faradayRotationStd`` with it everywhere (the processor leaves the layer empty).
* the annotation XML: ``xsd/biomass-xsd/bio-l1-annotations.xsd`` and ``bio-common-types.xsd``:
  ``polarimetricDistortion`` (``polarimetricDistortionType``: ``crossTalkList`` with ``crossTalkHVRx``,
  ``crossTalkVHRx``, ``crossTalkVHTx``, ``crossTalkHVTx`` and ``channelImbalanceList`` with ``channelImbalHVRx``,
  ``channelImbalHVTx``, each a ``complex`` of ``re`` and ``im``), ``ionosphereCorrection``
  (``ionosphereCorrectionType``: ``faradayRotationCorrectionApplied``, a ``bool`` written ``true`` or ``false``)
  and ``rfiMitigation`` (``rfiMitigationType``: ``rfiTMReportList/rfiTMReport`` with attribute ``polarisation``
  and ``percentageAffectedLines`` in per cent), children of the root ``mainAnnotation``
  (``bio-l1ab-main-annotation.xsd``).
"""

from __future__ import annotations

LUT_NO_DATA_ATTRIBUTE = "noDataValueFloat"
SLC_AXES = ("relativeAzimuthTimeSLC", "slantRangeTimeSLC")
RGC_AXES = ("relativeAzimuthTimeRGC", "slantRangeTimeRGC")
AXIS_UNITS = "s"
POLARISATIONS = ("HH", "HV", "VH", "VV")

LUT_VARIABLES = {
    # group: {variable: (units attribute or None where the writer sets none, axes)}
    "ionosphereCorrection": {"faradayRotation": ("rad", SLC_AXES), "faradayRotationStd": ("rad", SLC_AXES)},
    "denoising": {f"denoising{p}": (None, SLC_AXES) for p in POLARISATIONS},
    "geometry": {"latitude": ("deg", RGC_AXES), "longitude": ("deg", RGC_AXES), "height": ("m", RGC_AXES),
                 "incidenceAngle": ("deg", RGC_AXES)},
}
"""What the reader needs from the LUT file (other variables the writer adds are allowed and ignored)."""

SCENARIO_LUT_VARIABLES = {
    "ionosphereCorrection": {"tec": ("TECU", SLC_AXES)},
    "geometry": {"terrainSlope": (None, RGC_AXES)},
}
"""Further layers a product-driven scenario reads (``e2esim.product_inputs``), with the units the writer gives
them: ``tec`` is ``_phase_screen_to_tec`` of the Bickel-Bates phase screen, in TECU (10^16 electrons/m^2);
``terrainSlope`` has no units attribute and is in degrees (``compute_geometric_lut``: the incidence on the
ellipsoid minus the incidence on the DEM, both in deg)."""

ANNOTATION_ROOT = "mainAnnotation"
CROSSTALK_PATH = "polarimetricDistortion/crossTalkList"
CROSSTALK_ELEMENTS = ("crossTalkHVRx", "crossTalkVHRx", "crossTalkVHTx", "crossTalkHVTx")
IMBALANCE_PATH = "polarimetricDistortion/channelImbalanceList"
IMBALANCE_ELEMENTS = ("channelImbalHVRx", "channelImbalHVTx")
FARADAY_APPLIED_PATH = "ionosphereCorrection/faradayRotationCorrectionApplied"
RFI_REPORT_PATH = "rfiMitigation/rfiTMReportList/rfiTMReport"
RFI_FRACTION_ELEMENT = "percentageAffectedLines"
BOOLEAN_TEXT = {"true": True, "false": False}

ANNOTATION_FILE = "annotation.xml"
LUT_FILE = "lut.nc"
"""A product is a folder holding these two files (the BPS names them after the product; the reader also takes a
folder with exactly one ``*.xml`` annotation and one ``*.nc`` LUT, see ``biomass_l1.product_files``)."""

KNOWN_LUT_VARIABLES = {
    "ionosphereCorrection": ("phaseScreen", "tec", "rangeShifts", "azimuthShifts", "faradayRotationPlane",
                             "faradayRotation", "faradayRotationStd", "autofocusPhaseScreen",
                             "autofocusPhaseScreenStd"),
    "denoising": tuple(f"denoising{p}" for p in POLARISATIONS),
    "geometry": ("latitude", "longitude", "height", "incidenceAngle", "elevationAngle", "terrainSlope"),
    "radiometry": ("sigmaNought", "gammaNought"),
}
"""Every variable ``write_lut_file`` of BPS v4.3.0 writes in the groups the reader opens: anything else means a
layout the reader does not know, and it refuses the file."""
REQUIRED_GROUPS = ("denoising", "geometry")
"""``ionosphereCorrection`` is optional: the writer adds it only when the processor estimated the ionosphere."""
