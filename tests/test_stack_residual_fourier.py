"""The joint stack kernel in the residual rotation of the co-polarised correction as trigonometric polynomials
(e2esim.stack.residual_fourier, docs/theory/ground-cancellation.md, Section 3.4): the same values as the kernel
evaluated node by node, to rounding."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

from e2esim.case import KernelMemo
from e2esim.distortion.channel_moments import unit_covariances
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.stack import combination as combos
from e2esim.stack.analytic import pass_nodes
from e2esim.stack.channel_forms import channel_node_polynomials
from e2esim.stack.faraday import StackFaraday
from e2esim.stack.joint_model import StackJointErrorModel
from e2esim.stack.residual_fourier import DEGREE, PLANS, evaluate_at, frequencies, residual_coefficients
from e2esim.stack.system import StackSystemErrors
from stack_helpers import BOREAL_FR, rich_system, site_scene


@pytest.mark.parametrize("passes", sorted(PLANS))
def test_the_sampling_line_separates_every_frequency(passes):
    """k . m is distinct modulo Ns for every k with |k|_1 <= 4 (eq. 28's degree): the transform aliases nothing."""
    ns, m = PLANS[passes]
    ball = [k for k in itertools.product(range(-4, 5), repeat=passes) if sum(map(abs, k)) <= 4]
    assert len({int(np.dot(k, m)) % ns for k in ball}) == len(ball) == {1: 9, 2: 41, 3: 129}[passes]
    half = frequencies(passes, 4)
    assert len(half) == (len(ball) + 1) // 2 and not np.any(half[0])


def _kernel_inputs(rng, correlation, passes_nodes=3):
    scene = site_scene("boreal")
    errors = StackSystemErrors(rich_system(1e-3, 2e-3), correlation)
    faraday = StackFaraday(BOREAL_FR, np.radians(4.0))
    nodes = pass_nodes(scene, errors, faraday, np.radians(4.0))
    pick = rng.choice(len(nodes["weights"]), passes_nodes, replace=False)
    combination = combos.interpolated(scene.acquisitions.kz_rad_m)
    return (scene.blocks(), combination.matrix, nodes["omega"][pick], errors.pass_correlation(scene.passes),
            unit_covariances(errors.system), nodes["pair"])


@pytest.mark.parametrize("correlation, cross", [(1.0, False), (0.5, True)])
def test_the_polynomials_give_the_kernel_at_any_residual(rng, correlation, cross):
    """At residuals drawn anywhere in (-1, 1) rad per pass (not only a cubature's nodes), every output of the kernel
    (signal covariances, means, covariances of the channels' forms, tr(Q^2 Y), the speckle cross term) from the
    coefficients equals the kernel node by node, to 1e-13 of each output's largest entry; stable (r = 1, the 6 x 6
    trace path) and correlated errors."""
    blocks, q, omega, r, gammas, pair = _kernel_inputs(rng, correlation)
    residual = rng.uniform(-1.0, 1.0, (5, omega.shape[1]))
    got = evaluate_at(residual_coefficients(blocks, q, omega, r, gammas, pair, cross, True), residual)
    om = np.repeat(omega, len(residual), axis=0)
    want = channel_node_polynomials(blocks, q, om, om - np.tile(residual, (len(omega), 1)), r, gammas, pair, cross)
    assert set(DEGREE) <= set(want)
    for name in DEGREE:
        scale = np.abs(want[name]).max()
        assert scale > 0 or name == "csys"
        np.testing.assert_allclose(got[name], want[name], rtol=0, atol=1e-13 * max(scale, 1e-300), err_msg=name)


def test_without_signal_and_cross_term_the_large_outputs_are_left_out(rng):
    blocks, q, omega, r, gammas, pair = _kernel_inputs(rng, 1.0, 2)
    coefficients = residual_coefficients(blocks, q, omega, r, gammas, pair, False, False)
    assert "y0" not in coefficients and "csys" not in coefficients
    got = evaluate_at(coefficients, np.zeros((3, omega.shape[1])))
    assert got["y0"] is None and got["csys"].shape == (6, 6, 3) and not np.any(got["csys"])


def test_moments_over_a_kept_memo_are_those_node_by_node():
    """The joint moments of a stack corrected with a residual rotation (mean 3 deg, SD 6 deg) through a memo kept over
    many rows (``KernelMemo.repeated_geometry``, as a solve's engine runs) equal those evaluated node by node to
    1e-12 of each part (a covariance also to the rounding of its spread over the nodes, 32 eps sigma^2, as
    test_stack_joint); a second residual on the same memo reuses the coefficients (the memo grows by nothing but
    the table of the new model's node terms, ``StackModelBase.node_terms``).
    No Faraday-rotation difference: the rotation's own nodes alone, so that the coefficients are quick."""
    scene = site_scene("boreal")
    errors = StackSystemErrors(rich_system(1e-3, 2e-3), 0.5)
    kw = dict(looks=300, reference="scene")
    combination = combos.interpolated(scene.acquisitions.kz_rad_m)
    memo = KernelMemo(repeated_geometry=True)
    for mean_deg, sd_deg in ((3.0, 6.0), (-1.0, 2.0)):
        faraday = StackFaraday(BOREAL_FR, 0.0, GaussianFaraday(np.radians(mean_deg), np.radians(sd_deg)))
        plain = StackJointErrorModel(scene, errors, faraday, combination, **kw).current_joint()
        model = StackJointErrorModel(scene, errors, faraday, combination, kernel_memo=memo, **kw)
        kept = model.current_joint()
        power = np.abs(plain.values).max() ** 2  # a covariance also to the rounding of E[mu^2] - (E mu)^2
        for field in dataclasses.fields(plain):
            a, b = getattr(plain, field.name), getattr(kept, field.name)
            atol = 1e-12 * np.abs(a).max() + (32 * np.finfo(float).eps * power if a.ndim == 2 else 0.0)
            np.testing.assert_allclose(b, a, rtol=0, atol=atol, err_msg=field.name)
        if mean_deg == 3.0:
            size = len(memo)
    assert len(memo) == size + 1 and sum(k[0] == "stack node terms" for k in memo.keys()) == 2


def test_coefficients_kept_between_runs_are_those_computed(rng, tmp_path, monkeypatch):
    """A memo with a store (the array cache a solve hands it, ``KernelMemo.store``) keeps the coefficients between
    runs: a fresh memo over the same store finds them there instead of computing them, and the moments are bit for
    bit those of the first run; another code (the source of the kernel's modules is part of the key) misses."""
    from e2esim.io.array_cache import ArrayCache
    from e2esim.stack import residual_fourier

    scene = site_scene("boreal")
    errors = StackSystemErrors(rich_system(1e-3, 2e-3), 0.5)
    faraday = StackFaraday(BOREAL_FR, 0.0, GaussianFaraday(np.radians(2.0), np.radians(5.0)))
    combination = combos.interpolated(scene.acquisitions.kz_rad_m)
    store = ArrayCache(tmp_path)
    built = []
    real = residual_fourier.residual_coefficients
    monkeypatch.setattr("e2esim.stack.joint_moments.residual_coefficients",
                        lambda *a: built.append(1) or real(*a))

    def moments():
        memo = KernelMemo(repeated_geometry=True, store=store)
        return StackJointErrorModel(scene, errors, faraday, combination, looks=300, kernel_memo=memo).current_joint()
    first, again = moments(), moments()
    assert len(built) == 1 and len(list(tmp_path.glob(f"*{residual_fourier.STORE_KIND}*"))) == 1
    for field in dataclasses.fields(first):
        assert np.array_equal(getattr(first, field.name), getattr(again, field.name)), field.name
    monkeypatch.setattr(residual_fourier, "_code_digest", lambda: "another code")
    moments()
    assert len(built) == 2


def test_the_outputs_read_as_sums_are_the_weighted_sums_of_the_node_values(rng):
    """With the nodes' weights, ``evaluate_at`` gives the outputs the moments read only as weighted sums over the
    nodes (``SUMMED``) as those sums, summed in another order: to 1e-13 of their largest term; the others as before."""
    from e2esim.stack.residual_fourier import SUMMED

    blocks, q, omega, r, gammas, pair = _kernel_inputs(rng, 0.5)
    coefficients = residual_coefficients(blocks, q, omega, r, gammas, pair, True, True)
    residual = rng.uniform(-0.5, 0.5, (4, omega.shape[1]))
    w_g, w_j = rng.uniform(0.1, 1.0, omega.shape[0]), rng.uniform(0.1, 1.0, len(residual))
    nodes, sums = evaluate_at(coefficients, residual), evaluate_at(coefficients, residual, (w_g, w_j))
    w = np.outer(w_g, w_j).ravel()
    for name in SUMMED:
        want = np.einsum("kg...,g->k...", nodes[name], w)
        scale = np.einsum("kg...,g->k...", np.abs(nodes[name]), w).max()
        np.testing.assert_allclose(sums[name], want, rtol=0, atol=1e-13 * scale, err_msg=name)
    for name in ("y0", "mean"):
        assert np.array_equal(sums[name], nodes[name])
