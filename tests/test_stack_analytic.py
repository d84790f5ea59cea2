"""Analytic moments of multi-pass HV estimates: the reduction to the single-pass analysis (the Done-when test), the
error model interface, and the cancellation residual (docs/theory/ground-cancellation.md, Sections 3-4)."""

import dataclasses

import numpy as np
import pytest

from e2esim.distortion.analytic import hv_error_moments
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.stack import combination as combos
from e2esim.stack.analytic import stack_hv_moments
from e2esim.stack.error_model import StackHVErrorModel
from e2esim.stack.temporal import TemporalDecorrelation
from stack_helpers import BOREAL_FR, rich_system, site_scene, stack_errors

REDUCTION_RTOL = 1e-12


@pytest.mark.parametrize("temporal", [TemporalDecorrelation.none(), TemporalDecorrelation()],
                         ids=["no decorrelation", "decorrelation"])
@pytest.mark.parametrize("reference", ["scene", "population"])
@pytest.mark.parametrize("make", [lambda kz: combos.subtraction(3, 0, 1), lambda kz: combos.subtraction(3, 2, 0),
                                  lambda kz: combos.single_date(3, 1)], ids=["pair 1-2", "pair 3-1", "date 2"])
def test_stable_errors_reduce_to_the_single_pass_analysis(make, reference, temporal):
    """Stable system errors, no Faraday-rotation difference: the distortion acts identically on every pass and the
    combined error is hv_error_moments of the combined (ground-cancelled) covariance, with the noise of the
    combined passes (sigma_n sum |w|^2), to rounding."""
    scene = site_scene("boreal", temporal=temporal)
    combination = make(scene.acquisitions.kz_rad_m)
    errors, faraday = stack_errors(correlation=1.0, difference_deg=0.0)
    stack = stack_hv_moments(scene, errors, faraday, combination, looks=150, reference=reference)
    combined = ScatteringCovariance(combination.combined_covariance(scene.blocks()))
    system = errors.system.with_levels(noise_power=errors.system.noise_power * combination.noise_gain)
    single = hv_error_moments(combined, system, BOREAL_FR, "complete", 150, reference)
    assert stack.value == pytest.approx(combined.sigma_hv, rel=REDUCTION_RTOL)
    assert float(stack.mean) == pytest.approx(float(single.mean), rel=REDUCTION_RTOL)
    assert float(stack.variance) == pytest.approx(float(single.variance), rel=REDUCTION_RTOL)
    # the spread is a difference of nearly equal numbers (E mu^2 - (E mu)^2): compare against the variance
    assert float(stack.var_faraday_spread) == pytest.approx(float(single.var_faraday_spread),
                                                            abs=REDUCTION_RTOL * float(single.variance))


def test_the_reduction_holds_at_any_levels_vectorised():
    scene = site_scene("tropical")
    pair = combos.subtraction(3, 0, 2)
    errors, faraday = stack_errors(correlation=1.0)
    x = np.array([1e-4, 1e-3, 5e-3])[:, None]
    e = np.array([1e-4, 3e-3])[None, :]
    stack = stack_hv_moments(scene, errors, faraday, pair, 100, "scene", x, e, 2e-3)
    combined = ScatteringCovariance(pair.combined_covariance(scene.blocks()))
    single = hv_error_moments(combined, errors.system, BOREAL_FR, "complete", 100, "scene", x, e, 4e-3)
    assert stack.mean.shape == (3, 2)
    np.testing.assert_allclose(stack.mean, single.mean, rtol=REDUCTION_RTOL)
    np.testing.assert_allclose(stack.variance, single.variance, rtol=REDUCTION_RTOL)


def _model(**changes):
    scene = site_scene("boreal")
    errors, faraday = stack_errors(correlation=0.4, difference_deg=6.0)
    base = dict(scene=scene, errors=errors, faraday=faraday,
                combination=combos.interpolated(scene.acquisitions.kz_rad_m), looks=200, reference="scene")
    return StackHVErrorModel(**{**base, **changes})


def test_contributions_add_up_to_the_moments():
    for reference in ("scene", "population"):
        model = _model(reference=reference)
        parts = model.contributions()
        assert set(parts) == {"system_distortions", "faraday_rotation", "faraday_difference", "system_instability",
                              "noise"} | ({"speckle"} if reference == "population" else set())
        m = model.current()
        assert sum(c.mean for c in parts.values()) == pytest.approx(float(m.mean), rel=1e-12)
        assert sum(c.variance for c in parts.values()) == pytest.approx(float(m.variance), rel=1e-12)
        assert parts["noise"].mean > 0 and parts["system_instability"].variance != 0


def test_sources_removed_and_levels():
    model = _model()
    assert set(model.levels) == {"crosstalk", "channel_imbalance", "nesz", "faraday_difference"}
    assert model.levels["faraday_difference"] == pytest.approx(np.radians(6.0) ** 2)
    stable = model.without("system_instability")
    assert stable.errors.correlation == 1.0 and stable.without("system_instability") is stable
    no_diff = model.without("faraday_difference")
    assert float(no_diff.current().mean) == pytest.approx(float(model.moments(faraday_difference=0.0).mean),
                                                          rel=1e-13)
    quiet = model.without("noise")
    assert float(quiet.current().bias_noise) == 0.0
    coherent = model.without("temporal_decorrelation")
    assert coherent.scene.temporal.is_none and coherent.value < model.value  # decorrelation adds power
    with pytest.raises(KeyError, match="unknown error source 'speckle'"):
        model.without("speckle")  # only the population reference has speckle
    assert _model(reference="population").without("speckle").reference == "scene"
    with pytest.raises(TypeError, match="unknown levels temperature"):
        model.moments(temperature=1.0)


def test_level_arrays_broadcast_like_single_values():
    model = _model()
    v = np.array([1e-4, 1e-3])
    d = np.array([0.0, np.radians(6.0) ** 2, np.radians(20.0) ** 2])
    vec = model.moments(crosstalk=v[:, None], faraday_difference=d[None, :])
    for i, vi in enumerate(v):
        for j, dj in enumerate(d):
            one = model.moments(crosstalk=vi, faraday_difference=dj)
            assert vec.mean[i, j] == pytest.approx(float(one.mean), rel=1e-12)
            assert vec.variance[i, j] == pytest.approx(float(one.variance), rel=1e-12)


def test_unstable_errors_leak_the_ground_into_the_cancelled_channel():
    """The cancellation residual: with stable errors and one Faraday rotation the ground of a pair cancels
    exactly (no ground decorrelation); errors that differ between passes leave ground power."""
    scene = site_scene("boreal", temporal=TemporalDecorrelation.none())
    pair = combos.subtraction(3, 0, 1)
    stable = _model(scene=scene, combination=pair, errors=stack_errors(correlation=1.0)[0],
                    faraday=stack_errors(difference_deg=0.0)[1])
    assert stable.cancellation()["ground_residual_fraction"] == pytest.approx(0.0, abs=1e-18)
    def residual(rho):
        errors = stack_errors(rich_system(1e-3, 1e-3), correlation=rho)[0]
        return dataclasses.replace(stable, errors=errors).cancellation()

    independent, half = residual(0.0), residual(0.5)
    assert independent["ground_residual_ideal_fraction"] == pytest.approx(0.0, abs=1e-18)
    assert independent["ground_residual_fraction"] > 1e-5
    # to first order the leak is E|(l_1 - l_2) s_g|^2 = 2 (1 - rho) E|l s_g|^2: half as much at rho = 0.5
    assert half["ground_residual_fraction"] / independent["ground_residual_fraction"] == pytest.approx(0.5, rel=0.02)


def test_averaging_independent_errors_over_passes_reduces_the_variance():
    scene = site_scene("tropical")
    avg = combos.multi_date(3)
    stable = _model(scene=scene, combination=avg, errors=stack_errors(correlation=1.0)[0])
    independent = _model(scene=scene, combination=avg, errors=stack_errors(correlation=0.0)[0])
    assert float(independent.current().var_distortion) < 0.6 * float(stable.current().var_distortion)


def test_the_shapley_subsets_share_their_parents_node_terms_with_the_same_numbers(monkeypatch):
    """``subsets_of`` makes a multi-pass model's subset models from their parents by their first source (the levels
    lead the sources: ``levels_lead_sources``); with the run's kernel memo, the subsets that read the same node
    terms (by value: ``NodeTermTable``) share them: far fewer kernel evaluations than without a memo, and the means
    and variances of every subset those of the models made in the other order and without a memo, bit for bit."""
    import e2esim.stack.analytic as analytic
    from e2esim.case import KernelMemo
    from e2esim.error_model import subsets_of

    kernel_calls = []
    kernel = analytic.node_polynomials
    monkeypatch.setattr(analytic, "node_polynomials", lambda *a: kernel_calls.append(1) or kernel(*a))
    errors, faraday = stack_errors(correlation=1.0, difference_deg=6.0)  # stable errors: a smaller game

    def subsets(memo):
        kernel_calls[:] = []
        out = subsets_of(_model(scene=site_scene("boreal", temporal=TemporalDecorrelation.none()), errors=errors,
                                faraday=faraday, kernel_memo=memo))
        return out, len(kernel_calls)

    (names, means, variances, _), shared = subsets(KernelMemo())
    alone, unshared = subsets(None)
    monkeypatch.setattr(StackHVErrorModel, "levels_lead_sources", False)
    other, _ = subsets(KernelMemo())
    for made in (alone, other):
        assert names == made[0] and len(names) >= 5
        assert np.array_equal(means, made[1]) and np.array_equal(variances, made[2])
    assert shared < unshared / 4


def test_variants_that_keep_the_structure_are_handed_the_node_term_table(monkeypatch):
    """A variant that removes a level, the Faraday-rotation difference or speckle reads node terms of the same
    structure: it is handed its parent's table (``StackModelBase._variant``) instead of keying it anew, and its moments
    are those of the same model built afresh, bit for bit; a variant of another structure (stable errors) keys its
    own."""
    import e2esim.stack.model_base as model_base
    from e2esim.case import KernelMemo

    model = _model(reference="population", kernel_memo=KernelMemo())
    model.current()
    keyed = []
    key = model_base.value_key
    monkeypatch.setattr(model_base, "value_key", lambda *a: keyed.append(1) or key(*a))
    for source in ("crosstalk", "channel_imbalance", "noise", "faraday_difference", "speckle"):
        variant = model.without(source)
        assert variant.node_terms is model.node_terms and variant.channel_values == model.channel_values
        afresh = dataclasses.replace(variant, kernel_memo=None).current()  # its own node terms, no memo
        assert np.array_equal(variant.current().mean, afresh.mean)
        assert np.array_equal(variant.current().variance, afresh.variance)
    assert not keyed
    stable = model.without("system_instability")
    assert stable.node_terms is not model.node_terms and keyed
