"""Causes of slow scenarios removed without moving a number (issue 28, Build 2): the multi-pass error models'
evaluation cache stays out of the resume journal, the joint kernel's cache keeps only the terms its moments read,
and the Monte Carlo's quadratic form Re(a C a^H) equals the three-operand einsum it replaces to rounding."""

import dataclasses

import numpy as np
import pytest

from e2esim.distortion.montecarlo import hermitian_form
from e2esim.runner import plaindata
from e2esim.stack import combination as combos
from e2esim.stack.joint_model import StackJointErrorModel
from e2esim.stack.joint_moments import stack_joint_moments
from stack_helpers import rich_system, site_scene, stack_errors

PACKAGES = frozenset({"e2esim"})


def _joint(reference="scene", correlation=1.0):
    scene = site_scene("boreal", "interferometric")
    errors, faraday = stack_errors(rich_system(1e-3, 2e-3), correlation, 6.0)
    return StackJointErrorModel(scene=scene, errors=errors, faraday=faraday, looks=200, reference=reference,
                                combination=combos.interpolated(scene.acquisitions.kz_rad_m))


def test_the_journal_leaves_the_evaluation_cache_out_and_the_decoded_model_gives_the_same_numbers():
    model = _joint()
    before = model.joint_moments(faraday_difference=np.array([1e-4, 1e-3, 1e-2]))  # three levels searched
    assert len(model.node_terms) == 3
    header, payload = plaindata.encode(model, PACKAGES)
    # before the fix the node terms of every level searched were stored: megabytes per case
    assert len(payload) < 200_000, len(payload)
    back = plaindata.decode(header, payload, PACKAGES)
    assert "node_terms" not in vars(back)
    again = back.joint_moments(faraday_difference=np.array([1e-4, 1e-3, 1e-2]))
    np.testing.assert_array_equal(again.mean, before.mean)
    np.testing.assert_array_equal(again.covariance, before.covariance)


def test_the_joint_cache_keeps_the_signal_covariances_only_where_the_moments_read_them():
    scene_ref = _joint("scene")
    args = (scene_ref.scene, scene_ref.errors, scene_ref.faraday, scene_ref.combination, 200)
    cache: dict = {}
    scene_first = stack_joint_moments(*args, "scene", cache=cache, totals_only=True)
    assert all(t["y0"] is None for t in cache.values())  # stable errors, one scene: y0 is not read
    # a population variant sharing the cache needs y0: it is computed again, and the numbers are those of a fresh
    # evaluation
    shared = stack_joint_moments(*args, "population", cache=cache, totals_only=True)
    fresh = stack_joint_moments(*args, "population", totals_only=True)
    for a, b in zip(shared, fresh):
        np.testing.assert_array_equal(a, b)
    assert any(t["y0"] is not None for t in cache.values())
    for a, b in zip(stack_joint_moments(*args, "scene", cache=cache, totals_only=True), scene_first):
        np.testing.assert_array_equal(a, b)


def test_unstable_errors_keep_the_signal_covariances_for_the_passes_gains():
    model = _joint("scene", correlation=0.5)  # the passes' own gains: Cov over them reads y0
    assert model.errors.pass_gain_log_sd > 0
    model.joint_moments()
    assert all(t["y0"] is not None for t in model.node_terms.values())


@pytest.mark.parametrize("batched", [False, True])
def test_hermitian_form_is_the_einsum(rng, batched):
    m = 1000
    a = rng.standard_normal((m, 3)) + 1j * rng.standard_normal((m, 3))
    x = rng.standard_normal((m, 3, 3)) + 1j * rng.standard_normal((m, 3, 3))
    c = x @ np.swapaxes(x.conj(), -1, -2)
    c = c if batched else c[0]
    form = "mi,mij,mj->m" if batched else "mi,ij,mj->m"
    expected = np.real(np.einsum(form, a, c, a.conj()))
    parts = np.stack([a.T.real, a.T.imag], axis=1)  # (3, 2, M): the rows' real and imaginary planes
    np.testing.assert_allclose(hermitian_form(parts, c), expected, rtol=1e-13)


def test_a_model_variant_copies_no_cache_into_the_journal():
    model = _joint()
    model.contributions()  # fills the cache with variants and their node terms
    variant = dataclasses.replace(model, looks=100)
    _, payload = plaindata.encode(variant, PACKAGES)
    assert len(payload) < 200_000
