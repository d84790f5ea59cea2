"""The joint HH, HV and VV error model of multi-pass estimates (docs/theory/ground-cancellation.md, Section 3.2):
HV equal to the HV model, the reduction to issue 12's single-pass analysis of the ground-cancelled covariance, the
analytic joint moments against the Monte Carlo (statistical, any seed), the multi-channel retrieval on ground-
cancelled data with the random-error budget."""

import dataclasses
import functools

import numpy as np
import pytest

from e2esim.distortion.covariance_montecarlo import noncentral_wishart
from e2esim.distortion.faraday_correction import FaradayCorrection
from e2esim.distortion.polarimetric_moments import polarimetric_error_moments
from e2esim.distortion.validation import sample_covariance_moments
from e2esim.retrieval.combine import intensity_correlation
from e2esim.retrieval.multichannel import TABLE1_ALPHA
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.stack import combination as combos
from e2esim.stack.analytic import stack_hv_moments
from e2esim.stack.error_model import StackHVErrorModel
from e2esim.stack.joint_model import StackJointErrorModel
from e2esim.stack.joint_moments import stack_joint_moments
from e2esim.stack.montecarlo import simulate_stack
from e2esim.stack.multichannel_retrieval import ground_cancelled_alphas
from e2esim.stack.sites import SITES
from e2esim.stack.temporal import TemporalDecorrelation
from helpers import Z_ACCEPT
from stack_helpers import BOREAL_FR, rich_system, site_scene, stack_errors

RTOL = 1e-12


def _models(reference="population", site="boreal", rho=0.4, diff_deg=6.0, phase="interferometric", **kw):
    scene = site_scene(site, phase)
    errors, faraday = stack_errors(rich_system(1e-3, 2e-3), rho, diff_deg)
    base = dict(scene=scene, errors=errors, faraday=faraday, looks=200, reference=reference,
                combination=combos.interpolated(scene.acquisitions.kz_rad_m), **kw)
    return StackHVErrorModel(**base), StackJointErrorModel(**base)


def _same(a, b, scale, mu=0.0):
    """a = b to RTOL of ``scale``; a variance also to the rounding of its Faraday-rotation spread
    E[mu^2] - (E mu)^2 (terms of size mu^2, the estimate's mean power, summed over the nodes): 32 eps mu^2."""
    assert abs(float(a) - float(b)) <= RTOL * abs(scale) + 32 * np.finfo(float).eps * mu**2, (a, b)


@pytest.mark.parametrize("reference", ["scene", "population"])
def test_hv_of_the_joint_model_is_the_hv_model(reference):
    """Every HV number of the joint model equals StackHVErrorModel's: moments and parts, contributions, every
    source removed, levels as arrays, output scalars (scene reference; the population reference's own terms, the
    speckle of a multi-reference combination among them, with the moments and scalars)."""
    hv, joint = _models(reference)
    m, j = hv.current(), joint.current_joint()
    var, mu = float(m.variance), hv.value
    _same(m.mean, j.mean[1], m.mean)
    _same(m.variance, j.covariance[1, 1], var)
    for name, key in (("bias_distortion", "bias_distortion"), ("bias_noise", "bias_noise"), ("bias_gain", "bias_gain")):
        _same(getattr(m, name), getattr(j, key)[1], m.mean)
    for name, key in (("var_distortion", "cov_distortion"), ("var_pass_gain", "cov_pass_gain"),
                      ("var_faraday_spread", "cov_faraday_spread"), ("var_gain", "cov_gain"),
                      ("var_finite_looks", "cov_finite_looks")):
        _same(getattr(m, name), getattr(j, key)[1, 1], var, mu)
    a, b = hv.scalars(), joint.scalars()
    for key, value in a.items():
        if key.endswith(".sd"):  # sqrt of a variance: half its relative rounding
            _same(value**2, b[key] ** 2, value**2, mu)
        else:
            _same(value, b[key], value, mu if "var" in key else 0.0)
    if reference == "population":
        return
    for name, c in hv.contributions().items():
        other = joint.contributions()[name]
        _same(c.mean, other.mean, m.mean)
        _same(c.variance, other.variance, var, mu)
    for source in hv.sources:
        a, b = hv.without(source).current(), joint.without(source).current()
        _same(a.mean, b.mean, a.mean)
        _same(a.variance, b.variance, a.variance, mu)
    levels = dict(crosstalk=np.array([1e-4, 1e-3])[:, None], faraday_difference=np.array([0.0, 0.02])[None, :])
    np.testing.assert_allclose(joint.moments(**levels).mean, hv.moments(**levels).mean, rtol=RTOL)
    np.testing.assert_allclose(joint.moments(**levels).variance, hv.moments(**levels).variance, rtol=RTOL)


@pytest.mark.parametrize("temporal", [TemporalDecorrelation.none(), TemporalDecorrelation()],
                         ids=["no decorrelation", "decorrelation"])
@pytest.mark.parametrize("correct", [True, False], ids=["corrected", "uncorrected"])
@pytest.mark.parametrize("reference", ["scene", "population"])
def test_stable_errors_reduce_to_issue_12_on_the_ground_cancelled_covariance(reference, correct, temporal):
    """The Done-when identity for all channels: stable system errors, no Faraday-rotation difference, one
    combination of the passes (a pair, one date). The distortion then acts identically on every pass, and the joint
    moments are those of PolarimetricErrorModel on the combined (ground-cancelled) covariance, with the noise of the
    combined passes, Faraday rotation corrected on every pass (perfect correction) or not at all."""
    scene = site_scene("boreal", temporal=temporal)
    errors, faraday = stack_errors(correlation=1.0, difference_deg=0.0)
    for comb in (combos.subtraction(3, 2, 0), combos.single_date(3, 1)):
        joint = StackJointErrorModel(scene, errors, faraday, comb, looks=150, reference=reference,
                                     correct_copol=correct)
        # the stack kernel is second order in the errors (eq. 22): the single-pass moments to the same order
        single = functools.partial(
            polarimetric_error_moments, ScatteringCovariance(comb.combined_covariance(scene.blocks())),
            errors.system.with_levels(noise_power=errors.system.noise_power * comb.noise_gain), BOREAL_FR,
            FaradayCorrection("perfect" if correct else "none"), 150, reference, higher_order=False)
        a, b = joint.current_joint(), single()
        # corrected: the single-pass moments average the O(V^3), O(V^4) part of the spread of the conditional mean
        # exactly (harmonics up to 16 Omega, 33 nodes; co-pol sec. 4), the stack's rule to degree 8: 1e-8 of the
        # covariance here, 1e-7 at crosstalk 3e-3 (the part grows as V^3)
        cov_rtol = 1e-6 if correct else RTOL
        np.testing.assert_allclose(joint.values, b.sigma, rtol=RTOL)
        np.testing.assert_allclose(a.mean, b.mean, rtol=0, atol=RTOL * np.abs(b.mean).max())
        np.testing.assert_allclose(a.covariance, b.covariance, rtol=0, atol=cov_rtol * np.abs(b.covariance).max())
        np.testing.assert_allclose(a.expected_covariance, b.expected_covariance, rtol=0,
                                   atol=RTOL * np.abs(b.expected_covariance).max())
        x = np.array([1e-4, 3e-3])  # at other levels too
        np.testing.assert_allclose(joint.joint_moments(crosstalk=x).covariance,
                                   single(crosstalk_level=x).covariance, rtol=0,
                                   atol=cov_rtol * np.abs(b.covariance).max())


def _agree(rng, site, reference, looks, rho, diff_deg, correct, realisations):
    """Means and every element of the covariance of the three channels' errors within Z_ACCEPT standard errors;
    for one scene of L looks its sample covariance moves the analytic moments by O(1/sqrt(L)) (added to the
    standard errors, as compare_with_analytic does)."""
    scene = site_scene(site)
    errors, faraday = stack_errors(rich_system(3e-3, 5e-3, gain_sd_db=0.3), rho, diff_deg)
    comb = combos.interpolated(scene.acquisitions.kz_rad_m)
    an = StackJointErrorModel(scene, errors, faraday, comb, looks=looks, reference=reference,
                              correct_copol=correct).current_joint()
    mc = simulate_stack(scene, errors, faraday, comb, rng, looks, realisations, 1, reference, correct)
    s = sample_covariance_moments(np.stack([mc.errors[ch] for ch in ("hh", "hv", "vv")], -1))
    mean_se, cov_se = s["mean_se"], s["covariance_se"]
    if reference == "scene":
        sd = np.sqrt(np.diag(an.covariance))
        mean_se = np.hypot(mean_se, 2 * np.abs(an.bias_distortion) / np.sqrt(looks))
        cov_se = np.hypot(cov_se, 2 * np.outer(sd, sd) / np.sqrt(looks))
    z_mean = (s["mean"] - an.mean) / mean_se
    z_cov = (s["covariance"] - an.covariance) / cov_se
    assert np.all(np.abs(z_mean) < Z_ACCEPT), z_mean
    assert np.all(np.abs(z_cov) < Z_ACCEPT), z_cov


def test_analytic_joint_moments_agree_with_the_monte_carlo(rng):
    """Ground cancelled (interferometric), partly stable errors, Faraday-rotation differences, a gain error, the
    co-polarised channels corrected on every pass; a new scene per realisation (speckle included)."""
    _agree(rng, "boreal", "population", 300, 0.3, 8.0, True, 6000)


@pytest.mark.slow
@pytest.mark.parametrize("site, reference, looks, rho, diff_deg, correct", [
    ("tropical", "scene", 10**6, 0.0, 15.0, True),
    ("boreal", "scene", 10**6, 1.0, 0.0, True),
    ("boreal", "scene", 10**6, 0.5, 2.0, False),  # uncorrected: the rotation difference cubature is O((4 s_D)^6)
    ("tropical", "population", 200, 0.7, 30.0, True),
])
def test_analytic_joint_moments_agree_with_a_large_monte_carlo(rng, site, reference, looks, rho, diff_deg, correct):
    _agree(rng, site, reference, looks, rho, diff_deg, correct, 100_000)


def test_noncentral_wishart_in_any_dimension(rng):
    """Issue 12's helper in 9 dimensions (3 passes): mean signal + noise, and the exact variance of each diagonal
    entry, (|k_p|^2 2 s_p^2 + L s_p^4) / L^2, for the scatter factor k and noise SDs s; also with L < 2p (the rest
    of the noise drawn look by look)."""
    p, m = 9, 6000
    a = rng.standard_normal((p, p)) + 1j * rng.standard_normal((p, p))
    sd = np.linspace(0.3, 1.2, p)
    for looks in (12, 40):
        w = noncentral_wishart(rng, np.repeat(a[:, :, None], m, -1), sd, looks)
        signal = np.real(np.sum(np.abs(a) ** 2, axis=1))
        diag = np.real(np.diagonal(w, axis1=0, axis2=1))  # (M, p)
        expected = signal / looks + sd**2
        var = (2 * signal * sd**2 + looks * sd**4) / looks**2
        z = (diag.mean(0) - expected) / np.sqrt(var / m)
        assert np.all(np.abs(z) < Z_ACCEPT), z
        assert np.allclose(w, np.conj(np.swapaxes(w, 0, 1)))


def test_speckle_correlation_of_one_combination_is_the_intensity_correlation():
    _, joint = _models("scene")
    pair = dataclasses.replace(joint, combination=combos.subtraction(3, 0, 1))
    combined = pair.combination.combined_covariance(pair.scene.blocks())
    np.testing.assert_allclose(pair.speckle_correlation(), intensity_correlation(combined), atol=1e-14)
    multi = joint.speckle_correlation()  # two references: less correlated than one combination's intensities
    assert np.allclose(np.diag(multi), 1.0) and 0 < multi[0, 2] < 1 and multi[0, 1] == pytest.approx(0.0, abs=1e-15)


def test_ground_cancelled_exponents():
    """alpha (1 + mu) for rvog (eq. 24, the HV exponent of stack_power_law), the ground-cancelled HV's for volume (the
    default of HH), the biome's for same."""
    tropical = ground_cancelled_alphas(TABLE1_ALPHA["tropical"], SITES["tropical"].ground_to_volume_db)
    np.testing.assert_allclose(tropical, [1.1 / 1.9, 1.1 / 1.9, 0.0612 * (1 + 10**-0.6)], rtol=1e-14)
    same = ground_cancelled_alphas(TABLE1_ALPHA["tropical"], SITES["tropical"].ground_to_volume_db, ("same",) * 3)
    np.testing.assert_allclose(same, TABLE1_ALPHA["tropical"], rtol=0)
    boreal = ground_cancelled_alphas(TABLE1_ALPHA["boreal"], SITES["boreal"].ground_to_volume_db, ("rvog",) * 3)
    np.testing.assert_allclose(boreal, np.array(TABLE1_ALPHA["boreal"]) * (1 + 10 ** (np.array([3, -3, 0]) / 10)),
                               rtol=1e-14)


def _stack_retrieval_case(seed, realisations=2500, **stage):
    """A case through the stack stages (tropical site, the BIOMASS instrument): scene, joint error model with its
    Monte Carlo, the 200 m error budget with the stack's effective looks."""
    from e2esim.settings import SimulationSettings
    from e2esim.stack.modules import RVoGStackScene, StackBackscatterError, StackErrorBudget
    from e2esim.testing import reference_case

    settings = SimulationSettings(mode="both", seed=1, looks=2000, realisations=realisations)
    case = reference_case(("scene.covariance", "system.residual", "faraday.residual", "instrument"),
                          settings=settings, seed=seed)
    case = case.adding({"scene.stack": RVoGStackScene(site="tropical").forward(case)["scene.stack"]})
    case = case.adding(StackBackscatterError(channels="all", system_error_correlation=0.5, **stage).forward(case))
    return case.adding(StackErrorBudget(temporal={"sd_percent": 5.0}).forward(case))


def test_joint_agb_error_with_the_budget_agrees_with_the_monte_carlo(seed):
    """Co-pol eq. (8.4): the random-error budget adds its relative covariance to the systematic one in the delta
    method; the Monte Carlo adds correlated draws to every simulated triple and inverts it. The contributions add up
    to the total; the budget's terms are zero-mean."""
    from e2esim.stack.multichannel_retrieval import StackMultiChannelRetrieval
    from helpers import mean_and_variance_z

    case = _stack_retrieval_case(seed)
    agb = StackMultiChannelRetrieval().forward(case)["agb.error"]
    m_mean, m_sd = agb.error_mean, agb.error_sd
    z_mean, z_var = mean_and_variance_z(np.log1p(agb.samples), m_mean, m_sd**2)  # y = ln(AGB_hat / AGB)
    assert abs(z_mean) < Z_ACCEPT and abs(z_var) < Z_ACCEPT, (z_mean, z_var)
    parts = {c.name: c for c in agb.contributions}
    assert {"speckle_noise", "temporal", "nonlinearity", "system_distortions"} <= set(parts)
    assert sum(c.relative_variance for c in parts.values()) == pytest.approx(m_sd**2, rel=1e-12)
    assert sum(c.relative_mean for c in parts.values()) == pytest.approx(m_mean, rel=1e-12, abs=1e-15)
    assert parts["speckle_noise"].relative_mean == 0.0 and parts["speckle_noise"].relative_variance > 0


def test_one_ground_cancelled_channel_through_the_multichannel_retrieval_is_the_stack_power_law(seed):
    """HV alone with the ground-cancelled exponent: the same analytic AGB error, random budget included, as the
    power-law chain of stack_power_law (the rvog exponent p / (1 + mu_hv))."""
    from e2esim.stack.multichannel_retrieval import StackMultiChannelRetrieval
    from e2esim.stack.retrieval import StackPowerLawRetrieval

    case = _stack_retrieval_case(seed, realisations=200)
    one = StackMultiChannelRetrieval(estimator="hv").forward(case)["agb.error"]
    chain = StackPowerLawRetrieval().forward(case)["agb.error"]
    assert one.exponent == pytest.approx(chain.exponent, rel=1e-14)
    assert one.error_mean == pytest.approx(chain.error_mean, rel=1e-13)
    assert one.error_sd == pytest.approx(chain.error_sd, rel=1e-13)
    assert [c.name for c in one.contributions] == [c.name for c in chain.contributions]


def test_the_stable_quadratic_term_is_the_trace_of_the_full_products(rng):
    """Stable errors (r_mn = 1): Re tr(M F_pq^a M F_qp^b) of eq. (22) with F_pq^a = U_p G_q^a, taken through the
    6 x 6 products Z = G M U (cyclic trace), equals the trace of the 3N x 3N products written out."""
    from e2esim.stack.channel_forms import _stable_trace_pairs

    g, side = 4, 9

    def cn(*shape):
        return rng.standard_normal(shape) + 1j * rng.standard_normal(shape)

    uh, gtu, m = cn(g, 3, side, 6), cn(2, g, 3, 6, side), cn(side, side)
    full = np.array([[[[[np.real(np.trace(m @ uh[k, p] @ gtu[a, k, q] @ m @ uh[k, q] @ gtu[b, k, p]))
                         for q in range(3)] for p in range(3)] for k in range(g)] for b in range(2)] for a in range(2)])
    got = _stable_trace_pairs(uh, gtu, m)
    np.testing.assert_allclose(got, full, rtol=0, atol=1e-12 * np.abs(full).max())


def test_stable_errors_are_the_limit_of_correlated_errors():
    """The kernel's stable-error path (r_mn = 1) and its general path (any r) meet: the joint moments at a pass
    correlation 1 - 1e-9 are those at 1 to the size of the difference."""
    scene = site_scene("boreal")
    comb = combos.interpolated(scene.acquisitions.kz_rad_m)
    out = []
    for rho in (1.0, 1.0 - 1e-9):
        errors, faraday = stack_errors(rich_system(1e-3, 2e-3), rho, 6.0)
        out.append(StackJointErrorModel(scene, errors, faraday, comb, looks=200, reference="population")
                   .current_joint())
    np.testing.assert_allclose(out[1].covariance, out[0].covariance, rtol=0,
                               atol=1e-7 * np.abs(out[0].covariance).max())
    np.testing.assert_allclose(out[1].mean, out[0].mean, rtol=0, atol=1e-7 * np.abs(out[0].mean).max())


@pytest.mark.parametrize("unit", [True, False])
def test_complex_normal_draws_are_those_of_the_complex_expression(seed, unit):
    """The Monte Carlo's CN draws, written part by part into one array, are (x + 1j y) / sqrt(2) (unit) or x + 1j y
    of the same generator's draws, bit for bit: the stream of every Monte Carlo stays."""
    from e2esim.distortion.covariance_montecarlo import _complex_normal

    shape = (3, 4, 1001)
    first, second = np.random.default_rng(seed), np.random.default_rng(seed)
    expected = first.standard_normal(shape) + 1j * first.standard_normal(shape)
    expected = expected / np.sqrt(2) if unit else expected
    got = _complex_normal(second, shape, unit)
    assert got.tobytes() == expected.tobytes()
    assert first.standard_normal() == second.standard_normal()  # the generators left in the same state


@pytest.mark.parametrize("rho", [0.4, 1.0])
def test_the_cancellation_reads_means_computed_without_the_kernels_covariance(rho):
    """The ground an estimator leaves (``cancellation()``) is read from the means of the ground-only scene: its
    kernels skip their (co)variance (``mean_only``), and the means, hence every ``cancellation.*`` scalar, are those of
    the full moments, bit for bit (stable errors take the kernel's other path of eq. 22)."""
    hv, joint = _models("scene", rho=rho)
    ground = hv.scene.ground_only()
    quiet = dataclasses.replace(hv.errors, system=hv.errors.system.with_levels(noise_power=0.0))
    full = stack_hv_moments(ground, quiet, hv.faraday, hv.combination, None, "scene")
    lean = stack_hv_moments(ground, quiet, hv.faraday, hv.combination, None, "scene", mean_only=True)
    assert float(lean.value + lean.bias_distortion) == float(full.value + full.bias_distortion)
    assert float(lean.var_distortion) == 0.0 < float(full.var_distortion)  # the kernel's variance was left out
    left = stack_joint_moments(ground, quiet, joint.faraday, joint.combination, None, "scene", joint.correct_copol)
    lean = stack_joint_moments(ground, quiet, joint.faraday, joint.combination, None, "scene", joint.correct_copol,
                               mean_only=True)
    assert np.array_equal(lean.values + lean.bias_distortion, left.values + left.bias_distortion)
    assert not np.any(lean.cov_distortion) and np.any(left.cov_distortion)
    assert joint.cancellation()["hv.ground_residual_fraction"] == float((left.values + left.bias_distortion)[1]
                                                                         / joint.values[1])
    assert hv.cancellation()["ground_residual_fraction"] == float(full.value + full.bias_distortion) / hv.value


def test_a_shared_memo_gives_each_copolarised_correction_its_own_node_terms():
    """The kernel memo's node-term tables are keyed by what the node terms read: with and without the co-polarised
    Faraday-rotation correction (no calibration residual, so the rotations are the same) they differ, and one memo
    serving both (a sweep over ``correct_copol_faraday`` in one process) gives each its own moments, bit for bit
    those of a model with no memo (the table's entries are keyed by the correction too)."""
    from e2esim.case import KernelMemo

    scene = site_scene("boreal", "interferometric")
    errors, faraday = stack_errors(rich_system(1e-3, 2e-3), 0.4, 6.0)
    comb = combos.interpolated(scene.acquisitions.kz_rad_m)
    memo = KernelMemo()
    for correct in (True, False):
        shared, alone = (StackJointErrorModel(scene, errors, faraday, comb, looks=200, reference="population",
                                              correct_copol=correct, kernel_memo=m) for m in (memo, None))
        a, b = shared.current_joint(), alone.current_joint()
        for f in dataclasses.fields(a):
            assert np.array_equal(getattr(a, f.name), getattr(b, f.name)), (correct, f.name)


def test_the_memo_keeps_the_signal_terms_only_for_moments_that_read_them():
    """The passes' signal covariances ``y0`` (the largest node terms) are kept in the kernel memo only where the moments
    read them (the passes' own gains, the population reference's finite looks): a tomographic run's full memo evicted
    node terms it then computed again. One memo serving both kinds gives each the moments of a model with no memo,
    bit for bit."""
    from e2esim.case import KernelMemo

    def kept_signal(memo):
        kernels = ("e2esim.stack.joint_moments", "e2esim.stack.channel_forms")  # by the kernel's module
        terms = [memo.get(k) for k in memo.keys() if k[0] in kernels]
        return [t["y0"] is not None for t in terms if isinstance(t, dict) and "y0" in t]

    memo = KernelMemo()
    for reference, expect in (("scene", False), ("population", True)):
        shared, alone = (_models(reference, rho=1.0, kernel_memo=m)[1] for m in (memo, None))
        a, b = shared.current_joint(), alone.current_joint()
        for f in dataclasses.fields(a):
            assert np.array_equal(getattr(a, f.name), getattr(b, f.name)), (reference, f.name)
        assert expect in kept_signal(memo) and (expect or not any(kept_signal(memo)))
