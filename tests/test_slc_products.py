"""``e2esim uncertainty`` on generated NISAR RSLC and GSLC products (issue 26, item 3): the per-pixel budget from
their calibration tables on their own grid equals the per-case analytic model at a few pixels (the scene is the
scenario's: an SLC holds no covariance estimate; the noise is nes0 interpolated onto the grid), and a file whose
layout differs is refused with exit status 2, naming the variable."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
import rasterio

from e2esim.distortion.analytic import hv_error_moments
from e2esim.distortion.polarimetric_moments import polarimetric_error_moments
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.faraday.theory import bickel_bates_snr, bickel_bates_variance
from e2esim.products_io.assumptions import load_assumptions
from e2esim.products_io.nisar_slc_layout import slc_layout
from tests.product_writers import write_slc
from tests.test_product_inputs import refused
from tests.test_uncertainty_product import RTOL, agb_answer, assert_copol_layers, layers, run


def expected_noise(layout, f, i):
    """The mean of the three nes0 tables at pixel i: they vary along the columns only (the writer's), so a linear
    interpolation along the columns' axis (np.interp) gives it."""
    table = np.mean([f[layout.nes0(c)][()].astype(np.float64) for c in ("HH", "HV", "VV")], axis=0)[0]
    return float(np.interp(f[layout.columns][i[1]], f[layout.nes0_columns][()], table))


@pytest.mark.parametrize("product", ["RSLC", "GSLC"])
def test_slc_budget_from_its_calibration_tables_equals_the_per_case_model(tmp_path, product):
    """faradayRotation 0.004 rad removed, zero crosstalk tables (not corrected): the scenario's rotation less what
    was removed, the raw system errors, the nes0 noise across the swath; the scene and looks are the scenario's."""
    path = write_slc(tmp_path / "slc.h5", product, faraday=0.004, rfi=0.0)
    assert run(path, "-o", tmp_path / "out") == 0
    out = layers(tmp_path / "out")
    a = load_assumptions(None, "nisar")
    layout = slc_layout(product)
    faraday = GaussianFaraday(a.faraday.mean_rad - 0.004, a.faraday.sd_rad)
    with h5py.File(path) as f:
        for i in ((4, 5), (9, 12), (14, 19)):
            n = expected_noise(layout, f, i)
            m = hv_error_moments(a.scene, a.system, faraday, noise_power=n)
            assert out["sigma_hv_error_mean"][i] == pytest.approx(m.mean, rel=RTOL)
            assert out["sigma_hv_error_sd"][i] == pytest.approx(np.sqrt(m.variance), rel=RTOL)
            assert out["agb_relative_error"][i] == pytest.approx(agb_answer(a, a.scene.sigma_hv, m), rel=RTOL)
            sd = np.sqrt(bickel_bates_variance(bickel_bates_snr(a.scene, n), a.fr_window_looks, "asymptotic"))
            assert out["faraday_rotation_sd"][i] == pytest.approx(sd, rel=RTOL)
            assert out["residual_faraday_rotation_mean"][i] == pytest.approx(faraday.mean_rad, rel=RTOL)
            assert_copol_layers(out, i, polarimetric_error_moments(a.scene, a.system, faraday, noise_power=n))
        time_or_y = f[layout.rows][()]
    # the noise rises across the swath: so does the sigma_hv error
    assert np.all(np.diff(out["sigma_hv_error_mean"][5, 3:]) > 0)
    attrs = out["attrs"]
    assert attrs["product_type"] == product and "POE" in attrs["product_orbit"]
    assert attrs["faraday_rotation_corrected_by_processor"] == "True"
    assert attrs["crosstalk_corrected_by_processor"] == "False"
    if product == "RSLC":  # the second sub-swath starts at sample 3; the radar grid's coordinates
        assert np.all(out["verdict"][:, :3] == 255) and np.all(np.isnan(out["sigma_hv_error_sd"][:, :3]))
        assert np.all(out["verdict"][:, 3:] != 255)
        np.testing.assert_array_equal(out["zero_doppler_time"], time_or_y)
        assert "product_crosstalk_slant_range_m" in attrs
    else:  # the mask's fill and invalid pixels; the map grid
        assert out["verdict"][0, 0] == 255 and out["verdict"][1, 0] == 255 and out["verdict"][2, 0] != 255
        np.testing.assert_array_equal(out["y"], time_or_y)
        with rasterio.open(tmp_path / "out" / "uncertainty.tif") as tif:
            assert tif.crs.to_epsg() == 32646


def test_non_zero_crosstalk_tables_mean_corrected(tmp_path):
    path = write_slc(tmp_path / "slc.h5", "RSLC", crosstalk=0.01 + 0.002j)
    assert run(path, "-o", tmp_path / "out") == 0
    attrs = layers(tmp_path / "out")["attrs"]
    assert attrs["crosstalk_corrected_by_processor"] == "True"
    assert attrs["product_crosstalk_max_abs"] == pytest.approx(abs(0.01 + 0.002j), rel=1e-6)


def test_rslc_crosstalk_tables_apply_at_each_pixels_slant_range(tmp_path):
    """Tables zero up to 850.05 km and non-zero from 850.06 km; the image's columns lie at 850.00 to 850.19 km, 10 m
    apart: columns up to 5, where the interpolated tables are zero, are not corrected, so their raw system errors
    count; the others are, so the scenario's residual after calibration counts (docs/real-data.md)."""
    scenario = tmp_path / "s.yaml"
    scenario.write_text("""
scene: {type: table1_forest, forest: boreal_200}
instrument: {type: nisar}
ionosphere: {type: gaussian_faraday, mean_deg: 1.0, sd_deg: 0.5}
calibration:
  - {type: residual_system, crosstalk_db: -40.0, channel_imbalance_db: -40.0}
propagation: [{type: hv_backscatter_error}]
retrieval: {type: power_law, exponent: 2.0}
requirements: [{type: agb_error_bound, sources: systematic, bound_percent: 30, confidence_percent: 95, side: both}]
""")
    path = write_slc(tmp_path / "slc.h5", "RSLC", crosstalk=[0, 0, 0.01 + 0.002j, 0.012], rfi=0.0,
                     crosstalk_axis=[840e3, 850.05e3, 850.06e3, 860e3])
    assert run(path, "--scenario", scenario, "-o", tmp_path / "out") == 0
    out = layers(tmp_path / "out")
    a = load_assumptions(scenario, "nisar")
    layout = slc_layout("RSLC")
    with h5py.File(path) as f:
        for i, system in (((5, 3), a.system), ((9, 5), a.system), ((5, 6), a.system_residual),
                          ((9, 19), a.system_residual)):
            n = expected_noise(layout, f, i)
            m = hv_error_moments(a.scene, system, a.faraday, noise_power=n)
            assert out["sigma_hv_error_mean"][i] == pytest.approx(m.mean, rel=RTOL)
            assert out["sigma_hv_error_sd"][i] == pytest.approx(np.sqrt(m.variance), rel=RTOL)
            assert_copol_layers(out, i, polarimetric_error_moments(a.scene, system, a.faraday, noise_power=n))
    assert out["attrs"]["crosstalk_corrected_by_processor"] == "True"
    assert "slant range" in out["attrs"]["crosstalk_corrected_per_slant_range"]


R, G = slc_layout("RSLC"), slc_layout("GSLC")


@pytest.mark.parametrize(("product", "change", "expected"), [
    ("RSLC", {"drop": R.nes0("HV")}, ["variable", "nes0/HV is missing"]),
    ("RSLC", {"drop": f"{R.calibration}/crosstalk"}, ["group", "calibrationInformation/crosstalk is missing"]),
    ("RSLC", {"drop": R.crosstalk_slant_range}, ["crosstalk/slantRange is missing"]),
    ("RSLC", {"extra": f"{R.image}/gammaToBeta"}, ["gammaToBeta: unexpected variable", "slantRange"]),
    ("RSLC", {"units": {R.rows: "seconds"}}, ["zeroDopplerTime: units 'seconds'", "seconds since"]),
    ("RSLC", {"units": {R.faraday_rotation: "degrees"}}, ["faradayRotation: units 'degrees'", "'radians'"]),
    ("RSLC", {"orbit_shift_s": 5000.0}, ["metadata/orbit", "do not cover the acquisition"]),
    ("RSLC", {"rfi": 1.5}, ["HH/rfiLikelihood: 1.5", "[0, 1]"]),
    ("GSLC", {"drop": G.orbit}, ["metadata/orbit"]),
    ("GSLC", {"drop": G.mask}, ["grids/frequencyA/mask is missing"]),
    ("GSLC", {"units": {G.nes0("VV"): "dB"}}, ["nes0/VV: units 'dB'", "units '1'"]),
])
def test_bad_slc(tmp_path, capsys, product, change, expected):
    err = refused(capsys, write_slc(tmp_path / "slc.h5", product, **change), tmp_path / "out")
    assert "slc.h5" in err
    for text in expected:
        assert text in err


def test_an_hdf5_file_of_another_product_is_refused(tmp_path, capsys):
    with h5py.File(tmp_path / "rifg.h5", "w") as f:
        f.create_group("/science/LSAR/RIFG")
    err = refused(capsys, tmp_path / "rifg.h5", tmp_path / "out")
    assert "groups /science/LSAR/RIFG" in err and "/science/LSAR/RSLC" in err


@pytest.mark.parametrize("product", ["RSLC", "GSLC"])
def test_slc_holds_the_layout(tmp_path, product):
    layout = slc_layout(product)
    with h5py.File(write_slc(tmp_path / "slc.h5", product), "r") as f:
        for path, units in layout.units.items():
            if product == "GSLC" and path == layout.crosstalk_slant_range:
                assert path not in f  # the L2 writer copies the tables only
                continue
            given = f[path].attrs["units"]
            assert given == units if units else given.startswith("seconds since "), path
        assert set(f[layout.image]) - {f"validSamplesSubSwath{i}" for i in (1, 2)} <= layout.members
        assert f[f"{layout.image}/HH"].dtype == np.complex64


def test_a_gcov_whose_crosstalk_tables_come_without_their_axis_is_read(tmp_path):
    """isce3's L2 writer copies the RSLC's four crosstalk tables into the GCOV but not crosstalk/slantRange (and
    nisar_L2_GCOV.xml has no such variable): such a GCOV is read (it was refused as missing a variable)."""
    from e2esim.products_io import nisar_layout as nl
    from tests.product_writers import write_gcov

    path = write_gcov(tmp_path / "gcov.h5", drop=nl.CROSSTALK_SLANT_RANGE)
    assert run(path, "-o", tmp_path / "out") == 0
    assert layers(tmp_path / "out")["attrs"]["crosstalk_corrected_by_processor"] == "False"
