"""``e2esim uncertainty`` on generated products (issue 26, Done when): the per-pixel outputs equal the per-case
analytic model (``hv_error_moments`` for the pixel's scene, system, Faraday rotation, noise and looks; the
Bickel-Bates SD; the power law) at a few pixels, and the outputs hold what the product said and what was assumed."""

from __future__ import annotations

from itertools import pairwise
from types import SimpleNamespace

import netCDF4
import numpy as np
import pytest
import rasterio

from e2esim.case import KernelMemo
from e2esim.cli import main
from e2esim.distortion.analytic import hv_error_moments
from e2esim.distortion.polarimetric_moments import polarimetric_error_moments
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.faraday.theory import bickel_bates_snr, bickel_bates_variance
from e2esim.products_io.assumptions import load_assumptions
from e2esim.retrieval.agb_error import AGBError
from e2esim.scene.covariance import ScatteringCovariance
from tests.product_writers import write_biomass, write_gcov

PIXELS = ((0, 1), (5, 7), (11, 19))
RTOL = 2e-7  # the outputs are float32 (relative rounding 6e-8); the model itself agrees to 1e-15


def run(*args) -> int:
    return main(["uncertainty", *map(str, args)])


def layers(folder) -> dict:
    with netCDF4.Dataset(folder / "uncertainty.nc") as ds:
        ds.set_auto_mask(False)  # the fills as stored: NaN, and 255 for the verdict
        return {name: np.asarray(var[:]) for name, var in ds.variables.items()} | {
            "attrs": {k: ds.getncattr(k) for k in ds.ncattrs()}}


GAIN = 1 - 0.035  # the generated product's RFI mitigation blanked 3.5 % of the lines (HH)


def with_gain(m, sigma, gain=GAIN):
    """The moments ``m`` of a channel's error with its intensity multiplied by ``gain`` (the rfi term's FixedGain)."""
    return SimpleNamespace(mean=gain * m.mean - (1 - gain) * sigma, variance=gain**2 * m.variance)


def copol_with_gain(copol, gain):
    """``polarimetric_error_moments`` with every channel's intensity multiplied by ``gain``."""
    return SimpleNamespace(mean=gain * copol.mean - (1 - gain) * copol.sigma, sd=gain * copol.sd, sigma=copol.sigma)


def agb_answer(a, sigma_hv, m) -> float:
    agb = AGBError.from_sigma_errors(a.exponent, sigma_hv, m.mean, np.sqrt(m.variance))
    return max(abs(agb.quantile(1 - a.confidence)), abs(agb.quantile(a.confidence)))


def assert_copol_layers(out, i, m) -> None:
    """The sigma_hh and sigma_vv layers at pixel i against ``polarimetric_error_moments`` (``m``)."""
    for ch, p in (("hh", 0), ("vv", 2)):
        assert out[f"sigma_{ch}_error_mean"][i] == pytest.approx(m.mean[p], rel=RTOL)
        assert out[f"sigma_{ch}_error_sd"][i] == pytest.approx(m.sd[p], rel=RTOL)
        assert out[f"sigma_{ch}_relative_error_mean"][i] == pytest.approx(m.mean[p] / m.sigma[p], rel=RTOL)
        assert out[f"sigma_{ch}_relative_error_sd"][i] == pytest.approx(m.sd[p] / m.sigma[p], rel=RTOL)


def test_biomass_uncorrected_faraday_rotation_counts_in_full_with_the_filled_sd(tmp_path):
    """faradayRotationCorrectionApplied false: the data keep the LUT's Faraday rotation (the full error counts);
    the faradayRotationStd layer is all fill (as the BPS writes it), so its SD is e2esim's Bickel-Bates SD. The RFI
    mitigation blanked 3.5 % of the lines: a gain g = 0.965 on every channel, not restored (the rfi error term's
    FixedGain: E[e'] = g E[e] - (1 - g) sigma, SD[e'] = g SD[e])."""
    fr = np.radians(np.linspace(1.0, 12.0, 240)).reshape(12, 20)
    noise = np.broadcast_to(np.linspace(0.002, 0.02, 20), (12, 20))  # NESZ -27 to -17 dB across the swath
    product = write_biomass(tmp_path / "bio", faraday=fr, faraday_applied=False, noise=noise,
                            rfi_percent={"HH": 3.5})
    assert run(product, "-o", tmp_path / "out") == 0
    out = layers(tmp_path / "out")
    a = load_assumptions(None, "biomass")
    for i in PIXELS:
        n = float(np.float32(noise[i]))  # as the LUT stores it
        sd = np.sqrt(bickel_bates_variance(bickel_bates_snr(a.scene, n), a.fr_window_looks, "asymptotic"))
        m = with_gain(hv_error_moments(a.scene, a.system, GaussianFaraday(fr[i], sd), noise_power=n),
                      a.scene.sigma_hv)
        assert out["faraday_rotation_sd"][i] == pytest.approx(sd, rel=RTOL)
        assert out["faraday_rotation_sd_source"][i] == 2
        assert out["residual_faraday_rotation_mean"][i] == pytest.approx(fr[i], rel=RTOL)
        assert out["sigma_hv_error_mean"][i] == pytest.approx(m.mean, rel=RTOL)
        assert out["sigma_hv_error_sd"][i] == pytest.approx(np.sqrt(m.variance), rel=RTOL)
        assert out["agb_relative_error"][i] == pytest.approx(agb_answer(a, a.scene.sigma_hv, m), rel=RTOL)
        assert out["verdict"][i] == (agb_answer(a, a.scene.sigma_hv, m) <= a.bound)
        fr32 = float(np.float32(fr[i]))  # as the LUT stores it: sigma_hh and sigma_vv are sensitive to the rotation
        copol = polarimetric_error_moments(a.scene, a.system, GaussianFaraday(fr32, sd), noise_power=n)
        assert_copol_layers(out, i, copol_with_gain(copol, GAIN))
    # the noise bias grows across the swath: the near range passes the +-20 % bound, the far range does not
    assert out["verdict"][:, 0].all() and not out["verdict"][:, -1].any()
    attrs = out["attrs"]
    assert attrs["faraday_rotation_corrected_by_processor"] == "False"
    assert attrs["product_lut_faradayRotationStd"].startswith("empty")
    assert attrs["product_rfi_percentage_affected_lines_HH"] == pytest.approx(3.5)
    assert attrs["rfi_blanked_fraction_counted"] == pytest.approx(0.035)
    assert attrs["assumed_power_law_exponent"] == pytest.approx(2.2)


def test_biomass_corrected_faraday_rotation_leaves_the_estimate_error_of_its_own_sd(tmp_path):
    fr = np.full((12, 20), 0.2)
    own_sd = np.full((12, 20), np.radians(0.5))
    own_sd[3, 4] = -9999.0  # one no-data value: that pixel's SD is filled
    product = write_biomass(tmp_path / "bio", faraday=fr, faraday_std=own_sd, faraday_applied=True)
    assert run(product, "-o", tmp_path / "out") == 0
    out = layers(tmp_path / "out")
    assert out["faraday_rotation_sd_source"][0, 0] == 1 and out["faraday_rotation_sd_source"][3, 4] == 2
    assert out["residual_faraday_rotation_mean"][0, 0] == 0.0
    assert out["residual_faraday_rotation_sd"][0, 0] == pytest.approx(np.radians(0.5), rel=RTOL)
    a = load_assumptions(None, "biomass")
    m = hv_error_moments(a.scene, a.system, GaussianFaraday(0.0, np.radians(0.5)), noise_power=0.002)
    assert out["sigma_hv_error_mean"][0, 0] == pytest.approx(m.mean, rel=RTOL)


def test_nisar_gcov_scene_looks_and_noise_come_from_the_product(tmp_path):
    """The covariance per pixel, numberOfLooks and nes0 from the GCOV; faradayRotation 0.0 and zero crosstalk
    tables: not applied, so the scenario's rotation and the raw system errors count in full. rfiLikelihood 0.02 (HH),
    0.05 (HV) and NaN (VV: detection skipped): the largest finite one, 0.05, counts as the rfi term's blanked time,
    a gain g = 0.95 on every channel (docs/real-data.md)."""
    path = write_gcov(tmp_path / "gcov.h5", looks=25.0, nes0=0.003, rfi={"HH": 0.02, "HV": 0.05, "VV": np.nan})
    assert run(path, "-o", tmp_path / "out") == 0
    out = layers(tmp_path / "out")
    a = load_assumptions(None, "nisar")
    import h5py

    from e2esim.products_io import nisar_layout as nl

    with h5py.File(path) as f:
        hh, hv, vv, hhvv = (f[f"{nl.GRIDS}/{t}"][()] for t in ("HHHH", "HVHV", "VVVV", "HHVV"))
    for i in PIXELS[1:] + ((14, 19),):
        c = np.array([[hh[i], 0, hhvv[i]], [0, hv[i], 0], [np.conj(hhvv[i]), 0, vv[i]]], dtype=complex)
        m = with_gain(hv_error_moments(ScatteringCovariance(c), a.system, a.faraday, looks=25.0, noise_power=0.003),
                      float(hv[i]), 0.95)
        assert out["sigma_hv_error_mean"][i] == pytest.approx(m.mean, rel=RTOL)
        assert out["sigma_hv_error_sd"][i] == pytest.approx(np.sqrt(m.variance), rel=RTOL)
        assert out["agb_relative_error"][i] == pytest.approx(agb_answer(a, float(hv[i]), m), rel=RTOL)
        copol = polarimetric_error_moments(ScatteringCovariance(c), a.system, a.faraday, looks=25.0, noise_power=0.003)
        assert_copol_layers(out, i, copol_with_gain(copol, 0.95))
    assert np.isnan(out["sigma_hh_error_sd"][0, 0])  # mask fill
    assert np.isnan(out["sigma_hv_error_mean"][0, 0]) and out["verdict"][0, 0] == 255  # mask fill
    assert out["attrs"]["faraday_rotation_corrected_by_processor"] == "False"
    assert out["attrs"]["crosstalk_corrected_by_processor"] == "False"
    assert out["attrs"]["rfi_blanked_fraction_counted"] == pytest.approx(0.05)
    assert out["attrs"]["product_rfi_detection_skipped"] == "VV"
    with rasterio.open(tmp_path / "out" / "uncertainty.tif") as tif:
        assert tif.crs.to_epsg() == 32646
        assert tif.descriptions[2] == "sigma_hv_relative_error_mean"
        assert tif.descriptions[-1] == "sigma_vv_relative_error_sd"
        np.testing.assert_array_equal(tif.read(tif.count), out["sigma_vv_relative_error_sd"])
        np.testing.assert_array_equal(tif.read(3), out["sigma_hv_relative_error_mean"])
        assert tif.transform.c == pytest.approx(500000.0 - 10.0)


def test_corrected_crosstalk_uses_the_scenarios_residual_after_calibration(tmp_path):
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
    path = write_gcov(tmp_path / "gcov.h5", crosstalk=0.01 + 0.002j, faraday=0.004, rfi=0.0)
    assert run(path, "--scenario", scenario, "-o", tmp_path / "out") == 0
    out = layers(tmp_path / "out")
    a = load_assumptions(scenario, "nisar")
    assert a.system_residual != a.system and a.bound == pytest.approx(0.3) and a.exponent == 2.0
    with __import__("h5py").File(path) as f:
        hh, hv, vv, hhvv = (f[f"/science/LSAR/GCOV/grids/frequencyA/{t}"][()] for t in ("HHHH", "HVHV", "VVVV", "HHVV"))
    i = (7, 3)
    c = np.array([[hh[i], 0, hhvv[i]], [0, hv[i], 0], [np.conj(hhvv[i]), 0, vv[i]]], dtype=complex)
    residual = GaussianFaraday(np.radians(1.0) - 0.004, np.radians(0.5))  # the rotation less what was removed
    m = hv_error_moments(ScatteringCovariance(c), a.system_residual, residual, looks=25.0, noise_power=0.003)
    assert out["sigma_hv_error_mean"][i] == pytest.approx(m.mean, rel=RTOL)
    assert out["residual_faraday_rotation_mean"][i] == pytest.approx(np.radians(1.0) - 0.004, rel=RTOL)
    assert out["attrs"]["crosstalk_corrected_by_processor"] == "True"
    assert out["attrs"]["product_faradayRotation_rad"] == pytest.approx(0.004)


def test_worker_processes_give_the_numbers_of_one_process(tmp_path):
    """Blocks evaluated in two processes, a few rows at a time, are written bit for bit as in one process."""
    from e2esim.products_io.uncertainty import write_uncertainty

    path = write_gcov(tmp_path / "gcov.h5", shape=(15, 20))
    write_uncertainty(path, tmp_path / "one", pixels_per_block=60)
    write_uncertainty(path, tmp_path / "two", pixels_per_block=60, workers=2)
    one, two = layers(tmp_path / "one"), layers(tmp_path / "two")
    for name in one:
        if name != "attrs":
            np.testing.assert_array_equal(one[name], two[name], err_msg=name)


def test_cog_overviews_hold_pixels_of_the_layers(tmp_path):
    """The COG's overviews are resampled by nearest neighbour: an overview pixel is a pixel of its layer, so the
    verdict's overview holds only 0 and 1 (cubic resampling, as before, gave values such as -0.012 and 0.93)."""
    noise = np.broadcast_to(np.linspace(0.002, 0.02, 1100), (12, 1100))  # passes at near range, fails at far
    product = write_biomass(tmp_path / "bio", shape=(12, 1100), faraday=np.full((12, 1100), 0.05),
                            faraday_applied=False, noise=noise)
    assert run(product, "-o", tmp_path / "out") == 0
    with rasterio.open(tmp_path / "out" / "uncertainty.tif") as tif:
        band = tif.descriptions.index("verdict") + 1
        assert tif.overviews(band) == [2, 4]
        assert tif.compression.name == "zstd" and tif.block_shapes[0] == (512, 512)  # a tiled ZSTD COG
        assert tif.tags(ns="IMAGE_STRUCTURE")["LAYOUT"] == "COG"
        full = tif.read(band)
        overview = tif.read(band, out_shape=(tif.height // 2, tif.width // 2))
        sd_band = tif.descriptions.index("sigma_hv_error_sd") + 1
        sd_full, sd_overview = tif.read(sd_band), tif.read(sd_band, out_shape=(tif.height // 2, tif.width // 2))
    assert set(np.unique(full)) == {0.0, 1.0} and set(np.unique(overview)) == {0.0, 1.0}
    assert np.isin(sd_overview, sd_full).all()


def test_the_band_read_at_once_does_not_change_the_numbers(tmp_path):
    """A band of rows is read at once and evaluated in the model's blocks: whatever the band, a pixel's numbers are
    those of its block read alone (the co-polarised model's path depends on the rotations a block holds)."""
    from e2esim.products_io.block_pool import block_layers
    from e2esim.products_io.pixel_model import pixel_moments
    from e2esim.products_io.uncertainty import open_product

    fr = np.radians(np.linspace(1.0, 12.0, 240)).reshape(12, 20)
    fr[:4] = 0.1  # the first blocks share one rotation
    product = write_biomass(tmp_path / "bio", faraday=fr, faraday_applied=False)
    pixels = open_product(product)
    a = load_assumptions(None, "biomass")
    alone = {}
    for start in range(0, 12, 2):
        for name, values in pixel_moments(pixels.read(slice(start, start + 2)), pixels, a, KernelMemo()).items():
            alone.setdefault(name, []).append(values)
    for bands in ([slice(0, 12)], [slice(0, 4), slice(4, 10), slice(10, 12)]):
        got = list(block_layers(open_product, product, None, pixels, a, bands, 2))
        assert [rows for rows, _ in got] == bands
        for name, parts in alone.items():
            np.testing.assert_array_equal(np.concatenate([layers[name] for _, layers in got]),
                                          np.concatenate(parts), err_msg=name)


def test_a_band_holds_about_the_same_pixels_whatever_the_grid():
    """Memory is bounded by a band's pixels, not by the grid's width: a band of a 2,000 x 12,500 grid holds the
    pixels of a band of a 5,000 x 5,000 grid to within one model block of rows (a 12,500-column band was 2.5 times
    larger when bands were a fixed number of rows); bands tile the grid, each a whole number of model blocks."""
    from e2esim.products_io.uncertainty import BAND_PIXELS, block_rows, row_bands

    for shape in ((5000, 5000), (2000, 12500), (3000, 40000), (40, 2_000_000)):
        bands = list(row_bands(shape))
        step = block_rows(shape)
        assert bands[0].start == 0 and bands[-1].stop == shape[0]
        assert all(a.stop == b.start for a, b in pairwise(bands))
        assert all((b.stop - b.start) % step == 0 for b in bands[:-1])
        pixels = (bands[0].stop - bands[0].start) * shape[1]
        assert abs(pixels - BAND_PIXELS) <= max(step * shape[1] / 2, shape[1]), shape


def test_netcdf_chunks_written_directly_are_the_ones_hdf5_writes(tmp_path):
    """The chunks compressed by ``netcdf_chunks`` (in the workers) and written by HDF5's direct chunk write hold,
    once HDF5's own filters undo them, the bytes HDF5 stores when netCDF4 writes the same values: bands of 4 rows
    and chunks of 8 columns, the last band and the last column of chunks cut short (padded with the fill value)."""
    import zlib

    import h5py

    from e2esim.products_io.uncertainty_files import LAYER_STORAGE, netcdf_chunks

    rng = np.random.default_rng(3)
    values = {"sigma_hv_error_sd": rng.normal(size=(10, 19)), "verdict": rng.integers(0, 2, (10, 19)).astype("u1")}
    values["sigma_hv_error_sd"][2, 5] = np.nan
    values["verdict"][9, 18] = 255
    chunk = (4, 8)
    for direct in (False, True):
        with netCDF4.Dataset(tmp_path / f"{direct}.nc", "w") as ds:
            ds.createDimension("y", 10)
            ds.createDimension("x", 19)
            for name, v in values.items():
                dtype, fill = LAYER_STORAGE[name == "verdict"]
                var = ds.createVariable(name, dtype, ("y", "x"), fill_value=fill, chunksizes=chunk,
                                        compression="zlib", complevel=1, shuffle=True)
                if not direct:
                    var[:] = v
        if direct:
            with h5py.File(tmp_path / f"{direct}.nc", "r+") as f:
                for start in range(0, 10, 4):
                    band = {k: v[start:start + 4] for k, v in values.items()}
                    for name, parts in netcdf_chunks(band, chunk).items():
                        for column, data in parts:
                            f[name].id.write_direct_chunk((start, column), data)
    with netCDF4.Dataset(tmp_path / "False.nc") as a, netCDF4.Dataset(tmp_path / "True.nc") as b:
        for name in values:
            a[name].set_auto_mask(False)
            b[name].set_auto_mask(False)
            np.testing.assert_array_equal(a[name][:], b[name][:])
            assert a[name].filters() == b[name].filters()
    with h5py.File(tmp_path / "False.nc") as a, h5py.File(tmp_path / "True.nc") as b:
        for name in values:
            for offset in ((0, 0), (8, 16), (4, 8)):
                assert zlib.decompress(a[name].id.read_direct_chunk(offset)[1]) == zlib.decompress(
                    b[name].id.read_direct_chunk(offset)[1]), (name, offset)
