"""The co-polarised error theory (docs/theory/co-pol-error.md): the expansion of the estimators in the system
errors, its reduction to Men et al. (2021) for HV, closed forms it must reproduce, Faraday rotation exactly."""

import numpy as np
import pytest

from e2esim.distortion.analytic import hv_error_moments
from e2esim.distortion.channel_moments import CROSSTALK, IMBALANCE, unit_covariances
from e2esim.distortion.expansion import error_vector, estimator_matrix, evaluate, expansion
from e2esim.distortion.faraday_correction import FaradayCorrection
from e2esim.distortion.polarimetric_moments import (
    ErrorPolynomial,
    error_polynomial,
    node_polynomials,
    polarimetric_error_moments,
)
from e2esim.errors import PhysicsInputError
from e2esim.faraday.distribution import ConstantFaraday, EmpiricalFaraday, GaussianFaraday
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.polarimetry.system_model import effective_weights
from e2esim.scene.covariance import ScatteringCovariance
from helpers import forest, system

UNEQUAL = SystemErrorModel(crosstalk_level=1e-3, imbalance_level=4e-4, crosstalk_relative=(1, 2, 0.5, 1.5),
                           crosstalk_rho13=0.7 * np.exp(1j), crosstalk_rho24=0.3 * np.exp(-2j),
                           imbalance_relative=(1, 0.3), imbalance_rho=0.8 * np.exp(0.5j), noise_power=2e-3,
                           gain_offset_db=0.3, gain_sd_db=0.2)


def _random_errors(rng, n, scale=0.05):
    delta = scale * (rng.normal(size=(n, 4)) + 1j * rng.normal(size=(n, 4)))
    f = 1 + scale * (rng.normal(size=(n, 2)) + 1j * rng.normal(size=(n, 2)))
    return delta, f


def test_expansion_is_exact_with_and_without_correction(rng):
    # co-pol eq. (2.3): the operator is at most bilinear in the errors, so the expansion is exact
    delta, f = _random_errors(rng, 50)
    omega, omega_hat = rng.uniform(-2, 2, 50), rng.uniform(-2, 2, 50)
    for oh in (None, omega_hat):
        exact = estimator_matrix(delta, f, omega, oh)
        assert np.max(np.abs(evaluate(expansion(omega, oh), error_vector(delta, f)) - exact)) < 1e-14
    uncorrected = estimator_matrix(delta, f, omega)
    for k, ch in enumerate(("hh", "hv", "vv")):  # the rows of the existing system model
        assert np.allclose(uncorrected[:, k, :], effective_weights(delta, f, omega, ch), atol=1e-15)
    # the symmetrised HV estimate is unchanged by any correcting rotation (Men et al. 2021, eq. 2)
    assert np.allclose(estimator_matrix(delta, f, omega, omega_hat)[:, 1], uncorrected[:, 1], atol=1e-15)


def test_expansion_takes_the_one_term_sums_bit_for_bit(rng):
    """``expansion`` takes the sums over the one entry of each receive and transmit basis matrix alone: the same
    numbers, bit for bit and with einsum's +0 for a zero, as the generic sums over every index (kept in the kernel
    memo and read by every node kernel, so a last-bit change would move locked numbers)."""
    from e2esim.distortion import expansion as ex
    from e2esim.polarimetry.system_model import faraday_matrix

    omega = np.concatenate([rng.uniform(-4, 4, 300), np.arange(-8, 8) * np.pi / 8])  # with exact zeros of cos, sin
    for omega_hat in (None, omega, omega - rng.normal(0, 0.1, omega.size), np.zeros(omega.size)):
        e = ex.expansion(omega.reshape(-1, 2), None if omega_hat is None else omega_hat.reshape(-1, 2))
        q = faraday_matrix(omega.reshape(-1, 2))
        p = np.broadcast_to(np.eye(2), q.shape) if omega_hat is None else faraday_matrix(-omega_hat.reshape(-1, 2))
        qsq = np.einsum("...ab,cbd,...de->...cae", q, ex._SCENE_BASIS, q)
        left, right = np.einsum("...ab,...cbd->...cad", p, qsq), np.einsum("...cab,...bd->...cad", qsq, p)
        pr = np.einsum("...ab,ibd->...iad", p, ex._RECEIVE_BASIS)
        tp = np.einsum("jab,...bd->...jad", ex._TRANSMIT_BASIS, p)
        u = np.concatenate([np.einsum("...iab,...cbd->...icad", pr, right),
                            np.einsum("...cab,...jbd->...jcad", left, tp)], axis=-4)
        w = np.einsum("...iab,...cbd,...jde->...ijcae", pr, qsq, tp)
        for got, generic in ((e.u, u), (e.w, w)):
            generic = np.swapaxes(ex.estimate_channels(generic), -1, -2)
            assert np.array_equal(got, generic) and np.array_equal(np.signbit(got), np.signbit(generic))


def test_pure_rotation_mixes_hh_and_vv_and_correction_undoes_it():
    omega = 0.7
    c, s = np.cos(omega), np.sin(omega)
    a = estimator_matrix(np.zeros(4), np.ones(2), omega)
    # M_hh = c^2 S_hh - s^2 S_vv, M_vv = c^2 S_vv - s^2 S_hh (Quegan et al. 2018, eqs. 1-2)
    assert a[0] == pytest.approx([c * c, 0, -s * s], abs=1e-15)
    assert a[2] == pytest.approx([-s * s, 0, c * c], abs=1e-15)
    assert np.allclose(estimator_matrix(np.zeros(4), np.ones(2), omega, omega), np.eye(3), atol=1e-15)


@pytest.mark.parametrize("reference", ["scene", "population"])
@pytest.mark.parametrize("case", ["paper", "unequal"])
def test_hv_equals_the_existing_analysis_to_1e12(case, reference):
    scene, sys_model = (
        (forest("boreal_200"), system(-24, -28)) if case == "paper" else (forest("tropical_338"), UNEQUAL)
    )
    fr = GaussianFaraday(np.pi / 3, 0.6)
    levels = np.array([1e-5, 1e-4, 1e-3])
    for looks in (None, 1000):
        old = hv_error_moments(scene, sys_model, fr, looks=looks, reference=reference,
                               crosstalk_level=levels[:, None], imbalance_level=levels)
        new = polarimetric_error_moments(scene, sys_model, fr, looks=looks, reference=reference,
                                         crosstalk_level=levels[:, None], imbalance_level=levels, higher_order=False)
        assert new.mean.shape == (3, 3, 3) and new.covariance.shape == (3, 3, 3, 3)
        assert np.max(np.abs(new.mean[..., 1] / old.mean - 1)) < 1e-12
        assert np.max(np.abs(new.variance[..., 1] / old.variance - 1)) < 1e-12
        assert np.allclose(new.cov_faraday_spread[..., 1, 1], old.var_faraday_spread, rtol=1e-9, atol=0)
    # and at the model's own levels, the noise bias sigma_n / 2 exactly
    assert new.bias_noise[..., 1] == pytest.approx(sys_model.noise_power / 2)


def test_first_order_closed_forms_after_correction():
    # co-pol eq. (4.4): with the rotation corrected exactly, to first order
    # x_hh = 2 Re[s^2 Sigma_eps + cs Delta], x_vv = 2 Re[c^2 Sigma_eps - cs Delta], x_hv = Re Sigma_eps
    # (Sigma_eps = eps1 + eps2, Delta = delta3 + delta4 - delta1 - delta2, c, s of Omega)
    omega = 0.9
    c, s = np.cos(omega), np.sin(omega)
    scene, sys_model = forest("boreal_200"), UNEQUAL
    poly = error_polynomial(scene, sys_model, ConstantFaraday(omega), FaradayCorrection("perfect"))
    v, c13, c24, ve, ce12 = sys_model.unit_structure
    e_sum = ve[0] + ve[1] + 2 * np.real(ce12)  # E|eps1 + eps2|^2 at unit level
    e_delta = v.sum() - 2 * np.real(c13) - 2 * np.real(c24)  # E|Delta|^2
    sigma = np.real(np.diag(scene.matrix))
    k_eps = poly.cov[IMBALANCE] / np.outer(sigma, sigma)
    k_delta = poly.cov[CROSSTALK] / np.outer(sigma, sigma)
    assert k_eps[0, 0] == pytest.approx(2 * s**4 * e_sum, rel=1e-12)
    assert k_eps[2, 2] == pytest.approx(2 * c**4 * e_sum, rel=1e-12)
    assert k_eps[1, 1] == pytest.approx(e_sum / 2, rel=1e-12)  # 2 V_A of eq. (12a)
    assert k_eps[0, 1] == pytest.approx(s**2 * e_sum, rel=1e-12)
    assert k_eps[0, 2] == pytest.approx(2 * c**2 * s**2 * e_sum, rel=1e-12)
    assert k_delta[0, 0] == pytest.approx(2 * c**2 * s**2 * e_delta, rel=1e-12)
    assert k_delta[0, 2] == pytest.approx(-2 * c**2 * s**2 * e_delta, rel=1e-12)
    assert k_delta[1, 1] == pytest.approx(0.0, abs=1e-15)  # HV: no first-order crosstalk term


def test_first_order_closed_forms_without_correction():
    # co-pol eq. (4.3): uncorrected, HH has no first-order imbalance, VV has all of it (R_hh = T_hh = 1)
    poly = error_polynomial(forest("boreal_200"), UNEQUAL, ConstantFaraday(0.9))
    q = np.real(np.diagonal(poly.mean[0]))  # the rotated powers c^4 s_hh + s^4 s_vv - 2 c^2 s^2 R cos theta
    _, _, _, ve, ce12 = UNEQUAL.unit_structure
    assert poly.cov[IMBALANCE][0, 0] == pytest.approx(0.0, abs=1e-18)
    assert poly.cov[IMBALANCE][2, 2] == pytest.approx(2 * q[2] ** 2 * (ve[0] + ve[1] + 2 * np.real(ce12)), rel=1e-12)


def test_rotation_bias_is_exact_for_a_gaussian_rotation():
    # zero order in the errors: E[c^4] s_hh + E[s^4] s_vv - 2 E[c^2 s^2] R cos theta, eq. (9) moments
    scene, fr = forest("boreal_200"), GaussianFaraday(np.pi / 3, np.pi / 36)
    m = polarimetric_error_moments(scene, system(), fr)
    t = fr.trig_moments()
    rcos = np.real(scene.hhvv)
    expected_hh = t["c4"] * scene.sigma_hh + t["s4"] * scene.sigma_vv - 2 * t["c2s2"] * rcos - scene.sigma_hh
    assert m.bias_faraday[0] == pytest.approx(expected_hh, rel=1e-12)
    assert m.bias_faraday[0] / scene.sigma_hh == pytest.approx(-0.68, abs=0.01)  # "tens of percent"
    assert m.bias_faraday[1] == pytest.approx(0.0, abs=1e-15)


def test_estimated_correction_averages_the_residual_rotation_exactly(rng):
    # a residual rotation that is sometimes off by the pi/2 ambiguity swaps HH and -VV: the exact quadrature
    # over (Omega, dW) gives the mixture, checked against direct averaging over both sample sets
    scene, sys_model = forest("boreal_200"), system(nesz_db=None)
    omega_samples, dw_samples = rng.normal(1.0, 0.1, 7), np.array([0.0, 0.003, -0.002, np.pi / 2])
    fr, dw = EmpiricalFaraday(omega_samples), EmpiricalFaraday(dw_samples)
    m = polarimetric_error_moments(scene, sys_model, fr, FaradayCorrection("estimated", dw))
    means = [polarimetric_error_moments(scene, sys_model, ConstantFaraday(o),
                                        FaradayCorrection("estimated", ConstantFaraday(d))).mean
             for o in omega_samples for d in dw_samples]
    assert np.allclose(m.mean, np.mean(means, axis=0), rtol=1e-10, atol=1e-15)
    assert m.mean[0] / scene.sigma_hh == pytest.approx(0.25 * (scene.sigma_vv / scene.sigma_hh - 1), abs=0.01)


def test_equal_residual_rotations_share_one_polynomial(rng):
    # each case of a sweep (and each step of an allocation search) draws a new EmpiricalFaraday residual: one of
    # equal samples is the same quadrature, so the polynomial is computed once and shared through the process's
    # kernel memo (handed in as ``case.services.memo``), not rebuilt
    from e2esim.case import KernelMemo

    scene, sys_model, fr, memo = forest("boreal_200"), system(), GaussianFaraday(0.4, 0.05), KernelMemo()
    samples = rng.normal(0.0, 0.02, 50)

    def polynomial(residual):
        return error_polynomial(scene, sys_model, fr, FaradayCorrection("estimated", residual), memo)

    first = polynomial(EmpiricalFaraday(samples))
    again = polynomial(EmpiricalFaraday(samples.copy()))
    other = polynomial(EmpiricalFaraday(samples * 2))
    assert again is first and other is not first


def test_rotations_on_the_same_nodes_share_the_node_polynomials_bit_for_bit(rng):
    # the residual rotations of one scene's cases share their quadrature nodes and differ in their weights: the
    # conditional moments at the nodes are computed once (error_polynomial keeps them) and averaged per weights
    scene, gammas = forest("boreal_200"), unit_covariances(system())
    omega, omega_hat = rng.normal(0.4, 0.1, 9), rng.normal(0.0, 0.01, 9)
    nodes = node_polynomials(scene.matrix, gammas, omega, omega_hat)
    for weights in (rng.dirichlet(np.ones(9)), rng.dirichlet(np.ones(9))):
        shared = ErrorPolynomial.build(scene.matrix, gammas, omega, omega_hat, weights, nodes)
        fresh = ErrorPolynomial.build(scene.matrix, gammas, omega, omega_hat, weights)
        for name in ("sigma", "mean", "cov", "spread", "cov_higher"):
            assert np.array_equal(getattr(shared, name), getattr(fresh, name)), name


def test_general_scene_covariance_is_accepted():
    # no reflection symmetry needed: an HH-HV correlation adds a first-order crosstalk term to HH at Omega = 0
    m = np.array(forest("boreal_200").matrix)
    m[0, 1] = m[1, 0] = 0.05 * np.sqrt(m[0, 0] * m[1, 1]) * np.exp(0.4j)
    m[1, 0] = np.conj(m[0, 1])
    poly = error_polynomial(ScatteringCovariance(m), system(), ConstantFaraday(0.0))
    assert poly.cov[CROSSTALK][0, 0] > 0
    symmetric = error_polynomial(forest("boreal_200"), system(), ConstantFaraday(0.0))
    assert symmetric.cov[CROSSTALK][0, 0] == pytest.approx(0.0, abs=1e-18)


def test_bad_correction_is_refused_by_its_message():
    with pytest.raises(PhysicsInputError, match="must be one of"):
        FaradayCorrection("sometimes")
    with pytest.raises(PhysicsInputError, match="needs the residual rotation"):
        FaradayCorrection("estimated")
