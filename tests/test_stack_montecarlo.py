"""The exact Monte Carlo of multi-pass estimates: against the analytic moments, against the pixel-level simulation
with ground cancellation of the measured images, and the reduction to the single-pass Monte Carlo. Every check is
statistical, |z| < Z_MAX for any seed (E2ESIM_TEST_SEED); larger sizes and more configurations are slow tests."""

import numpy as np
import pytest

from e2esim.distortion.montecarlo import simulate
from e2esim.distortion.validation import compare_with_analytic, sample_moments
from e2esim.errors import PhysicsInputError
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.stack import combination as combos
from e2esim.stack.analytic import stack_hv_moments
from e2esim.stack.images import simulate_stack_images
from e2esim.stack.montecarlo import simulate_stack
from e2esim.stack.temporal import TemporalDecorrelation
from stack_helpers import BOREAL_FR, rich_system, site_scene, stack_errors

Z_MAX = 5.0  # two-sided false-failure probability 6e-7 per comparison


def _z_scores(analytic, mc, looks=None, fixed_scene=False):
    c = compare_with_analytic(float(analytic.mean), float(analytic.variance), mc.hv, looks, fixed_scene)
    return c["bias_rel_diff"] / c["bias_rel_se"], c["var_rel_diff"] / c["var_rel_se"]


def _agree(a: dict, b: dict) -> tuple:
    """z-scores of the difference of two independent samples' means and variances (``sample_moments``)."""
    zm = (a["mean"] - b["mean"]) / np.hypot(a["mean_se"], b["mean_se"])
    zv = (a["variance"] - b["variance"]) / np.hypot(a["variance_se"], b["variance_se"])
    return zm, zv


CASES = [  # (site, estimator, correlation, Faraday difference deg, reference, looks)
    ("boreal", "ground_cancelled", 0.3, 8.0, "population", 300),
    ("tropical", "multi_date", 0.0, 15.0, "scene", 10**6),
]


def _combination(name, scene):
    return {"ground_cancelled": combos.interpolated(scene.acquisitions.kz_rad_m),
            "multi_date": combos.multi_date(scene.passes), "single_date": combos.single_date(scene.passes, 0),
            "subtraction": combos.subtraction(scene.passes, 0, 1)}[name]


def _check_against_monte_carlo(rng, site, estimator, rho, diff_deg, reference, looks, phase, realisations):
    scene = site_scene(site, phase)
    errors, faraday = stack_errors(rich_system(3e-3, 5e-3, gain_sd_db=0.3), rho, diff_deg)
    comb = _combination(estimator, scene)
    analytic = stack_hv_moments(scene, errors, faraday, comb, looks, reference)
    mc = simulate_stack(scene, errors, faraday, comb, rng, looks, realisations, 1, reference)
    zb, zv = _z_scores(analytic, mc)
    assert abs(zb) < Z_MAX and abs(zv) < Z_MAX, (zb, zv)


@pytest.mark.parametrize("site, estimator, rho, diff_deg, reference, looks", CASES)
def test_analytic_moments_agree_with_the_monte_carlo(rng, site, estimator, rho, diff_deg, reference, looks):
    _check_against_monte_carlo(rng, site, estimator, rho, diff_deg, reference, looks, "interferometric", 8000)


SLOW_CASES = [
    ("boreal", "ground_cancelled", 1.0, 0.0, "scene", 10**6, "interferometric"),
    ("boreal", "ground_cancelled", 0.0, 30.0, "scene", 10**6, "interferometric"),
    ("tropical", "ground_cancelled", 0.5, 10.0, "population", 200, "interferometric"),
    ("tropical", "subtraction", 0.2, 20.0, "population", 100, "interferometric"),
    ("boreal", "single_date", 0.0, 10.0, "population", 100, "interferometric"),
    ("tropical", "multi_date", 0.7, 5.0, "population", 100, "interferometric"),
    ("boreal", "ground_cancelled", 0.5, 10.0, "scene", 10**6, "tomographic"),
    ("tropical", "ground_cancelled", 0.0, 5.0, "population", 500, "tomographic"),
]


@pytest.mark.slow
@pytest.mark.parametrize("site, estimator, rho, diff_deg, reference, looks, phase", SLOW_CASES)
def test_analytic_moments_agree_with_a_large_monte_carlo(rng, site, estimator, rho, diff_deg, reference, looks, phase):
    _check_against_monte_carlo(rng, site, estimator, rho, diff_deg, reference, looks, phase, 100_000)


@pytest.mark.parametrize("reference", ["scene", "population"])
def test_fast_path_equals_ground_cancellation_of_simulated_images(rng, reference):
    """Every channel of the fast path against the pixel-level simulation that cancels the ground on the measured
    images (same scene vectors for the one-scene reference)."""
    scene = site_scene("boreal")
    errors, faraday = stack_errors(rich_system(1e-2, 2e-2, noise_db=-20.0, gain_sd_db=0.5), 0.3, 10.0)
    comb = combos.interpolated(scene.acquisitions.kz_rad_m)
    looks, m = 24, 600
    vectors = scene.sample(rng, looks) if reference == "scene" else None
    images = simulate_stack_images(scene, errors, faraday, comb, rng, looks, m, reference, scene_vectors=vectors)
    fast = simulate_stack(scene, errors, faraday, comb, rng, looks, m, 1, reference, scene_vectors=vectors)
    for ch in ("hh", "hv", "vv"):
        zm, zv = _agree(sample_moments(images.errors[ch]), sample_moments(fast.errors[ch]))
        assert abs(zm) < Z_MAX and abs(zv) < Z_MAX, (ch, zm, zv)


def test_stable_stack_monte_carlo_reduces_to_the_single_pass_one(rng):
    """Stable errors, one Faraday rotation: the pair's Monte Carlo is the single-pass Monte Carlo of the combined
    covariance with the noise of both passes (statistically)."""
    scene = site_scene("tropical")
    errors, faraday = stack_errors(rich_system(3e-3, 5e-3, noise_db=-22.0), 1.0, 0.0)
    pair = combos.subtraction(3, 0, 1)
    looks, m = 200, 6000
    stack = simulate_stack(scene, errors, faraday, pair, rng, looks, m, 1, "population")
    combined = ScatteringCovariance(pair.combined_covariance(scene.blocks()))
    system = errors.system.with_levels(noise_power=2 * errors.system.noise_power)
    single = simulate(combined, system, BOREAL_FR, rng, looks, m, 1, "population")
    zm, zv = _agree(sample_moments(stack.hv), sample_moments(single.hv))
    assert abs(zm) < Z_MAX and abs(zv) < Z_MAX, (zm, zv)


def test_ground_left_by_unstable_errors_is_the_analytic_residual(rng):
    """The ground alone, cancelled with errors that differ between the passes: the simulated power left is the
    analytic cancellation residual."""
    scene = site_scene("boreal", temporal=TemporalDecorrelation.none())
    ground = scene.ground_only()
    errors, faraday = stack_errors(rich_system(1e-2, 1e-2, noise_db=-200.0, gain_sd_db=0.0), 0.0, 10.0)
    pair = combos.subtraction(3, 0, 1)
    analytic = stack_hv_moments(ground, errors, faraday, pair, None, "scene")
    residual = analytic.value + float(analytic.bias_distortion)
    mc = simulate_stack(ground, errors, faraday, pair, rng, 10**6, 20000, 1, "scene")
    left = sample_moments(np.real(mc.combined[..., 1, 1]))
    assert residual > 0 and abs(left["mean"] - residual) < Z_MAX * left["mean_se"] + 1e-3 * residual


def test_one_scene_needs_enough_looks(rng):
    scene = site_scene("boreal")
    errors, faraday = stack_errors()
    with pytest.raises(PhysicsInputError, match="needs at least 3N = 9 looks, got 5"):
        simulate_stack(scene, errors, faraday, combos.multi_date(3), rng, 5, 10, 1, "scene")


@pytest.mark.parametrize("phase", ["interferometric", "tomographic"])
def test_the_combined_covariance_of_every_realisation_is_the_sum_over_combinations(rng, phase):
    # sum_r c_r sum_nm w_rn w_rm^* W[n, :, m, :], the processor's combination written out, for the ground
    # cancellation (several combinations, complex weights) of 3 and 7 passes
    from e2esim.stack.montecarlo import _combine

    combination = combos.interpolated(site_scene("boreal", phase).acquisitions.kz_rad_m)
    n = combination.passes
    w = rng.standard_normal((5, n, 3, n, 3)) + 1j * rng.standard_normal((5, n, 3, n, 3))
    written_out = sum(c * np.einsum("n,m,knimj->kij", wr, wr.conj(), w)
                      for c, wr in zip(combination.coefficients, combination.weights))
    np.testing.assert_allclose(_combine(combination, w), written_out, rtol=1e-13, atol=1e-13 * np.abs(w).max())
    # one matrix-vector product over the N^2 pass pairs: each realisation's sums do not depend on the others
    alone = np.concatenate([_combine(combination, w[k:k + 1]) for k in range(len(w))])
    np.testing.assert_array_equal(alone, _combine(combination, w))


def test_the_faraday_correction_is_the_distortion_operator_without_distortion_bit_for_bit(rng):
    # faraday_correction skips distortion_operator's identity distortion factor (a product with the identity is
    # exact): the Monte Carlo's numbers are those of the full operator, bit for bit
    from e2esim.polarimetry.system_model import distortion_operator
    from e2esim.stack.montecarlo import faraday_correction

    omega = np.concatenate([rng.uniform(-np.pi, np.pi, (50, 3)), np.zeros((1, 3))])
    full = distortion_operator(np.zeros(omega.shape + (4,)), np.ones(omega.shape + (2,)), -omega)
    assert np.array_equal(faraday_correction(omega), full)


def test_the_combination_matrix_is_computed_once_and_read_only():
    combination = combos.interpolated(site_scene("boreal", "tomographic").acquisitions.kz_rad_m)
    q = combination.matrix
    assert q is combination.matrix and not q.flags.writeable
    w = combination.weights
    np.testing.assert_array_equal(q, np.einsum("r,rm,rn->mn", combination.coefficients, w.conj(), w))


@pytest.mark.parametrize("estimator", ["single_date", "multi_date", "subtraction", "ground_cancelled"])
def test_only_the_entries_the_combination_reads_are_computed_bit_for_bit(seed, monkeypatch, estimator):
    # the noncentral Wishart computes only the entries of W that the combination weighs (read_entries): the same
    # draws in the same order, so the combined covariances are those of the full W bit for bit, and so is the
    # generator's state after it
    import e2esim.stack.montecarlo as mc
    from e2esim.distortion.covariance_montecarlo import noncentral_wishart

    scene = site_scene("boreal", "tomographic")
    errors, faraday = stack_errors(rich_system(3e-3, 5e-3, gain_sd_db=0.3), 0.5, 8.0)
    comb = _combination(estimator, scene)
    mask = mc.read_entries(comb)
    assert mask.sum() == 9 * np.count_nonzero(comb.matrix) and np.array_equal(mask, mask.T)
    runs = []
    for entries in (mc.read_entries, lambda c: None):
        monkeypatch.setattr(mc, "read_entries", entries)
        rng = np.random.default_rng(seed)
        runs.append((simulate_stack(scene, errors, faraday, comb, rng, 1000, 40, 2, "scene").combined,
                     rng.standard_normal()))
    assert runs[0][0].tobytes() == runs[1][0].tobytes() and runs[0][1] == runs[1][1]
    # the helper itself: the masked entries as the full matrix's, the others 0 (the 3 x 3 dof < p path too)
    p, m = 9, 30
    rng = np.random.default_rng(seed)
    factor = rng.standard_normal((p, p, m)) + 1j * rng.standard_normal((p, p, m))
    sub = np.kron(np.eye(3, dtype=bool)[[0, 2, 1]], np.ones((3, 3), bool))  # blocks (0, 0), (1, 2), (2, 1)
    for looks in (12, 40):
        full, masked = (noncentral_wishart(np.random.default_rng(seed), factor, np.linspace(0.5, 1, p), looks, e)
                        for e in (None, sub))
        assert np.array_equal(masked[sub], full[sub]) and not masked[~sub].any()


def test_the_embedding_and_the_estimates_are_their_matrix_products_bit_for_bit(rng):
    # pass_operators takes the columns and rows of the 0/1/half weights instead of batches of 4 x 4 products: exact
    from e2esim.polarimetry.system_model import RECIPROCAL_EMBEDDING
    from e2esim.stack.montecarlo import ESTIMATES, _embedded, _estimates

    k = (rng.standard_normal((400, 7, 4, 4)) + 1j * rng.standard_normal((400, 7, 4, 4))) * np.exp(
        rng.uniform(-30, 30, (400, 7, 4, 4)))  # magnitudes over 26 decades
    assert _embedded(k).tobytes() == (k @ RECIPROCAL_EMBEDDING).tobytes()
    assert _estimates(k[..., :3]).tobytes() == (ESTIMATES @ k[..., :3]).tobytes()
