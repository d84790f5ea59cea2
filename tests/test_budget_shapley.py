"""The Shapley split of a requirement's checked value over the error sources (issue 23, item 1; e2esim.requirements
.shapley, docs/theory/error-budget.md, Section 3a): it sums to the value, equals the variance shares for independent
zero-mean sources that add in quadrature, gives equal shares to interchangeable sources and nothing to a source
without effect, and has no remainder where the sources couple. Every shipped scenario's split is summed in
tests/test_budget_shares.py."""

from __future__ import annotations

from math import factorial

import numpy as np
import pytest

from e2esim.distortion.error_model import HVErrorModel
from e2esim.error_model import Contribution, ErrorModel, Moments
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.requirements.shapley import bound_shapley, rms_shapley, shapley_values, subset_moments
from e2esim.requirements.shares import bound_shares, rms_parts, shares
from e2esim.retrieval.agb_error import AGBContribution, AGBError
from helpers import forest, system

CONF = 0.99865


class ToyModel(ErrorModel):
    """Sources of zero mean whose variances add, times (1 + coupling x the product of the first two), so that
    ``coupling`` makes the first two interact; a source of level 0 is present but does nothing."""

    def __init__(self, variances: dict, coupling: float = 0.0, value: float = 0.05, removed=(), means=None):
        self.variances, self.coupling, self._value, self.removed = dict(variances), coupling, value, frozenset(removed)
        self.means = dict(means or {})

    value = property(lambda self: self._value)
    levels = property(lambda self: {})
    sources = property(lambda self: tuple(self.variances))

    def moments(self, **levels):
        on = {k: v for k, v in self.variances.items() if k not in self.removed}
        names = list(self.variances)
        pair = np.prod([on.get(k, 0.0) for k in names[:2]]) / self._value**4
        mean = sum(m for k, m in self.means.items() if k not in self.removed)
        return Moments(np.float64(mean), np.float64(sum(on.values()) * (1.0 + self.coupling * pair)))

    def without(self, source):
        return ToyModel(self.variances, self.coupling, self._value, self.removed | {source}, self.means)

    def contributions(self):
        return {k: Contribution(0.0, v) for k, v in self.variances.items()}


def _toy_agb(variances, coupling=0.0, random=(), means=None):
    model = ToyModel(variances, coupling, means=means)
    m = model.current()
    agb = AGBError.from_sigma_errors(2.2, model.value, float(m.mean), float(m.sd), error_model=model)
    return agb.with_terms(tuple(AGBContribution(f"term{k}", "random", 0.0, v) for k, v in enumerate(random)))


def _bound(agb, sides=("over",)):
    q = {"over": 100 * float(agb.quantile(CONF)), "under": -100 * float(agb.quantile(1 - CONF))}
    value = max(q[s] for s in sides)
    return value, bound_shapley(value, agb, CONF, sides, {s: q[s] for s in sides}, "percent")


def test_the_shapley_value_of_a_game_is_its_definition_and_sums_to_the_whole():
    rng = np.random.default_rng(7)
    f = rng.normal(size=8)
    f[0] = 0.0
    phi = shapley_values(f)
    assert phi.sum() == pytest.approx(f[-1], rel=1e-12)
    for i in range(3):  # phi_i = sum over S without i of |S|!(n-|S|-1)!/n! [f(S+i) - f(S)] (Shapley 1953)
        expected = sum(factorial(bin(s).count("1")) * factorial(2 - bin(s).count("1")) / 6 * (f[s | 1 << i] - f[s])
                       for s in range(8) if not s >> i & 1)
        assert phi[i] == pytest.approx(expected, rel=1e-12)


def test_independent_sources_adding_in_quadrature_get_their_variance_shares():
    variances = {"a": 4e-6, "b": 9e-6}
    for agb in (_toy_agb(variances), _toy_agb({"a": 4e-6}, random=(9e-6 / 0.05**2,))):
        names = agb.sources()
        value, out = _bound(agb)
        rmse = 100 * agb.rmse()
        rms = rms_shapley(rmse, agb, "percent")
        for name, var in zip(names, variances.values()):  # share_i = V v_i / sum v
            assert out[f"shapley.{name}_percent"] == pytest.approx(value * var / 13e-6, rel=1e-9)
            assert rms[f"shapley.{name}_percent"] == pytest.approx(rmse * var / 13e-6, rel=1e-9)
        assert sum(out.values()) == pytest.approx(value, rel=1e-12)
        assert abs(out["shapley.no_source_percent"]) < 1e-9 * value  # rounding of the added variance


def test_where_biased_sources_add_the_shapley_split_of_the_mean_square_is_the_euler_split():
    """Where b and v add over the sources, the game b_S^2 + v_S gives phi_i = b_i b + v_i (docs/theory/error-budget.md,
    Section 3a): eq. (2), with no remainder."""
    agb = _toy_agb({"a": 4e-6, "b": 9e-6, "c": 1e-6}, means={"a": 0.004, "b": -0.001}, random=(0.002,))
    rmse = 100 * agb.rmse()
    euler = shares(rmse, *rms_parts(agb), "percent")
    exact = rms_shapley(rmse, agb, "percent")
    assert abs(euler["share.interactions_percent"]) < 1e-12 * rmse
    for name in agb.sources():
        assert exact[f"shapley.{name}_percent"] == pytest.approx(euler[f"share.{name}_percent"], rel=1e-9, abs=1e-12)
    b, v = 0.003, 14e-6 + 0.05**2 * 0.002  # b pulls the bias back: its part b_b b + v_b is less than its variance
    assert exact["shapley.b_percent"] == pytest.approx(rmse * (-0.001 * b + 9e-6) / (b * b + v), rel=1e-9)


def test_interchangeable_sources_share_equally_and_a_source_without_effect_gets_nothing():
    agb = _toy_agb({"a": 5e-6, "b": 5e-6, "idle": 0.0, "c": 2e-6}, coupling=3e5)
    value, out = _bound(agb, ("over", "under"))
    assert out["shapley.a_percent"] == pytest.approx(out["shapley.b_percent"], rel=1e-12)
    assert out["shapley.idle_percent"] == 0.0
    assert sum(out.values()) == pytest.approx(value, rel=1e-12)
    # the coupling is real: the single removals (Euler) leave a remainder that the Shapley split does not
    q = {"over": value, "under": -100 * float(agb.quantile(1 - CONF))}
    euler = bound_shares(value, agb, CONF, ("over", "under"), q, "percent")
    assert abs(euler["share.interactions_percent"]) > 0.05 * value


def test_where_faraday_rotation_couples_the_split_has_no_remainder_and_stays_within_the_value():
    model = HVErrorModel(forest("boreal_200"), system(), GaussianFaraday(np.pi / 3, np.radians(5.0)))
    m = model.current()
    agb = AGBError.from_sigma_errors(2.2, model.value, float(m.mean), float(m.sd), error_model=model)
    names, b, v, _ = subset_moments(agb)
    assert b[-1] == pytest.approx(float(m.mean), rel=1e-12) and v[-1] == pytest.approx(float(m.variance), rel=1e-12)
    assert "faraday_rotation" in names and b[0] == 0.0 and v[0] == 0.0
    value, out = _bound(agb, ("over", "under"))
    assert sum(out.values()) == pytest.approx(value, rel=1e-12)
    assert all(-value <= x <= value for x in out.values())
    q = {"over": value, "under": -100 * float(agb.quantile(1 - CONF))}
    euler = bound_shares(value, agb, CONF, ("over", "under"), q, "percent")
    assert abs(euler["share.interactions_percent"]) > 0.01 * value


def test_a_block_leaves_out_a_source_active_in_none_of_its_cases_as_each_case_alone_does():
    """The subsets' moments are the error model's (``ErrorModel.source_subsets``, evaluated once per model object):
    a source that no case of a block has (here the gain error) is left out, so the block evaluates 2^k subsets of
    the k sources active somewhere, as each case alone does, with each case's numbers bit for bit."""
    from e2esim.distortion.analytic import MomentInputs

    faraday = GaussianFaraday(np.pi / 3, np.radians(5.0))
    alone = [HVErrorModel(forest(name), system(crosstalk_db=db), faraday)
             for name, db in (("boreal_200", -30.0), ("tropical_338", -24.0), ("boreal_50", -36.0))]
    block = HVErrorModel(alone[0].scene, alone[0].system, faraday,
                         inputs=MomentInputs.stack([m.moment_inputs for m in alone]))
    assert block.without("gain") is block  # no case has a gain error: removing it is the model itself
    names, means, variances, active = block.source_subsets
    assert all(np.all(a) for a in active)  # the four active in every case
    assert block.source_subsets is block.source_subsets
    assert names == ("crosstalk", "channel_imbalance", "noise", "faraday_rotation") and means.shape == (16, 3)
    for k, model in enumerate(alone):
        own, mean, variance, _ = model.source_subsets
        assert own == names
        np.testing.assert_array_equal(means[:, k], mean)
        np.testing.assert_array_equal(variances[:, k], variance)


def test_a_source_active_in_no_case_of_a_block_is_neither_evaluated_nor_attributed():
    """``AGBError.without`` of a source that no case of a block has evaluates nothing (as for a case alone, where
    the error model returns itself): the attribution gives it 0 in every case, as each case alone."""
    from e2esim.distortion.analytic import MomentInputs
    from e2esim.requirements.attribution import attribution

    faraday = GaussianFaraday(np.pi / 3, np.radians(5.0))
    alone = [HVErrorModel(forest(name), system(), faraday) for name in ("boreal_200", "tropical_338")]
    block = HVErrorModel(alone[0].scene, alone[0].system, faraday,
                         inputs=MomentInputs.stack([m.moment_inputs for m in alone]))
    m = block.current()
    agb = AGBError.from_sigma_errors(np.full(2, 2.2), block.value, m.mean, m.sd, error_model=block)
    variant, inactive = agb.without("gain")
    assert variant is None and np.all(inactive)
    out, _ = attribution(lambda a: a.rmse("analytic") * 100, agb)
    for k, model in enumerate(alone):
        one = model.current()
        alone_out, _ = attribution(lambda a: a.rmse("analytic") * 100, AGBError.from_sigma_errors(
            2.2, model.value, float(one.mean), float(one.sd), error_model=model))
        assert {key: out[key][k] for key in out} == alone_out


def _loop_shapley(f):
    """The definition term by term (Shapley 1953): each player's terms added one by one from 0.0 in the order of
    the subsets' masks, the order ``shapley_values`` keeps."""
    n = int(f.shape[0]).bit_length() - 1
    phi = np.empty((n,) + f.shape[1:])
    for i in range(n):
        total = np.zeros(f.shape[1:])
        for m in (m for m in range(2**n) if not m >> i & 1):
            s = bin(m).count("1")
            total = total + factorial(s) * factorial(n - s - 1) / factorial(n) * (f[m | 1 << i] - f[m])
        phi[i] = total
    return phi


@pytest.mark.parametrize("n", [0, 1, 3, 6, 10])
def test_the_shapley_values_are_the_loop_over_subsets_bit_for_bit_for_a_case_and_any_block(n, seed):
    """``shapley_values`` forms a player's terms at once and adds them in the masks' order (numpy's reduction over
    the rows, one case by accumulation): the loop's bits, -0.0 sums included, for a case alone, a block of any size
    (one, two, odd, several cache chunks) and a block's cases each alone."""
    rng = np.random.default_rng(seed)
    cases = 2 * (2**20 // 2 ** max(n - 1, 0)) + 3 if n == 10 else 37  # n = 10: three chunks, the last of 3 cases
    f = rng.normal(size=(2**n, cases)) * 10.0 ** rng.integers(-8, 8, size=(2**n, cases))
    f[:, 0] = 0.0  # a game without effect
    f[:, 1] = -0.0
    f[1::2, 2] = f[0::2, 2]  # player 0 without effect: -0.0 differences where f is negative
    f[:, 3] = np.where(np.arange(2**n) & 1, -0.0, 0.0)  # player 0's terms all -0.0: their sum from 0.0 is +0.0
    got = shapley_values(f)
    want = _loop_shapley(f)
    assert got.shape == want.shape == (n, cases)
    assert got.tobytes() == want.tobytes()
    for k in (0, 1, 2, 3, 4, cases - 1):  # each case alone, as a 1-D game and as a block of one
        assert shapley_values(f[:, k]).tobytes() == want[:, k].tobytes()
        assert shapley_values(np.ascontiguousarray(f[:, k:k + 1])).tobytes() == want[:, k:k + 1].tobytes()
    # a block of two, a strided one, the last two, one in Fortran order (a gathered block's layout)
    for block in (f[:, 5:7], f[:, ::3], f[:, -2:], np.asfortranarray(f[:, 4:13])):
        assert shapley_values(block).tobytes() == _loop_shapley(block).tobytes()


def test_a_block_whose_cases_have_different_players_gives_each_case_its_own_game_bit_for_bit(seed):
    """``_by_players``: each case plays with the sources active there (the others switched on, given 0), grouped by
    pattern; every case's values are those of its own game alone, bit for bit, in a block of mixed patterns, of one
    pattern lacking a player, and of every player."""
    from e2esim.requirements.shapley import _by_players

    rng = np.random.default_rng(seed)
    n, cases = 5, 40
    game = rng.normal(size=(2**n, cases))
    for active in (rng.random((n, cases)) < 0.7, np.tile(np.array([[1], [0], [1], [1], [0]], dtype=bool), cases),
                   np.ones((n, cases), dtype=bool)):
        phi, empty = _by_players(game, active)
        for c in range(cases):
            players = np.flatnonzero(active[:, c])
            rest = sum(1 << j for j in range(n) if not active[j, c])
            sub = [rest | sum(1 << int(p) for b, p in enumerate(players) if m >> b & 1)
                   for m in range(2 ** len(players))]
            want = np.zeros(n)
            want[players] = shapley_values(game[sub, c])
            assert phi[:, c].tobytes() == want.tobytes() and empty[c] == game[sub[0], c]


@pytest.mark.parametrize("kind", ["rms", "bound"])
def test_the_game_formed_a_chunk_of_cases_at_a_time_is_the_whole_game_bit_for_bit(kind, seed, monkeypatch):
    """``_Game`` forms f for a chunk of cases at a time (in arrays reused across chunks): its Shapley values, empty
    and full sets are, bit for bit, those of the whole (2^n, cases) game formed at once and split by ``_by_players``
    (several chunks and a last chunk of one case; the bound with a side per case)."""
    from e2esim.requirements import shapley

    rng = np.random.default_rng(seed)
    k, n = 4, 10
    cases = 2 * (shapley.CHUNK_BYTES // (8 * 2 ** (n - 1))) + 1
    means = rng.normal(size=(2**k, cases)) * 0.01
    variances = rng.random((2**k, cases)) * 10.0 ** rng.integers(-8, -2, size=(2**k, cases))
    extra = rng.random((2 ** (n - k), cases)) * 1e-4
    active = np.ones((n, cases), dtype=bool)
    monkeypatch.setattr(shapley, "_subset_parts", lambda agb: (tuple(f"s{j}" for j in range(n)), means, variances,
                                                              extra, active, (cases,)))
    sign = np.where(rng.random(cases) < 0.5, 1.0, -1.0)
    z = 3.0
    whole = np.empty((2**n, cases))
    for m in range(2**n):
        o, t = m & (2**k - 1), m >> k
        v = variances[o] + extra[t]
        if kind == "rms":
            whole[m] = means[o] * means[o] + v
        else:
            x = np.sqrt(v) * z + sign * means[o]
            whole[m] = x * np.abs(x)
    game = shapley._rms_game(None) if kind == "rms" else shapley._bound_game(None, z, sign)
    phi, empty = shapley._played(game)
    want_phi, want_empty = shapley._by_players(whole, active)
    assert phi.tobytes() == want_phi.tobytes() and empty.tobytes() == want_empty.tobytes()
    assert game.row(2**n - 1).tobytes() == whole[-1].tobytes()
    assert game.whole().tobytes() == whole.tobytes()


def test_the_hv_model_evaluates_its_own_moments_once_and_moments_at_other_levels_each_time():
    """``HVErrorModel.moments()`` at its own levels is kept with the model (the Shapley split's variants, its bound
    and the attribution ask the same model): the same object, equal to a fresh model's bit for bit; a question at
    other levels is answered at those levels, before and after, never with the kept moments."""
    faraday = GaussianFaraday(np.pi / 3, np.radians(5.0))
    model = HVErrorModel(forest("boreal_200"), system(), faraday)
    fresh = HVErrorModel(forest("boreal_200"), system(), faraday)
    at_levels = model.moments(crosstalk=1e-2)
    own = model.moments()
    assert model.moments() is own
    assert float(own.mean) == float(fresh.moments().mean) and float(own.variance) == float(fresh.moments().variance)
    again = model.moments(crosstalk=1e-2)
    assert float(again.variance) == float(at_levels.variance) != float(own.variance)
