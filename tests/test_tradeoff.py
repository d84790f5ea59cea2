"""Trade-off curves (Men et al. 2021, eq. 19 and Appendix B): root finding against the closed-form conic."""

import numpy as np
import pytest

from e2esim.distortion.analytic import hv_error_moments
from e2esim.distortion.error_model import HVErrorModel
from e2esim.errors import PhysicsInputError
from e2esim.faraday.distribution import ConstantFaraday, GaussianFaraday
from e2esim.requirements.tradeoff import AGBRequirement, ConicTradeoff, axis_limits, first_failing_level, tradeoff_curve
from e2esim.retrieval.power_law import BIOME_EXPONENTS, sigma_relative_error
from e2esim.units import variance_from_level_db
from helpers import forest, system

FORESTS = ["boreal_50", "boreal_200", "boreal_350", "tropical_338", "tropical_341"]


def _setup(name):
    scene = forest(name)
    return scene, ConstantFaraday(np.pi / 3 if scene.biome == "boreal" else 0.0), BIOME_EXPONENTS[scene.biome]


@pytest.mark.parametrize("name", FORESTS)
@pytest.mark.parametrize("side", ["over", "under"])
@pytest.mark.parametrize("confidence", [0.95, 0.99865])
def test_conic_and_root_finding_agree(name, side, confidence):
    scene, fr, p = _setup(name)
    req = AGBRequirement(0.2, confidence, side, p)
    x = variance_from_level_db(np.linspace(-50, -12, 60), "three_sigma_amplitude")
    by_roots = tradeoff_curve(req, HVErrorModel(scene, system(), fr, form="paper"), x)
    conic = ConicTradeoff.from_moments(req, scene, system(), fr)
    closed = conic.imbalance_for_crosstalk(x)
    finite = np.isfinite(by_roots)
    assert finite.sum() > 10
    np.testing.assert_array_equal(finite, np.isfinite(closed))
    np.testing.assert_allclose(by_roots[finite], closed[finite], rtol=1e-8)
    # points of the curve satisfy the standard form (B7) with the corrected B1, B2 (errata E8)
    np.testing.assert_allclose(conic.standard_form_residual(closed[finite], x[finite]), 0.0, atol=1e-8)
    # and on the curve the requirement holds with equality (eq. 19)
    m = hv_error_moments(scene, system(), fr, "paper", crosstalk_level=x[finite], imbalance_level=closed[finite])
    np.testing.assert_allclose(req.violation(m.mean, m.sd, scene.sigma_hv) / scene.sigma_hv, 0.0, atol=1e-9)


def test_the_conic_is_an_ellipse_at_high_confidence_and_can_be_a_hyperbola():
    # docs/errata.md E8: Appendix B says "hyperbola"; the type depends on the case.
    kinds = {}
    for name in FORESTS:
        scene, fr, p = _setup(name)
        for conf in (0.95, 0.99, 0.99865):
            conic = ConicTradeoff.from_moments(AGBRequirement(0.2, conf, "over", p), scene, system(), fr)
            kinds[(name, conf)] = conic.standard_form["kind"]
    assert all(kinds[(n, c)] == "ellipse" for n in FORESTS for c in (0.99, 0.99865))
    assert kinds[("tropical_338", 0.95)] == "hyperbola"


def test_overestimation_curve_decreases_with_crosstalk():
    scene, fr, p = _setup("boreal_200")
    x = variance_from_level_db(np.linspace(-45, -21, 40), "three_sigma_amplitude")
    req = AGBRequirement(0.2, 0.99865, "over", p)
    y = tradeoff_curve(req, HVErrorModel(scene, system(), fr, form="complete"), x)
    finite = np.isfinite(y)
    assert finite.sum() >= 30  # the curve exists over most of the range (no vacuous pass on NaN)
    assert np.all(np.diff(y[finite]) < 0)
    # every point is on the curve: eq. (19) holds with equality there, computed from the moments directly
    m = hv_error_moments(scene, system(), fr, "complete", crosstalk_level=x[finite], imbalance_level=y[finite])
    f_sigma = sigma_relative_error(0.2, p) * scene.sigma_hv
    np.testing.assert_allclose(m.mean + req.z * m.sd, f_sigma, rtol=1e-6)


def test_tighter_requirements_need_smaller_errors():
    # Section V-B point 2: tighter confidence, smaller permissible errors; point 3: channel imbalance must be
    # much smaller than crosstalk.
    scene, fr, p = _setup("boreal_200")
    limits = [axis_limits(AGBRequirement(b, c, "over", p), HVErrorModel(scene, system(), fr, form="paper"))
              for b, c in [(0.2, 0.95), (0.2, 0.99865), (0.1, 0.99865)]]
    assert limits[0]["imbalance_limit"] > limits[1]["imbalance_limit"] > limits[2]["imbalance_limit"]
    assert limits[0]["crosstalk_limit"] > limits[1]["crosstalk_limit"] > limits[2]["crosstalk_limit"]
    assert all(lim["crosstalk_limit"] > 3 * lim["imbalance_limit"] for lim in limits)  # 6 to 13 dB apart


def test_underestimation_is_less_demanding_than_overestimation():
    # Section III-D and V-B: constraining overestimation also bounds underestimation.
    for name in FORESTS:
        scene, fr, p = _setup(name)
        over = axis_limits(AGBRequirement(0.2, 0.99865, "over", p), HVErrorModel(scene, system(), fr, form="paper"))
        under = axis_limits(AGBRequirement(0.2, 0.99865, "under", p), HVErrorModel(scene, system(), fr, form="paper"))
        assert under["imbalance_limit"] > over["imbalance_limit"]


def test_first_failing_level_edge_cases():
    assert first_failing_level(lambda v: v - 1e-4) == pytest.approx(1e-4, rel=1e-9)
    assert np.isnan(first_failing_level(lambda v: np.ones_like(v)))  # fails at any level
    assert first_failing_level(lambda v: -np.ones_like(v)) == np.inf  # never fails


def test_conic_refuses_gain_errors_and_requirement_validates():
    scene, fr, p = _setup("boreal_200")
    with pytest.raises(PhysicsInputError, match="no gain error"):
        ConicTradeoff.from_moments(AGBRequirement(0.2, 0.99, "over", p), scene, system(gain_sd_db=0.1), fr)
    with pytest.raises(PhysicsInputError, match="side must be one of"):
        AGBRequirement(0.2, 0.99, "sideways", p)
    with pytest.raises(PhysicsInputError, match="confidence must be between"):
        AGBRequirement(0.2, 1.2, "over", p)


def test_random_faraday_rotation_tightens_the_crosstalk_limit():
    scene, _, p = _setup("boreal_350")
    req = AGBRequirement(0.2, 0.99865, "over", p)
    fixed = axis_limits(req, HVErrorModel(scene, system(), ConstantFaraday(np.pi / 3)))["crosstalk_limit"]
    spread = axis_limits(req, HVErrorModel(scene, system(), GaussianFaraday(np.pi / 3, np.radians(20))))[
        "crosstalk_limit"
    ]
    assert spread < fixed


def _counting(fn):
    """``fn`` with the number of distinct levels it was asked at (what a costly level pays for)."""
    seen = set()

    def violation(v):
        seen.update(np.unique(np.asarray(v)).tolist())
        return fn(np.asarray(v))

    return violation, seen


def test_a_bisected_scan_finds_the_full_scans_limit_bit_for_bit_at_a_fifth_of_the_levels():
    # each element its own root (in range, below the grid, above it), a block of cases and one case
    roots = np.array([[3e-7, 1e-13, 2.0], [5e-3, 0.7, 1e-11]])
    for shape, fn in [((2, 3), lambda v: np.log(v) - np.log(roots)[..., None]),
                      ((), lambda v: np.tanh(1e3 * (v - 2.5e-5)))]:
        full, full_seen = _counting(fn)
        bisected, bisected_seen = _counting(fn)
        expected = first_failing_level(full, shape)
        got = first_failing_level(bisected, shape, bisect=True)
        np.testing.assert_array_equal(got, expected)  # NaN, +inf and the refined roots alike
        if shape == ():  # the same refinement; the grid's 25 levels become its two ends and five midpoints
            assert len(bisected_seen) <= len(full_seen) - 25 + 7, (len(bisected_seen), len(full_seen))


def test_the_stack_models_margin_over_the_faraday_difference_bisects_its_scan():
    # the level whose every value needs new Faraday-rotation nodes; the others are scanned in one evaluation
    from e2esim.stack.error_model import StackHVErrorModel
    from e2esim.stack.joint_model import StackJointErrorModel

    assert StackHVErrorModel.costly_levels == ("faraday_difference",) == StackJointErrorModel.costly_levels
    assert HVErrorModel.costly_levels == ()
