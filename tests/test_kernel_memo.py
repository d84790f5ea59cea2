"""The process's kernel memo (``e2esim.case.KernelMemo``, issues 27 and 28): the node terms of the multi-pass
moments found again by value across cases give the numbers of a computation without it, bit for bit; it is bounded,
keyed by content (never by an object's id) and starts empty in another process."""

import dataclasses
import pickle

import numpy as np

from e2esim.case import KernelMemo
from e2esim.stack import analytic
from e2esim.stack import combination as combos
from e2esim.stack.error_model import StackHVErrorModel
from e2esim.stack.joint_model import StackJointErrorModel
from stack_helpers import rich_system, site_scene, stack_errors

SEARCHED = np.array([1e-6, 1e-3, 1e-2, 0.3])  # Faraday-rotation difference variances, as a margin search asks


def _models(kind, memo, difference_deg=6.0, correlation=0.5):
    scene = site_scene("boreal", "interferometric")
    errors, faraday = stack_errors(rich_system(1e-3, 2e-3), correlation, difference_deg)
    return kind(scene=scene, errors=errors, faraday=faraday, looks=200, reference="population",
                combination=combos.interpolated(scene.acquisitions.kz_rad_m), kernel_memo=memo)


def _hv(model):
    m = model.moments(crosstalk=np.array([[1e-4], [1e-3]]), faraday_difference=SEARCHED)
    return [np.asarray(getattr(m, f.name)) for f in dataclasses.fields(m)]


def _joint(model):
    m = model.joint_moments(crosstalk=np.array([[1e-4], [1e-3]]), faraday_difference=SEARCHED)
    return [m.mean, m.covariance]


def test_node_terms_shared_between_cases_equal_those_computed_alone_bit_for_bit():
    for kind, values in ((StackHVErrorModel, _hv), (StackJointErrorModel, _joint)):
        memo = KernelMemo()
        first = values(_models(kind, memo))
        filled = len(memo)
        tables = [k for k in memo.keys() if k[0] == "stack node terms"]
        assert len(tables) == 1 and len(memo.get(tables[0])) == len(SEARCHED)  # one table: an entry per difference
        # a second case of the same geometry (another Faraday-rotation difference of its own) finds them all
        second = values(_models(kind, memo, difference_deg=30.0))
        assert len(memo) == filled
        alone = values(_models(kind, None, difference_deg=30.0))
        for a, b in zip(second, alone):
            np.testing.assert_array_equal(a, b)
        for a, b in zip(first, values(_models(kind, None))):
            np.testing.assert_array_equal(a, b)
        # another geometry (stable errors: other pass correlations) is a new key, never a stale hit
        values(_models(kind, memo, correlation=1.0))
        assert len([k for k in memo.keys() if k[0] == "stack node terms"]) == 2 and len(memo) > filled


def test_the_key_is_the_content_of_the_inputs():
    calls = []

    def kernel(a, flag):
        calls.append(1)
        return {"x": a * 2.0}

    memo = KernelMemo()
    one = analytic.memoised(memo, kernel, np.arange(3.0), True)
    two = analytic.memoised(memo, kernel, np.arange(3.0), True)  # another array of the same content
    assert len(calls) == 1 and two is not one and two["x"] is one["x"]
    analytic.memoised(memo, kernel, np.arange(3.0), False)
    analytic.memoised(memo, kernel, np.arange(3), True)  # same numbers, another dtype
    analytic.memoised(memo, kernel, np.arange(3.0).reshape(1, 3), True)  # another shape
    assert len(calls) == 4


def test_the_memo_is_bounded_and_starts_empty_in_another_process():
    memo = KernelMemo(max_bytes=3 * 800)
    for k in range(5):
        memo[k] = {"a": np.zeros(100)}  # 800 bytes each
        assert memo.get(0) is not None  # the most recently used stays
    assert len(memo) == 3 and memo.get(1) is None and memo.get(4) is not None
    memo["big"] = {"a": np.zeros(1000)}  # larger than the bound: not kept
    assert memo.get("big") is None
    back = pickle.loads(pickle.dumps(memo))
    assert len(back) == 0 and back.max_bytes == memo.max_bytes


def test_the_joint_totals_read_the_diagonal_alone_and_equal_the_full_moments_bit_for_bit():
    from e2esim.stack.joint_moments import stack_joint_moments

    model = _models(StackJointErrorModel, None)
    args = (model.scene, model.errors, model.faraday, model.combination, model.looks, model.reference, True,
            np.array([[1e-5], [1e-3]]), np.array([1e-4, 1e-2, 1e-1]))
    full = stack_joint_moments(*args, difference_variance=np.array([[[1e-3]], [[0.2]]]))
    mean, cov = stack_joint_moments(*args, difference_variance=np.array([[[1e-3]], [[0.2]]]), totals_only=True)
    np.testing.assert_array_equal(mean, full.mean)
    np.testing.assert_array_equal(cov, full.covariance)


def test_recall_keeps_a_bounded_number_of_each_kind_and_the_process_memo_is_one():
    """The one in-memory cache (docs/architecture.md, "Caching"): ``recall`` makes a value once per key, keeps at
    most ``keep`` of a kind (the least recently used leave first) without touching the other kinds, and the
    process's memo is what the runner and a case made outside a run are handed."""
    import e2esim.case as case_module
    from e2esim.runner.cases import default_services

    memo, made = KernelMemo(max_entries=10), []
    for k in (1, 2, 1, 3):
        memo.recall(("poly", k), lambda k=k: made.append(k) or [k], keep=2)
    memo.recall(("table", 0), lambda: made.append("t") or ["t"], keep=1)
    assert made == [1, 2, 3, "t"]  # the second 1 was found
    assert memo.get(("poly", 2)) is None and memo.get(("poly", 1)) == [1] and memo.get(("table", 0)) == ["t"]
    for k in range(20):
        memo[("other", k)] = k
    assert len(memo) == 10  # bounded in entries too
    assert case_module.Services().memo is case_module.process_memo() is default_services().memo
    assert pickle.loads(pickle.dumps(case_module.process_memo())) is case_module.process_memo()


def test_the_arrays_inside_a_tuple_count_towards_the_bound():
    # node polynomials are kept as a tuple of arrays: their bytes bound the memo as a dict's or an array's do
    memo = KernelMemo(max_bytes=1000)
    memo[("nodes", 1)] = (np.zeros(100), (np.zeros(10), [np.zeros(5)]))  # 920 bytes: kept
    assert memo.get(("nodes", 1)) is not None
    memo[("nodes", 2)] = (np.zeros(100), np.zeros(100))  # 1,600 bytes: over the bound, never kept
    assert memo.get(("nodes", 2)) is None
    memo[("nodes", 3)] = (np.zeros(20),)  # 920 + 160 > 1,000: the least recently used array-holder leaves
    assert memo.get(("nodes", 1)) is None and memo.get(("nodes", 3)) is not None


def test_a_memo_sent_to_a_worker_arrives_empty_with_its_settings(tmp_path):
    # a solve's engine runs take the residual-rotation path (repeated_geometry) in every process, so a solve on
    # --workers gives the serial numbers; the worker gets the setting and the store kept between runs (the array
    # cache's folder), not the values
    from e2esim.io.array_cache import ArrayCache

    memo = KernelMemo(max_bytes=5000, max_entries=7, repeated_geometry=True, store=ArrayCache(tmp_path))
    memo[("a", 1)] = np.zeros(10)
    there = pickle.loads(pickle.dumps(memo))
    assert (there.max_bytes, there.max_entries, there.repeated_geometry, len(there)) == (5000, 7, True, 0)
    assert there.store.folder == tmp_path
    assert pickle.loads(pickle.dumps(KernelMemo())).repeated_geometry is False
    assert pickle.loads(pickle.dumps(KernelMemo())).store is None
