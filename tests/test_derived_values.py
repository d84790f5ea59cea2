"""Values derived once (issue 27, Build 7; docs/architecture.md, "Caching"): the error models' evaluations, their
variants without a source and the Faraday-rotation quadratures are ``functools.cached_property``s, the expansions at
quadrature nodes and the multi-pass node terms live in the kernel memo. A kept value equals a fresh computation bit
for bit, a copy made by ``dataclasses.replace`` never serves its original's value, and a kept value is never data
(the plain-data encoding leaves it out)."""

import dataclasses

import numpy as np
import pytest

from e2esim.case import KernelMemo
from e2esim.derived import derived_values, knowing
from e2esim.distortion.error_model import SOURCES, HVErrorModel
from e2esim.distortion.expansion import expansion, expansion_at
from e2esim.distortion.faraday_correction import FaradayCorrection
from e2esim.distortion.polarimetric_model import PolarimetricErrorModel
from e2esim.faraday.distribution import FINE_QUADRATURE_DEGREE, ConstantFaraday, GaussianFaraday, quadrature_nodes
from e2esim.runner import plaindata
from e2esim.stack import combination as combos
from e2esim.stack.faraday import StackFaraday
from e2esim.stack.joint_model import StackJointErrorModel
from helpers import forest, system
from stack_helpers import rich_system, site_scene, stack_errors

FR = GaussianFaraday(np.radians(4.0), np.radians(6.0))


def _hv(faraday=FR, **kw):
    return HVErrorModel(forest(), system(), faraday, "complete", looks=1000, reference="population", **kw)


def _same(a, b):
    for f in dataclasses.fields(a):
        np.testing.assert_array_equal(np.asarray(getattr(a, f.name)), np.asarray(getattr(b, f.name)), err_msg=f.name)


def test_the_kept_evaluations_and_variants_equal_fresh_ones_bit_for_bit():
    model = _hv()
    assert model.current() is model.current() is model.evaluated
    _same(model.current(), _hv().moments())
    for source in SOURCES:  # each variant made once, its moments those of the variant made alone
        variant = model.without(source)
        assert variant is model.without(source)
        _same(variant.current(), dataclasses.replace(variant).moments())
    with pytest.raises(KeyError, match="unknown error source 'ionosphere'"):
        model.without("ionosphere")


def test_a_copy_made_by_replace_derives_its_own_values():
    model = _hv()
    model.current(), model.without("crosstalk"), model.contributions()
    assert {"evaluated", "removals", "no_faraday"} <= set(derived_values(model))
    other = dataclasses.replace(model, system=system(crosstalk_db=-20.0), faraday=ConstantFaraday(0.5))
    assert derived_values(other) == {}
    _same(other.current(), HVErrorModel(forest(), system(crosstalk_db=-20.0), ConstantFaraday(0.5), "complete",
                                        looks=1000, reference="population").moments())
    assert float(other.current().mean) != float(model.current().mean)
    # a model made with its Monte Carlo samples knows what the model without them derived (none of it reads them)
    simulated = model.with_montecarlo(None, {"skewness": 0.1})
    assert simulated.current() is model.current() and simulated.gaussianity == {"skewness": 0.1}


def test_knowing_sets_only_values_derived_once():
    model = _hv()
    with pytest.raises(AttributeError, match="HVErrorModel derives no scene once"):
        knowing(model, scene=None)
    row = _hv().current()
    assert knowing(model, evaluated=row).current() is row


def test_a_polarimetric_variant_of_a_level_shares_the_polynomial_and_its_numbers_are_fresh():
    memo = KernelMemo()
    model = PolarimetricErrorModel(forest(), system(), FR, FaradayCorrection(), looks=1000, kernel_memo=memo)
    variant = model.without("crosstalk")
    assert variant.polynomial() is model.polynomial()  # the polynomial does not depend on the levels
    alone = PolarimetricErrorModel(forest(), system().with_levels(crosstalk=0.0), FR, FaradayCorrection(), looks=1000)
    _same(variant.current_joint(), alone.current_joint())


def test_a_distribution_keeps_its_quadratures_and_a_copy_has_its_own():
    fr = GaussianFaraday(0.1, 0.3)
    weights = fr.quadrature()[1]
    assert fr.quadrature() is fr.quadrature_rule and not weights.flags.writeable
    assert fr.quadrature(FINE_QUADRATURE_DEGREE) is fr.fine_quadrature_rule
    np.testing.assert_array_equal(fr.quadrature(5)[1], GaussianFaraday(0.1, 0.3).quadrature(5)[1])  # not kept
    wider = dataclasses.replace(fr, sd=0.6)
    np.testing.assert_array_equal(wider.quadrature()[1], GaussianFaraday(0.1, 0.6).quadrature()[1])
    assert not np.array_equal(wider.quadrature()[1], weights)
    np.testing.assert_array_equal(wider.even_quadrature()[1], GaussianFaraday(0.1, 0.6).even_quadrature()[1])


def test_an_expansion_is_kept_by_the_values_of_its_nodes():
    memo = KernelMemo()
    omega = quadrature_nodes(8)
    kept = expansion_at(omega, None, memo)
    assert expansion_at(omega.copy(), None, memo) is kept  # another array of the same values
    assert expansion_at(omega + 0.1, None, memo) is not kept and len(memo) == 2
    fresh = expansion(omega, None)
    for name in ("a0", "u", "w"):
        np.testing.assert_array_equal(getattr(kept, name), getattr(fresh, name))
        assert not getattr(kept, name).flags.writeable


def test_a_stack_copy_with_another_common_rotation_reads_its_own_nodes():
    # before: StackFaraday kept its nodes in a dict that dataclasses.replace handed to the copy, so a model without
    # its common Faraday rotation (``without("faraday_rotation")``) averaged over the rotation it had removed
    errors, faraday = stack_errors(rich_system(1e-3, 2e-3), 0.5, 6.0)
    faraday.nodes(3, 0.0)
    copy = dataclasses.replace(faraday, common=ConstantFaraday(0.0))
    np.testing.assert_array_equal(copy.nodes(3, 0.0)[1], StackFaraday(ConstantFaraday(0.0)).nodes(3, 0.0)[1])
    scene = site_scene("boreal", "interferometric")
    for memo in (None, KernelMemo()):
        model = StackJointErrorModel(scene=scene, errors=errors, faraday=faraday, looks=200, reference="scene",
                                     combination=combos.interpolated(scene.acquisitions.kz_rad_m), kernel_memo=memo)
        model.current_joint()
        variant = model.without("faraday_rotation")
        alone = dataclasses.replace(variant, faraday=StackFaraday(ConstantFaraday(0.0), faraday.difference_sd),
                                    kernel_memo=None)
        _same(variant.current_joint(), alone.current_joint())


def test_the_plain_data_encoding_leaves_derived_values_out():
    model = _hv()
    model.current(), model.contributions()
    header, payload = plaindata.encode(model, frozenset({"e2esim"}))
    back = plaindata.decode(header, payload, frozenset({"e2esim"}))
    assert derived_values(back) == {} and b"evaluated" not in header and b"removals" not in header
    _same(back.current(), model.current())
