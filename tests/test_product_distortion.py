"""The polarimetric distortion of a BIOMASS L1 annotation as the instrument's (issue 26, item 5;
e2esim.product_inputs.distortion_modules): the convention (which crosstalk term is which, linear complex amplitude
ratios, channel imbalance as f = 1 + epsilon) pinned through the system model, the statistics it gives, bad inputs."""

from __future__ import annotations

import numpy as np
import pytest
from hostile_files import refused_scenario
from product_writers import write_biomass

from e2esim.instrument.modules import BiomassInstrument
from e2esim.polarimetry.system_model import measured_matrix, to_vector
from e2esim.product_inputs import distortion_modules as dm
from e2esim.products_io.biomass_annotation import read_annotation
from e2esim.units import level_db_from_variance

CROSSTALK = (0.01 + 0.02j, -0.015j, 0.004 + 0.0j, 0.008 - 0.006j)  # HVRx, VHRx, VHTx, HVTx (schema order)
IMBALANCE = (1.02 - 0.01j, 0.97 + 0.0j)  # HVRx, HVTx


def _annotation(tmp_path, crosstalk=CROSSTALK, imbalance=IMBALANCE):
    return write_biomass(tmp_path / "p", faraday=np.zeros((12, 20)), crosstalk=crosstalk, imbalance=imbalance,
                         rfi_percent={"HV": 1.0})


@pytest.mark.parametrize(("term", "scatterer", "channel", "meaning"), [
    (0, "hh", "hv", "crossTalkHVRx: H received leaks into the V receiver"),
    (1, "vv", "vh", "crossTalkVHRx: V received leaks into the H receiver"),
    (2, "hh", "vh", "crossTalkVHTx: V commanded on transmit radiates H"),
    (3, "vv", "hv", "crossTalkHVTx: H commanded on transmit radiates V"),
])
def test_which_crosstalk_term_is_which(tmp_path, term, scatterer, channel, meaning):
    """A scatterer with one co-polarised term, measured through one annotated crosstalk term alone (0.1), shows it
    in the cross-polarised channel that the schema's description names (bio-common-types.xsd, crossTalkList)."""
    crosstalk = [0.0] * 4
    crosstalk[term] = 0.1
    annotation = read_annotation(_annotation(tmp_path, crosstalk, (1.0, 1.0)) / "annotation.xml")
    delta, f = dm.annotation_distortion(annotation)
    s = np.diag([1.0, 0.0] if scatterer == "hh" else [0.0, 1.0]).astype(complex)
    m = dict(zip(("hh", "hv", "vh", "vv"), to_vector(measured_matrix(s, delta, f, 0.0)), strict=True))
    assert m[channel] == pytest.approx(0.1, abs=1e-15), meaning
    assert [k for k in ("hv", "vh") if abs(m[k]) > 0] == [channel]


def test_the_channel_imbalance_is_f_receive_then_transmit(tmp_path):
    """channelImbalHVRx is f1 (the V receiver's gain over the H receiver's), channelImbalHVTx f2: a pure S_hv
    (transmit h, receive v) is measured as f1 S_hv, a pure S_vh as f2 S_vh; 1 is balanced."""
    delta, f = dm.annotation_distortion(read_annotation(_annotation(tmp_path, [0.0] * 4) / "annotation.xml"))
    assert tuple(f) == IMBALANCE
    m = to_vector(measured_matrix(np.array([[0, 1], [1, 0]], dtype=complex), delta, f, 0.0))
    assert m[1] == IMBALANCE[0] and m[2] == IMBALANCE[1]


def test_the_statistics_are_those_of_the_annotations_values(tmp_path):
    """V_i = |delta_i|^2 and V_eps,i = |f_i - 1|^2: the biomass preset given those levels as variances (the largest
    as level_db, the others as term offsets) has the same model to 1e-12; correlations and noise the preset's."""
    module = dm.BiomassProductDistortion(annotation_file=str(_annotation(tmp_path) / "annotation.xml"))
    v_delta = np.abs(CROSSTALK) ** 2
    v_eps = np.abs(np.array(IMBALANCE) - 1) ** 2
    np.testing.assert_allclose(module.model.crosstalk_variance, v_delta, rtol=1e-14)
    np.testing.assert_allclose(module.model.imbalance_variance, v_eps, rtol=1e-14)

    def group(v):
        return {"level_db": float(10 * np.log10(v.max())), "convention": "variance",
                "term_offsets_db": [float(x) for x in 10 * np.log10(v / v.max())], "correlation_magnitude": 0.9}

    given = BiomassInstrument(crosstalk=group(v_delta), channel_imbalance=group(v_eps)).model
    for name in ("crosstalk_level", "imbalance_level", "crosstalk_relative", "imbalance_relative",
                 "crosstalk_rho13", "crosstalk_rho24", "imbalance_rho", "noise_power"):
        np.testing.assert_allclose(getattr(module.model, name), getattr(given, name), rtol=1e-12, err_msg=name)
    # stated in the instrument's own convention (the preset's 3-sigma amplitude label)
    assert module.description.crosstalk_db == pytest.approx(
        float(level_db_from_variance(v_delta.max(), "three_sigma_amplitude")), rel=1e-15)
    assert module.description.convention == "three_sigma_amplitude"


def test_with_the_noise_of_the_lut_and_the_scenarios_imbalance(tmp_path):
    product = _annotation(tmp_path, imbalance=(0.0, 0.0))
    module = dm.BiomassProductInstrument(lut_file=str(product / "lut.nc"), annotation_file=str(
        product / "annotation.xml"), channel_imbalance_from_product=False, lat_deg=60.03, lon_deg=92.07)
    made = module.forward(None)
    assert made["system"].noise_power == pytest.approx(0.002, rel=1e-7)  # the writer's denoising layers
    np.testing.assert_allclose(made["system"].crosstalk_variance, np.abs(CROSSTALK) ** 2, rtol=1e-14)
    preset = BiomassInstrument().model
    assert made["system"].imbalance_level == preset.imbalance_level  # the scenario's (preset) -34 dB
    assert made["instrument"].imbalance_db == -34.0


def _run(tmp_path, capsys, product, **settings) -> str:
    scenario = {"name": "bad", "scene": {"type": "table1_forest"},
                "instrument": {"type": "biomass_product_distortion",
                               "annotation_file": str(product / "annotation.xml"), **settings},
                "ionosphere": {"type": "gaussian_faraday", "mean_deg": 5.0, "sd_deg": 1.0},
                "propagation": [{"type": "hv_backscatter_error"}], "simulation": {"mode": "analytic", "seed": 1}}
    return refused_scenario(tmp_path, capsys, scenario)


def test_an_annotation_of_zeros_is_refused(tmp_path, capsys):
    err = _run(tmp_path, capsys, _annotation(tmp_path, crosstalk=(0.0,) * 4))
    assert "instrument.annotation_file" in err and "annotation.xml" in err
    assert "mainAnnotation/polarimetricDistortion/crossTalkList: every term is 0" in err
    assert "crosstalk_from_product: false" in err
    err = _run(tmp_path, capsys, _annotation(tmp_path, imbalance=(0.0, 0.0)))
    assert "channelImbalanceList: every term is 0" in err and "channel_imbalance_from_product: false" in err


def test_a_missing_term_is_refused(tmp_path, capsys):
    product = _annotation(tmp_path)
    xml = product / "annotation.xml"
    text = xml.read_text()
    start, end = text.index("<crossTalkVHTx>"), text.index("</crossTalkVHTx>") + len("</crossTalkVHTx>")
    xml.write_text(text[:start] + text[end:])
    err = _run(tmp_path, capsys, product)
    assert "element mainAnnotation/polarimetricDistortion/crossTalkList/crossTalkVHTx is missing" in err
