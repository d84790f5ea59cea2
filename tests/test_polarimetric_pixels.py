"""The co-polarised error moments vectorised over pixels (``e2esim.distortion.polarimetric_pixels``) give the
numbers of the case-by-case ``polarimetric_error_moments`` (co-pol eqs. 3.2-3.6, 4.2, 5.1-5.4) for any scene,
Gaussian rotation, noise and looks: the same exact polynomials, contracted in another order (the scene through the
polarisation identity), so they agree to rounding (1e-10 relative, far below the float32 outputs' 6e-8)."""

from __future__ import annotations

import numpy as np
import pytest

from e2esim.case import KernelMemo
from e2esim.distortion.polarimetric_moments import polarimetric_error_moments
from e2esim.distortion.polarimetric_pixels import (
    PIXEL_MODELS_KEPT,
    PolarimetricPixelModel,
    gaussian_weights,
    pixel_model_for,
)
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.scene.covariance import ScatteringCovariance

UNEQUAL = SystemErrorModel(crosstalk_level=1e-3, imbalance_level=4e-4, crosstalk_relative=(1, 2, 0.5, 1.5),
                           crosstalk_rho13=0.7 * np.exp(1j), crosstalk_rho24=0.3 * np.exp(-2j),
                           imbalance_relative=(1, 0.3), imbalance_rho=0.8 * np.exp(0.5j), noise_power=2e-3,
                           gain_offset_db=0.3, gain_sd_db=0.2)
RTOL = 1e-10


def random_pixels(rng, n):
    hh, hv, vv = rng.uniform(0.02, 0.3, n), rng.uniform(0.005, 0.08, n), rng.uniform(0.02, 0.3, n)
    hhvv = rng.uniform(0.0, 0.9, n) * np.sqrt(hh * vv) * np.exp(1j * rng.uniform(-np.pi, np.pi, n))
    return (np.stack([hh, hv, vv, hhvv.real, hhvv.imag], -1), rng.uniform(-0.5, 0.5, n),
            rng.uniform(0.0, 0.2, n), rng.uniform(0.0, 0.02, n))


@pytest.mark.parametrize(("higher_order", "looks", "rotations"), [
    (True, None, 16),  # a rotation per pixel: weights per pixel
    (False, 16.0, 2),  # pixels grouped by their rotation
    (True, 9.0, 1),  # one rotation for all (a NISAR product: the scenario's)
])
def test_pixels_give_the_numbers_of_polarimetric_error_moments(rng, higher_order, looks, rotations):
    scene, fr_mean, fr_sd, noise = random_pixels(rng, 16)
    fr_mean, fr_sd = fr_mean[np.arange(16) % rotations], fr_sd[np.arange(16) % rotations]
    fr_sd[0] = 0.0 if rotations > 1 else fr_sd[0]  # a rotation known exactly
    model = PolarimetricPixelModel.build(UNEQUAL, higher_order)
    n_looks = None if looks is None else np.full(16, looks)
    mean, var = model.moments(scene, fr_mean, fr_sd, noise, n_looks)
    for i in (0, 1, 7, 14):
        hh, hv, vv, re, im = scene[i]
        c = np.array([[hh, 0, re + 1j * im], [0, hv, 0], [re - 1j * im, 0, vv]])
        m = polarimetric_error_moments(ScatteringCovariance(c), UNEQUAL, GaussianFaraday(fr_mean[i], fr_sd[i]),
                                       looks=looks, noise_power=noise[i], higher_order=higher_order)
        np.testing.assert_allclose(mean[i], m.mean, rtol=RTOL)
        np.testing.assert_allclose(var[i], m.variance, rtol=RTOL)


def test_pixel_models_are_kept_in_the_callers_memo_by_the_systems_values():
    """``pixel_model_for`` keeps what ``build`` gives in the memo it is handed, found again by the system's values
    (an equal system made anew), a model per level, at most ``PIXEL_MODELS_KEPT`` of them."""
    memo = KernelMemo()
    model = pixel_model_for(UNEQUAL, memo)
    built = PolarimetricPixelModel.build(UNEQUAL)
    np.testing.assert_array_equal(model.mean, built.mean)
    np.testing.assert_array_equal(model.cov, built.cov)
    assert model.gain_moments == built.gain_moments
    assert pixel_model_for(UNEQUAL.with_levels(), memo) is model  # equal values, another object
    assert pixel_model_for(UNEQUAL, KernelMemo()) is not model  # another process's memo: built anew
    assert pixel_model_for(UNEQUAL, memo, higher_order=False) is not model
    for k in range(1, PIXEL_MODELS_KEPT + 1):
        assert pixel_model_for(UNEQUAL.with_levels(crosstalk=(1 + k) * 1e-3), memo) is not model
    assert [key[0] for key in memo.keys()].count("pixel model") == PIXEL_MODELS_KEPT
    assert pixel_model_for(UNEQUAL, memo) is not model  # the least recently used left first


def test_gaussian_weights_are_the_distributions_quadrature_weights():
    fr = GaussianFaraday(0.3, 0.1)
    np.testing.assert_allclose(gaussian_weights(np.array([0.3]), np.array([0.1]))[0], fr.quadrature()[1],
                               rtol=1e-13, atol=1e-15)
