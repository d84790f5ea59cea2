"""The fast exact Monte Carlo against the brute-force pixel-level reference (Men et al. 2021, Section IV)."""

import numpy as np
import pytest
from scipy import stats

from e2esim.distortion.montecarlo import gaussianity, hermitian_form, simulate
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.polarimetry.system_model import effective_weight_parts
from helpers import Z_ACCEPT, forest, system

FR = GaussianFaraday(np.pi / 3, np.pi / 36)


def _paired(fast, brute):
    """z of the mean of paired row differences (same system-error draws, different noise)."""
    d = fast.mean(axis=1) - brute.mean(axis=1)
    return d.mean() / (d.std(ddof=1) / np.sqrt(d.size))


@pytest.mark.parametrize("channel", ["hv", "hh", "vv"])
def test_fast_equals_brute_force_on_the_same_scene(seed, channel):
    scene, sys_model = forest("boreal_200"), system(-24.0, -28.0, nesz_db=-22.0)
    vectors = scene.sample(np.random.default_rng(seed + 1), 1000)
    kw = dict(looks=1000, realisations=800, noise_realisations=2, channels=(channel,), scene_vectors=vectors)
    fast = simulate(scene, sys_model, FR, np.random.default_rng(seed), method="fast", **kw)
    brute = simulate(scene, sys_model, FR, np.random.default_rng(seed), method="brute_force", **kw)
    # Same seed and draw order: identical system-error and FR realisations, independent noise.
    assert fast.reference[channel] == pytest.approx(brute.reference[channel], rel=1e-12)
    e_f, e_b = fast.errors[channel], brute.errors[channel]
    assert abs(_paired(e_f, e_b)) < Z_ACCEPT
    assert abs(_paired(e_f**2, e_b**2)) < Z_ACCEPT


def test_noise_distribution_given_the_scene_is_exact(seed):
    # One system-error realisation, a tiny window and many noise draws: the fast path's noncentral
    # chi-square must have the same distribution as averaging |a.s + nu|^2 pixel by pixel.
    scene, sys_model = forest("boreal_50"), system(-25.0, -28.0, nesz_db=-14.0)  # noise comparable to signal
    vectors = scene.sample(np.random.default_rng(seed + 1), 4)
    kw = dict(looks=4, realisations=2, noise_realisations=20_000, scene_vectors=vectors)
    fast = simulate(scene, sys_model, FR, np.random.default_rng(seed), method="fast", **kw).hv
    brute = simulate(scene, sys_model, FR, np.random.default_rng(seed), method="brute_force", **kw).hv
    for row in range(2):
        assert stats.ks_2samp(fast[row], brute[row]).pvalue > 1e-5


def test_population_reference_fast_equals_brute_force(seed):
    scene, sys_model = forest("tropical_338"), system(-26.0, -30.0)
    kw = dict(looks=200, realisations=600, reference="population")
    fast = simulate(scene, sys_model, FR, np.random.default_rng(seed), method="fast", **kw).hv
    brute = simulate(scene, sys_model, FR, np.random.default_rng(seed), method="brute_force", **kw).hv
    assert abs(stats.ttest_ind(fast.ravel(), brute.ravel()).statistic) < Z_ACCEPT
    assert stats.levene(fast.ravel(), brute.ravel()).pvalue > 1e-5


def test_paper_sizes_are_affordable_and_shaped(rng):
    mc = simulate(forest(), system(), FR, rng, looks=100_000, realisations=10_000, noise_realisations=1)
    assert mc.hv.shape == (10_000, 1)
    assert np.ndim(mc.reference["hv"]) == 0
    assert np.all(mc.hv + mc.reference["hv"] >= 0)  # estimated powers are never negative


def test_gaussianity_statistics(rng):
    normal = gaussianity(rng.normal(size=20_000))
    assert normal["normaltest_pvalue"] > 1e-5 and normal["ks_distance"] < 0.02
    skewed = gaussianity(rng.exponential(size=20_000))
    assert skewed["normaltest_pvalue"] < 1e-10 and skewed["skewness"] > 1.5


def test_simulated_errors_are_close_to_gaussian(rng):
    # Men et al. (2021), Fig. 2 and Section V-A: at the BIOMASS error levels the sigma_hv error is close to
    # Gaussian (small skewness and excess kurtosis), so exceedance probabilities follow from mean and SD.
    mc = simulate(forest("boreal_200"), system(), FR, rng, looks=100_000, realisations=10_000)
    g = gaussianity(mc.hv)
    assert abs(g["skewness"]) < 0.2
    assert abs(g["excess_kurtosis"]) < 0.3
    assert g["ks_distance"] < 0.025  # p ~ 1e-5 under exact normality at n = 10^4


def test_bad_arguments():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="method must be one of"):
        simulate(forest(), system(), FR, rng, 10, 10, method="slow")
    with pytest.raises(ValueError, match="unknown channel 'vh'"):
        simulate(forest(), system(), FR, rng, 10, 10, channels=("vh",))
    with pytest.raises(ValueError, match="scene_vectors can only be given"):
        simulate(forest(), system(), FR, rng, 10, 10, reference="population", scene_vectors=np.zeros((10, 3)))


@pytest.mark.parametrize("per_realisation", [False, True])
def test_hermitian_form_is_a_c_a_h_bit_for_bit_in_its_order(rng, per_realisation):
    # Re(a C a^H): C_ii |a_i|^2 and 2 Re(a_i C_ij a_j^*) added in the order (0,0), (0,1), (0,2), (1,1), (1,2), (2,2).
    m = 30
    delta = 0.1 * (rng.standard_normal((m, 4)) + 1j * rng.standard_normal((m, 4)))
    parts = effective_weight_parts(delta, 1 + delta[:, :2], rng.uniform(-np.pi, np.pi, m))
    a = parts[:, 0].T + 1j * parts[:, 1].T
    x = rng.standard_normal((m, 3, 3)) + 1j * rng.standard_normal((m, 3, 3))
    c = x @ np.swapaxes(x.conj(), -1, -2) if per_realisation else x[0] @ x[0].conj().T
    cm = np.broadcast_to(c, (m, 3, 3))
    expected = 0.0
    for i in range(3):
        expected = expected + cm[:, i, i].real * (a[:, i].real ** 2 + a[:, i].imag ** 2)
        for j in range(i + 1, 3):
            re = a[:, i].real * a[:, j].real + a[:, i].imag * a[:, j].imag
            im = a[:, i].imag * a[:, j].real - a[:, i].real * a[:, j].imag
            expected = expected + 2 * (cm[:, i, j].real * re - cm[:, i, j].imag * im)
    q = hermitian_form(parts, c)
    assert np.array_equal(q, expected)
    np.testing.assert_allclose(q, np.einsum("mi,mij,mj->m", a, cm, a.conj()).real, rtol=1e-12)
