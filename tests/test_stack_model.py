"""The multi-pass model: acquisition stack, RVoG covariance, temporal decorrelation, pass combinations, per-pass
Faraday rotation and system errors (docs/theory/ground-cancellation.md, eqs. 1-8, 17)."""

import numpy as np
import pytest
from scipy import integrate

from e2esim.errors import PhysicsInputError
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.polarimetry.system_model import effective_weights
from e2esim.stack import combination as combos
from e2esim.stack.acquisitions import AcquisitionStack, preset_stack, radar_wavelength, vertical_wavenumber
from e2esim.stack.faraday import ShiftedFaraday, StackFaraday, gaussian_cubature, tec_difference_sd
from e2esim.stack.quadratic_form import trig_matrices
from e2esim.stack.rvog import ForestStructure, split_covariance, volume_coherence
from e2esim.stack.scene import StackScene
from e2esim.stack.sites import SITES, ground_cancelled_exponent
from e2esim.stack.system import StackSystemErrors, error_covariance
from e2esim.stack.temporal import DAY_S, TemporalDecorrelation
from stack_helpers import rich_system, site_scene, table1


def test_vertical_wavenumber_of_a_baseline():
    # 4 pi B / (lambda rho sin theta): 1 km, 435 MHz, 740 km, 30 deg
    lam = radar_wavelength(435e6)
    assert lam == pytest.approx(0.68918, rel=1e-5)
    assert vertical_wavenumber(1000.0, lam, 740e3, np.radians(30.0)) == pytest.approx(
        4 * np.pi * 1000 / (lam * 740e3 * 0.5), rel=1e-14)


def test_phase_presets_are_the_published_pass_counts():
    assert preset_stack("interferometric", 0.5).passes == 3  # Quegan et al. (2018), Section 2
    tom = preset_stack("tomographic", 0.5)
    assert tom.passes == 7 and np.ptp(tom.time_s) / DAY_S == 18.0
    with pytest.raises(PhysicsInputError, match="unknown stack phase 'commissioning'"):
        preset_stack("commissioning", 0.5)
    with pytest.raises(PhysicsInputError, match="one time, k_z and incidence per pass"):
        AcquisitionStack([0.0, 1.0], [0.0], [0.5, 0.5])


@pytest.mark.parametrize("extinction", [0.0, 0.02, 0.3])
def test_volume_coherence_is_the_profile_integral(extinction):
    h, theta, kappa = 30.0, np.radians(30.0), 0.09
    p = 2 * extinction / np.cos(theta)
    num = integrate.quad(lambda z: np.exp(p * z) * np.cos(kappa * z), 0, h)[0] + 1j * integrate.quad(
        lambda z: np.exp(p * z) * np.sin(kappa * z), 0, h)[0]
    den = integrate.quad(lambda z: np.exp(p * z), 0, h)[0]
    assert volume_coherence(kappa, h, extinction, theta) == pytest.approx(num / den, rel=1e-10)
    assert volume_coherence(0.0, h, extinction, theta) == pytest.approx(1.0, abs=1e-12)


def test_stack_reduces_to_the_single_pass_table1_powers():
    scene = site_scene("boreal", "tomographic")
    cov = table1("boreal_200").matrix
    for n in range(scene.passes):
        np.testing.assert_allclose(scene.block(n, n), cov, rtol=0, atol=1e-15)
    assert np.linalg.eigvalsh(scene.matrix)[0] > -1e-12
    np.testing.assert_allclose(scene.volume + scene.ground, cov, atol=1e-15)
    # the ground share of HV is the ground-to-volume ratio mu / (1 + mu) (boreal preset: -3 dB)
    mu = 10 ** (SITES["boreal"].ground_to_volume_db[1] / 10)
    assert scene.ground[1, 1].real / cov[1, 1].real == pytest.approx(mu / (1 + mu), rel=1e-12)


def test_ground_is_coherent_and_volume_decorrelates_between_passes():
    t = TemporalDecorrelation(floor=0.5, time_constant_s=15 * DAY_S, ground_ratio=0.0)
    scene = site_scene("tropical", temporal=t)
    st = scene.acquisitions
    c01 = scene.block(0, 1)
    gamma_vol = SITES["tropical"].coherence(st.kz_rad_m[0] - st.kz_rad_m[1], st.incidence_rad[0])
    expected = gamma_vol * (0.5 + 0.5 * np.exp(-3 / 15)) * scene.volume + scene.ground
    np.testing.assert_allclose(c01, expected, atol=1e-15)
    assert t.volume(3 * DAY_S) == pytest.approx(0.5 + 0.5 * np.exp(-0.2))
    assert TemporalDecorrelation(0.5, DAY_S, 1.0).ground(1e9) == pytest.approx(0.5)


def test_an_impossible_ground_split_says_why():
    forest = ForestStructure(20.0, 0.1, (-20.0, -3.0, -20.0), 1.0)  # volume takes all of HH-VV correlation and more
    with pytest.raises(PhysicsInputError, match=r"the ground part of .* is not a covariance: its HH-VV coherence"):
        split_covariance(table1("boreal_200"), forest)


def test_subtraction_cancels_a_coherent_ground_exactly():
    scene = site_scene("boreal", temporal=TemporalDecorrelation.none())
    pair = combos.subtraction(3, 0, 1)
    assert pair.value(scene.ground_only().channel_matrix(1)) == pytest.approx(0.0, abs=1e-16)
    # the volume left: 2 sigma_v (1 - Re gamma_vol) (MdA 2020 / BPS ATBD eq. 5.1 for a uniform... any profile)
    g = SITES["boreal"].coherence(scene.acquisitions.kz_rad_m[0] - scene.acquisitions.kz_rad_m[1], np.radians(28.375))
    assert pair.value(scene.channel_matrix(1)) == pytest.approx(2 * scene.volume[1, 1].real * (1 - g.real), rel=1e-12)
    assert pair.noise_gain == 2.0 and pair.noise_diversity == 1.0


def test_interpolated_cancellation_follows_the_bps_operator():
    k0 = np.pi / 30.0
    # a pass exactly at k_z0 relative to the first: the reference-1 combination is a plain subtraction
    exact = combos.interpolated([0.0, k0, 2 * k0], 30.0)
    np.testing.assert_allclose(exact.weights[0], [1, -1, 0], atol=1e-15)
    # in between: weights (1 - t) e^{j (k0 - ka) z0/2} and t e^{j (k0 - kb) z0/2}, t = (k0 - ka)/(kb - ka)
    kz = [0.0, 0.087, 0.174]
    w = combos.interpolated(kz, 30.0)
    t = (k0 - 0.087) / 0.087
    np.testing.assert_allclose(w.weights[0], [1, -(1 - t) * np.exp(1j * (k0 - 0.087) * 15), -t * np.exp(
        1j * (k0 - 0.174) * 15)], atol=1e-14)
    assert "references 1, 3" in w.label and w.coefficients.tolist() == [0.5, 0.5]  # pass 2 would extrapolate
    with pytest.raises(PhysicsInputError, match=r"no reference pass brackets k_z0 = pi/z0 = 0\.1047 rad/m"):
        combos.interpolated([0.0, 0.01, 0.02], 30.0)


def test_effective_looks_of_the_multi_date_average():
    scene = site_scene("tropical")
    y = scene.channel_matrix(1)
    gamma = scene.coherence(1)
    assert combos.multi_date(3).speckle_diversity(y) == pytest.approx(9 / np.sum(np.abs(gamma) ** 2), rel=1e-12)
    assert combos.single_date(3, 2).speckle_diversity(y) == pytest.approx(1.0)
    assert combos.multi_date(3).noise_diversity == pytest.approx(3.0)


def test_effective_weights_split_into_trig_matrices(rng):
    """a = e + T1 v + T2 (U, W, D) (quadratic_form, eqs. 10-11) is the exact operator of Men et al. eq. (1)."""
    d = 0.05 * (rng.standard_normal(4) + 1j * rng.standard_normal(4))
    e = 0.05 * (rng.standard_normal(2) + 1j * rng.standard_normal(2))
    omega = 0.83
    t1, t2 = trig_matrices(np.array(omega))
    v = np.array([(d[0] + d[2]) / 2, (d[1] + d[3]) / 2, (e[0] + e[1]) / 2, (e[1] - e[0]) / 2])
    p = np.array([d[0] * d[3] - d[1] * d[2], d[0] * d[3] + d[1] * d[2], d[1] * e[1] + d[3] * e[0]])
    a = np.array([0, 1, 0]) + t1 @ v + t2 @ p
    np.testing.assert_allclose(a, effective_weights(d, 1 + e, omega), rtol=0, atol=1e-15)


@pytest.mark.parametrize("dim, degree", [(1, 5), (2, 5), (3, 5), (6, 5), (6, 3)])
def test_cubature_moments(dim, degree):
    x, w = gaussian_cubature(dim, degree)
    assert w.sum() == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(w @ x, 0, atol=1e-14)
    np.testing.assert_allclose((x * w[:, None]).T @ x, np.eye(dim), atol=1e-13)
    np.testing.assert_allclose(w @ x**3, 0, atol=1e-13)
    if degree == 5:
        np.testing.assert_allclose(w @ x**4, 3.0, rtol=1e-13)
        if dim > 1:
            assert w @ (x[:, 0] ** 2 * x[:, 1] ** 2) == pytest.approx(1.0, rel=1e-13)
            assert w @ (x[:, 0] ** 3 * x[:, 1] ** 2) == pytest.approx(0.0, abs=1e-13)


def test_the_common_shift_keeps_the_quadrature_exact():
    base = GaussianFaraday(0.9, 0.1)
    shifted = ShiftedFaraday(base, 0.05)
    expected = GaussianFaraday(0.9, np.hypot(0.1, 0.05))
    np.testing.assert_allclose(shifted.circular_moment(np.arange(1, 9)), expected.circular_moment(np.arange(1, 9)),
                               rtol=1e-13)


def test_faraday_nodes_reproduce_the_difference_statistics():
    f = StackFaraday(GaussianFaraday(1.0, 0.05), np.radians(8.0))
    omega, w = f.nodes(3)
    assert w.sum() == pytest.approx(1.0)
    diff = omega[:, 0] - omega[:, 1]
    assert w @ diff == pytest.approx(0.0, abs=1e-13)
    assert w @ diff**2 == pytest.approx(np.radians(8.0) ** 2, rel=1e-12)  # SD of the difference of two passes
    # each pass: Omega_0 + Delta_n ~ N(1, 0.05^2 + sigma_D^2 / 2), seen through its circular moments
    marginal = GaussianFaraday(1.0, np.hypot(0.05, np.radians(8.0) / np.sqrt(2)))
    for k in (2, 4):
        # the cubature of the deviations neglects O((k sigma)^6 / 6!) terms of exp(i k Delta)
        assert w @ np.exp(1j * k * omega[:, 2]) == pytest.approx(marginal.circular_moment(k), rel=2e-5)


def test_difference_sd_from_the_tec_variability():
    # Omega_rms s sqrt(2 (1 - rho)), s = sqrt(ln(1 + cv^2))
    assert tec_difference_sd(0.5, 0.25, 0.0) == pytest.approx(0.5 * np.sqrt(np.log1p(0.0625)) * np.sqrt(2))
    assert tec_difference_sd(0.5, 0.25, 1.0) == 0.0
    with pytest.raises(PhysicsInputError, match=r"correlation in \[-1, 1\]"):
        tec_difference_sd(0.5, 0.25, 1.5)


def test_per_pass_errors_have_the_stated_correlation(rng):
    system = rich_system(crosstalk=1e-2, imbalance=1e-2)
    errors = StackSystemErrors(system, 0.6)
    delta, f, gain = errors.sample(rng, 40000, 3)
    xi = np.concatenate([delta, f - 1], axis=-1)  # (M, N, 6)
    sigma1 = error_covariance(*[np.asarray(x) * 1e-2 for x in system.unit_structure])  # both levels 1e-2
    cross = np.einsum("mi,mj->ij", xi[:, 0], xi[:, 1].conj()) / xi.shape[0]
    same = np.einsum("mi,mj->ij", xi[:, 2], xi[:, 2].conj()) / xi.shape[0]
    se = 1e-2 / np.sqrt(xi.shape[0])  # each entry's SD is at most V / sqrt(M)
    assert np.max(np.abs(cross - 0.6 * sigma1)) < 6 * se
    assert np.max(np.abs(same - sigma1)) < 6 * se
    corr = np.corrcoef(np.log(gain[:, 0]), np.log(gain[:, 1]))[0, 1]
    assert abs(corr - 0.6) < 6 / np.sqrt(xi.shape[0])
    with pytest.raises(PhysicsInputError, match=r"must be in \[0, 1\], got 1\.5"):
        StackSystemErrors(system, 1.5)


def test_ground_cancelled_exponent_of_the_rvog_split():
    # p / (1 + mu): 1.9 / 1.1 tropical (-10 dB), 2.2 / (1 + 10^-0.3) boreal (-3 dB)
    assert ground_cancelled_exponent(1.9, -10.0) == pytest.approx(1.9 / 1.1, rel=1e-14)
    assert ground_cancelled_exponent(2.2, -3.0) == pytest.approx(1.46550673, rel=1e-8)


def test_stack_scene_refuses_a_non_psd_forest_with_its_reason():
    with pytest.raises(PhysicsInputError, match="incidences between 0 and 90 deg"):
        StackScene(AcquisitionStack([0.0], [0.0], [2.0]), table1("boreal_200"), SITES["boreal"],
                   TemporalDecorrelation())
