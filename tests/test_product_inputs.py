"""Bad products for ``e2esim uncertainty`` (issue 26, Done when): a truncated file, a missing group, an unexpected
variable, wrong units, a value out of range: exit status 2, one message naming the file, the group or variable, the
value and what is allowed, and no output left behind (not even a partial file)."""

from __future__ import annotations

import numpy as np
import pytest

from e2esim.cli import main
from e2esim.products_io import nisar_layout as nl
from e2esim.products_io import pixel_model
from tests.product_writers import write_biomass, write_gcov


def refused(capsys, product, out) -> str:
    assert main(["uncertainty", str(product), "-o", str(out)]) == 2
    assert not out.exists() or not any(out.iterdir()), "no output, not even a partial file"
    err = capsys.readouterr().err
    assert err.startswith("e2esim: error: ") and "Traceback" not in err
    return err


@pytest.mark.parametrize(("change", "expected"), [
    ({"truncate": 0.5}, ["gcov.h5", "truncated"]),
    ({"drop": f"{nl.CALIBRATION}/frequencyA/nes0"}, ["group", "frequencyA/nes0 is missing"]),
    ({"drop": nl.FARADAY_ROTATION}, ["variable", "faradayRotation is missing"]),
    ({"units": {nl.FARADAY_ROTATION: "degrees"}}, ["faradayRotation", "'degrees'", "'radians'"]),
    ({"units": {f"{nl.GRIDS}/HVHV": "dB"}}, ["HVHV", "'dB'", "units '1'"]),
    ({"extra": f"{nl.GRIDS}/gammaToBeta"}, ["gammaToBeta: unexpected variable", "HHHH"]),
    ({"faraday": 3.0}, ["faradayRotation: 3.0 rad", "[-pi/2, pi/2]"]),
])
def test_bad_gcov(tmp_path, capsys, change, expected):
    err = refused(capsys, write_gcov(tmp_path / "gcov.h5", **change), tmp_path / "out")
    assert "gcov.h5" in err
    for text in expected:
        assert text in err


@pytest.mark.parametrize(("change", "expected"), [
    ({"drop": "geometry"}, ["lut.nc", "group 'geometry' is missing"]),
    ({"drop": ("geometry", "incidenceAngle")}, ["lut.nc", "geometry/incidenceAngle is missing"]),
    ({"extra": ("geometry", "slopeAngle")}, ["lut.nc", "geometry/slopeAngle: unexpected variable", "terrainSlope"]),
    ({"units": {("ionosphereCorrection", "faradayRotation"): "deg"}},
     ["lut.nc", "ionosphereCorrection/faradayRotation: units 'deg'", "units 'rad'"]),
    ({"units": {("denoising", "denoisingHV"): "dB"}}, ["denoising/denoisingHV: units 'dB'", "no units attribute"]),
])
def test_bad_biomass_lut(tmp_path, capsys, change, expected):
    product = write_biomass(tmp_path / "bio", faraday=np.zeros((12, 20)), **change)
    err = refused(capsys, product, tmp_path / "out")
    for text in expected:
        assert text in err


def test_truncated_biomass_files(tmp_path, capsys):
    product = write_biomass(tmp_path / "bio", faraday=np.zeros((12, 20)))
    lut = product / "lut.nc"
    lut.write_bytes(lut.read_bytes()[:2000])
    assert "lut.nc: cannot be read as NetCDF-4" in refused(capsys, product, tmp_path / "out")
    product = write_biomass(tmp_path / "bio2")
    xml = product / "annotation.xml"
    xml.write_bytes(xml.read_bytes()[:300])
    assert "annotation.xml: not a complete XML document" in refused(capsys, product, tmp_path / "out")


def test_bad_annotation_values(tmp_path, capsys):
    product = write_biomass(tmp_path / "bio", rfi_percent={"HV": 140.0})
    err = refused(capsys, product, tmp_path / "out")
    assert "percentageAffectedLines (HV): 140.0" in err and "[0, 100]" in err
    text = (product / "annotation.xml").read_text().replace("<faradayRotationCorrectionApplied>true",
                                                            "<faradayRotationCorrectionApplied>yes")
    (product / "annotation.xml").write_text(text.replace("140.0", "1.0"))
    err = refused(capsys, product, tmp_path / "out")
    assert "faradayRotationCorrectionApplied: 'yes'" in err and "'true' or 'false'" in err


def test_a_failure_while_writing_leaves_no_partial_output(tmp_path, capsys, monkeypatch):
    """The outputs are temporaries until both are complete: a failure in the second block of rows removes them."""
    calls = []
    original = pixel_model.pixel_moments

    def failing(block, pixels, assumptions, memo):
        calls.append(block.rows)
        if len(calls) == 2:
            raise OSError("disk full")
        return original(block, pixels, assumptions, memo)

    monkeypatch.setattr("e2esim.products_io.block_pool.pixel_moments", failing)
    from e2esim.products_io.uncertainty import write_uncertainty

    with pytest.raises(OSError, match="disk full"):
        write_uncertainty(write_gcov(tmp_path / "gcov.h5"), tmp_path / "out", pixels_per_block=40)
    assert len(calls) == 2 and list((tmp_path / "out").iterdir()) == []


def test_existing_outputs_need_force(tmp_path, capsys):
    path = write_gcov(tmp_path / "gcov.h5")
    assert main(["uncertainty", str(path), "-o", str(tmp_path / "out")]) == 0
    capsys.readouterr()
    assert main(["uncertainty", str(path), "-o", str(tmp_path / "out")]) == 2
    assert "uncertainty.nc exists; give --force" in capsys.readouterr().err
    assert main(["uncertainty", str(path), "-o", str(tmp_path / "out"), "--force"]) == 0


def test_workers_must_be_positive(tmp_path, capsys):
    assert main(["uncertainty", str(write_gcov(tmp_path / "gcov.h5")), "-o", str(tmp_path / "out"),
                 "--workers", "0"]) == 2
    assert "--workers: 0; expected a positive integer" in capsys.readouterr().err


def test_a_failure_while_opening_the_outputs_leaves_no_partial_output(tmp_path, monkeypatch):
    """The NetCDF temporary exists when the GeoTIFF cannot be opened: it is removed."""
    import rasterio

    def refuse(*args, **kwargs):
        raise OSError("no space left for the GeoTIFF")

    monkeypatch.setattr(rasterio, "open", refuse)
    from e2esim.products_io.uncertainty import write_uncertainty

    with pytest.raises(OSError, match="no space left"):
        write_uncertainty(write_gcov(tmp_path / "gcov.h5"), tmp_path / "out")
    assert list((tmp_path / "out").iterdir()) == []
