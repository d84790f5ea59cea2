"""The generated test products against the public schemas and the layout modules (issue 26, item 6): the BIOMASS
annotation sections e2esim reads validate against their types in the BPS XSDs (tests/data/bps_xsd, MIT; a documented
subset: the main annotation's other sections are neither read nor written), and every variable the layout modules
name is in the generated files with the units they give."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import netCDF4
import numpy as np
import pytest

from e2esim.products_io import biomass_layout as bl
from e2esim.products_io import nisar_layout as nl
from tests.product_writers import biomass_annotation, write_biomass, write_gcov

etree = pytest.importorskip("lxml.etree")  # the test extra brings it
XSD = Path(__file__).parent / "data" / "bps_xsd"
SECTIONS = {"polarimetricDistortion": "polarimetricDistortionType", "ionosphereCorrection": "ionosphereCorrectionType",
            "rfiMitigation": "rfiMitigationType"}


def section_schema():
    """A schema of one top-level element per section e2esim reads, of the section's type in the BPS XSD."""
    elements = "".join(f'<xsd:element name="{name}" type="{kind}"/>' for name, kind in SECTIONS.items())
    text = ('<xsd:schema xmlns:xsd="http://www.w3.org/2001/XMLSchema" elementFormDefault="unqualified">'
            f'<xsd:include schemaLocation="{(XSD / "bio-l1-annotations.xsd").as_uri()}"/>{elements}</xsd:schema>')
    return etree.XMLSchema(etree.fromstring(text.encode(), base_url=(XSD / "wrapper.xsd").as_uri()))


@pytest.mark.parametrize("rfi", [None, {"HH": 1.5, "VV": 0.0}])
def test_annotation_sections_validate_against_the_bps_xsd(rfi):
    schema = section_schema()
    root = biomass_annotation(crosstalk=(0.01 + 0.002j, 0.0, 0.0, 0.003j), rfi_percent=rfi)
    for section in root:
        doc = etree.fromstring(ET.tostring(section))
        assert schema.validate(doc), schema.error_log


def test_the_schema_check_can_fail():
    schema = section_schema()
    root = biomass_annotation()
    bad = root.find("ionosphereCorrection/faradayRotationCorrectionApplied")
    bad.text = "yes"  # not an xsd bool of the BPS ('true' or 'false')
    assert not schema.validate(etree.fromstring(ET.tostring(root.find("ionosphereCorrection"))))
    root.find("polarimetricDistortion/crossTalkList").remove(root.find("polarimetricDistortion/crossTalkList")[0])
    assert not schema.validate(etree.fromstring(ET.tostring(root.find("polarimetricDistortion"))))


def test_biomass_lut_holds_the_layout(tmp_path):
    product = write_biomass(tmp_path / "bio", faraday=np.zeros((12, 20)))
    with netCDF4.Dataset(product / bl.LUT_FILE) as ds:
        assert bl.LUT_NO_DATA_ATTRIBUTE in ds.ncattrs()
        for group, variables in bl.LUT_VARIABLES.items():
            for name, (units, axes) in variables.items():
                var = ds.groups[group].variables[name]
                assert getattr(var, "units", None) == units and var.dimensions == axes
            assert set(ds.groups[group].variables) <= set(bl.KNOWN_LUT_VARIABLES[group])


def test_gcov_holds_the_layout(tmp_path):
    with h5py.File(write_gcov(tmp_path / "gcov.h5"), "r") as f:
        for path, units in nl.UNITS.items():
            assert path in f and f[path].attrs["units"] == units, path
        assert f[nl.MASK].dtype == np.uint8 and f[f"{nl.GRIDS}/HHVV"].dtype == np.complex64
