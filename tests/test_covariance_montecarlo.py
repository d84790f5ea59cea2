"""The fast exact Monte Carlo of the full estimated covariance against the brute-force pixel simulation, and the
analytic moments of every channel against it at the paper's sizes (docs/theory/co-pol-error.md, sec. 7)."""

import numpy as np
import pytest
from scipy import stats

from e2esim.distortion.covariance_montecarlo import simulate_covariance
from e2esim.distortion.faraday_correction import FaradayCorrection
from e2esim.distortion.polarimetric_moments import polarimetric_error_moments
from e2esim.distortion.validation import sample_covariance_moments
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.table1 import TABLE1_FORESTS
from helpers import Z_ACCEPT, forest, system

FR = GaussianFaraday(np.pi / 3, np.pi / 36)
ESTIMATED = FaradayCorrection("estimated", GaussianFaraday(0.0, np.radians(2.0)))
PAPER = dict(looks=100_000, realisations=10_000)
# complex pair correlations and unequal variances (the general case of Section III)
GENERAL = SystemErrorModel(crosstalk_level=2.2e-4, imbalance_level=8.8e-5, crosstalk_relative=(1.0, 1.6, 0.7, 1.2),
                           crosstalk_rho13=0.9 * np.exp(0.6j), crosstalk_rho24=0.5 * np.exp(-1.1j),
                           imbalance_relative=(1.0, 0.5), imbalance_rho=0.8 * np.exp(0.3j), noise_power=10**-2.7)


def _paired_z(fast, brute):
    """z of the mean of paired row differences (same system-error and rotation draws, other noise)."""
    d = fast.mean(axis=1) - brute.mean(axis=1)
    return d.mean(0) / (d.std(0, ddof=1) / np.sqrt(d.shape[0]))


@pytest.mark.parametrize("correction", [FaradayCorrection(), ESTIMATED], ids=["uncorrected", "corrected"])
def test_fast_equals_brute_force_on_the_same_scene(seed, correction):
    scene, sys_model = forest("boreal_200"), system(-24.0, -28.0, nesz_db=-22.0)
    vectors = scene.sample(np.random.default_rng(seed + 1), 400)
    kw = dict(looks=400, realisations=400, noise_realisations=2, scene_vectors=vectors, correction=correction)
    fast = simulate_covariance(scene, sys_model, FR, np.random.default_rng(seed), method="fast", **kw)
    brute = simulate_covariance(scene, sys_model, FR, np.random.default_rng(seed), method="brute_force", **kw)
    assert np.allclose(fast.reference, brute.reference, rtol=1e-13)
    # every element of the 3x3 covariance: diagonal, real and imaginary off-diagonal parts, and their squares
    iu = np.triu_indices(3)
    parts = lambda x: np.concatenate([x.real[..., iu[0], iu[1]], x.imag[..., [0, 0, 1], [1, 2, 2]]], -1)
    f, b = parts(fast.covariance), parts(brute.covariance)
    for power in (1, 2):
        assert np.all(np.abs(_paired_z(f**power, b**power)) < Z_ACCEPT)


def test_noise_distribution_given_the_scene_is_exact(seed):
    # one realisation of the errors, a small window, many noise draws: the noncentral Wishart of the fast path
    # has the distribution of the pixel sums (co-pol eq. 7.1); noise comparable to the signal
    scene, sys_model = forest("boreal_50"), system(-25.0, -28.0, nesz_db=-12.0)
    vectors = scene.sample(np.random.default_rng(seed + 1), 8)
    kw = dict(looks=8, realisations=2, noise_realisations=2500, scene_vectors=vectors, correction=ESTIMATED)
    fast = simulate_covariance(scene, sys_model, FR, np.random.default_rng(seed), method="fast", **kw).covariance
    brute = simulate_covariance(scene, sys_model, FR, np.random.default_rng(seed), method="brute_force",
                                **kw).covariance
    for row in range(2):
        for p, q in ((0, 0), (1, 1), (2, 2), (0, 2), (1, 2)):
            for part in (np.real, np.imag):
                if p == q and part is np.imag:
                    continue
                assert stats.ks_2samp(part(fast[row, :, p, q]), part(brute[row, :, p, q])).pvalue > 1e-5


def test_population_reference_fast_equals_brute_force_and_analytic(seed):
    # a new scene per realisation: speckle correlates the channel errors as |C_pq|^2 / L (co-pol eq. 5.4)
    scene, sys_model = forest("tropical_338"), system(-26.0, -30.0)
    kw = dict(looks=60, realisations=2000, reference="population", correction=ESTIMATED)
    fast = simulate_covariance(scene, sys_model, FR, np.random.default_rng(seed), method="fast", **kw).errors
    brute = simulate_covariance(scene, sys_model, FR, np.random.default_rng(seed + 7), method="brute_force",
                                **kw).errors
    for ch in range(3):
        assert abs(stats.ttest_ind(fast[..., ch].ravel(), brute[..., ch].ravel()).statistic) < Z_ACCEPT
        assert stats.levene(fast[..., ch].ravel(), brute[..., ch].ravel()).pvalue > 1e-5
    an = polarimetric_error_moments(scene, sys_model, FR, ESTIMATED, looks=60, reference="population")
    _assert_agree(sample_covariance_moments(fast), an)


def _assert_agree(mc, an):
    """Every mean and every element of the covariance within Z_ACCEPT standard errors."""
    z_mean = (mc["mean"] - an.mean) / mc["mean_se"]
    z_cov = (mc["covariance"] - an.covariance) / mc["covariance_se"]
    assert np.all(np.abs(z_mean) < Z_ACCEPT), z_mean
    assert np.all(np.abs(z_cov) < Z_ACCEPT), z_cov


@pytest.mark.parametrize("forest_name", sorted(TABLE1_FORESTS))
def test_analytic_equals_monte_carlo_for_every_table1_forest_at_the_paper_sizes(seed, forest_name):
    # Done-when of the issue: analytic and Monte Carlo moments of every channel and their covariances agree
    # within sampling uncertainty at L = 1e5, M = 1e4, with complex correlations and unequal variances, before
    # and after Faraday-rotation correction. The analytic moments are taken given the simulated scene's own
    # sample covariance (the "scene" reference of eq. 17): the rotation bias of HH and VV depends on it.
    base = forest(forest_name)
    fr = GaussianFaraday(np.pi / 3 if base.biome == "boreal" else 0.0, np.pi / 36)
    for correction in (FaradayCorrection(), ESTIMATED):
        mc = simulate_covariance(base, GENERAL, fr, np.random.default_rng(seed), correction=correction, **PAPER)
        an = polarimetric_error_moments(ScatteringCovariance(mc.reference), GENERAL, fr, correction,
                                        looks=PAPER["looks"])
        _assert_agree(sample_covariance_moments(mc.errors), an)


def test_off_diagonal_means_agree(seed):
    # the mean of the whole estimated covariance (co-pol eq. 3.2), HH-VV correlation included
    scene = forest("boreal_200")
    mc = simulate_covariance(scene, GENERAL, FR, np.random.default_rng(seed), looks=100_000, realisations=4000)
    an = polarimetric_error_moments(ScatteringCovariance(mc.reference), GENERAL, FR, looks=100_000)
    x = mc.covariance[:, 0, 0, 2]
    for part in (np.real, np.imag):
        z = (part(x).mean() - part(an.expected_covariance[0, 2])) / (part(x).std(ddof=1) / np.sqrt(x.size))
        assert abs(z) < Z_ACCEPT


def test_paper_sizes_shapes_and_bad_arguments(rng):
    mc = simulate_covariance(forest(), system(), FR, rng, looks=100_000, realisations=10_000)
    assert mc.covariance.shape == (10_000, 1, 3, 3) and mc.errors.shape == (10_000, 1, 3)
    assert np.all(np.linalg.eigvalsh(mc.covariance[:50, 0]) > 0)  # a covariance: positive definite
    with pytest.raises(ValueError, match="method must be one of"):
        simulate_covariance(forest(), system(), FR, rng, 10, 10, method="quick")
    with pytest.raises(ValueError, match="scene_vectors can only be given with reference='scene'"):
        simulate_covariance(forest(), system(), FR, rng, 10, 10, reference="population",
                            scene_vectors=np.zeros((10, 3)))


@pytest.mark.slow
@pytest.mark.parametrize("offset", range(5))
def test_analytic_equals_monte_carlo_for_more_seeds_and_levels(seed, offset):
    # the fast test above for other seeds and stronger errors (crosstalk -24 dB, imbalance -28 dB, 36 deg spread)
    strong = GENERAL.with_levels(crosstalk=GENERAL.crosstalk_level * 4, imbalance=GENERAL.imbalance_level * 4)
    fr = GaussianFaraday(np.pi / 3, np.radians(36.0))
    for name in sorted(TABLE1_FORESTS):
        for correction in (FaradayCorrection(), ESTIMATED, FaradayCorrection("perfect")):
            mc = simulate_covariance(forest(name), strong, fr, np.random.default_rng(seed + offset),
                                     correction=correction, **PAPER)
            an = polarimetric_error_moments(ScatteringCovariance(mc.reference), strong, fr, correction,
                                            looks=PAPER["looks"])
            _assert_agree(sample_covariance_moments(mc.errors), an)


@pytest.mark.slow
def test_fast_equals_brute_force_at_larger_sizes(seed):
    scene, sys_model = forest("tropical_341"), GENERAL
    vectors = scene.sample(np.random.default_rng(seed + 1), 5000)
    kw = dict(looks=5000, realisations=2000, scene_vectors=vectors, correction=ESTIMATED)
    fast = simulate_covariance(scene, sys_model, FR, np.random.default_rng(seed), method="fast", **kw)
    brute = simulate_covariance(scene, sys_model, FR, np.random.default_rng(seed), method="brute_force", **kw)
    for power in (1, 2):
        assert np.all(np.abs(_paired_z(fast.errors**power, brute.errors**power)) < Z_ACCEPT)
