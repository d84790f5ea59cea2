"""Budgets that add up where the sources couple: the Shapley split of a requirement's checked value over the error
sources (docs/theory/error-budget.md, Section 3a).

The Euler split (``e2esim.requirements.shares``) needs only the n single removals, and is exact where the sources
add; where the error model couples them (Faraday rotation acts through crosstalk and imbalance, Men et al. 2021,
eqs. 11-12) the single removals do not add, and the Euler parts can leave a remainder larger than the value. The
Shapley value (Shapley 1953, "A value for n-person games", Contributions to the Theory of Games II, 307-317, eq. for
phi_i; for variance decompositions Owen 2014, SIAM/ASA J. Uncertainty Quantification 2, 245-251, Section 2) splits a
game f over the subsets S of the n sources without remainder:

    phi_i = sum over S not holding i of |S|! (n - |S| - 1)! / n!  [f(S + i) - f(S)],   sum_i phi_i = f(N) - f({}).

The game is the square of the statistic of the sigma error that the checked value is a monotone function of, with
only the sources of S switched on (the others taken away through ``ErrorModel.without`` and the added variances,
as ``AGBError.without`` takes away one):

* RMSE: f(S) = b_S^2 + v_S, the mean square (where the sources add this is the Euler split exactly: the cross terms
  2 b_i b_j are halved between i and j, phi_i = b_i b + v_i);
* the bound's quantile x = b + z s ("over"; z s - b "under"): f(S) = x_S |x_S| (the square with its sign, so a
  source that pulls the quantile below zero counts against it); for independent zero-mean terms x^2 = z^2 sum v_i,
  and phi_i = z^2 v_i: the variance shares.

The checked value V is divided in proportion, share_i = V phi_i / f(N) (eq. 4 of the Euler split), and f({}) (what
the error model keeps with every source taken away; zero for the built-in models) is ``shapley.no_source_<unit>``, so
the shares sum to V exactly (to rounding). The 2^n subsets cost 2^k evaluations of the error model (k its sources
active in some case of the block, each evaluated once for the whole block and kept with the model:
``ErrorModel.source_subsets``) and arithmetic for the others.
"""

from __future__ import annotations

from math import factorial

import numpy as np

from e2esim.requirements.base import plain
from e2esim.requirements.shares import picked_side
from e2esim.retrieval.gauss_hermite import standard_normal_quantile

NO_SOURCE = "no_source"
"""The key of the part of the checked value that the error model keeps with every source taken away:
``shapley.no_source_<unit>``."""


def subset_moments(agb) -> tuple:
    """(names, b, v, active): the sources of ``agb`` active in some case, the mean b and variance v of the sigma error
    (m^2/m^2, (m^2/m^2)^2), shape (2^n,) + the case shape, with only the sources of each subset switched on (subset
    mask m: bit k set where source k is on; m = 2^n - 1 is ``agb`` itself), and where each source is active, (n,) +
    the case shape (None without sources). A source not active in a case changes nothing there, exactly."""
    model = agb.error_model
    own, means, variances, own_active = model.source_subsets
    added = np.asarray(agb.added_variance, dtype=float)
    value2 = np.square(np.asarray(model.value, dtype=float))
    others = []
    for name in agb.sources():
        if name not in model.sources:
            var = value2 * np.maximum(agb.contribution(name).relative_variance, 0.0)
            if np.any(var != 0):
                others.append((name, var))
    names = tuple(own) + tuple(n for n, _ in others)
    k, n = len(own), len(names)
    shape = np.broadcast_shapes(np.shape(added), np.shape(means[0]), *(np.shape(var) for _, var in others))
    masks = np.arange(2**n)
    b = np.broadcast_to(means[masks & (2**k - 1)].reshape((-1,) + np.shape(means[0])), (2**n,) + shape)
    v = np.broadcast_to(variances[masks & (2**k - 1)].reshape((-1,) + np.shape(means[0])), (2**n,) + shape)
    if others:
        # the variance of the terms left out, added term by term in one order (a case gets the same bits alone as
        # in a block); as AGBError.without: the added variance less it, never negative
        left_out = np.zeros((2**n,) + shape)
        for j, (_, var) in enumerate(others):
            off = ((masks >> (k + j)) & 1 == 0).astype(float).reshape((-1,) + (1,) * len(shape))
            left_out = left_out + off * var
        v = v + np.maximum(added - left_out, 0.0)
    else:
        v = v + added
    active = np.stack([np.broadcast_to(x, shape) for x in own_active] + [np.broadcast_to(var != 0, shape)
                                                                          for _, var in others]) if n else None
    return names, np.array(b, dtype=float), v, active


def shapley_values(f: np.ndarray) -> np.ndarray:
    """phi (n,) + case shape of the game ``f`` ((2^n,) + case shape, indexed by the subset's bit mask): the Shapley
    value of every player (module docstring)."""
    n = int(f.shape[0]).bit_length() - 1
    masks = np.arange(2**n)
    sizes = np.array([bin(m).count("1") for m in masks])
    weight = np.array([factorial(s) * factorial(n - s - 1) / factorial(n) if s < n else 0.0 for s in sizes])
    phi = np.empty((n,) + f.shape[1:])
    for i in range(n):
        total = np.zeros(f.shape[1:])
        # the terms added one by one in the order of the subsets' masks: each case's sum is the same alone or in a
        # block of any size (np.sum's order of addition depends on the array's layout)
        for m in masks[(masks >> i & 1) == 0]:
            total = total + weight[m] * (f[m | (1 << i)] - f[m])
        phi[i] = total
    return phi


def _by_players(game: np.ndarray, active) -> tuple:
    """(phi, empty): the Shapley values (n,) + case shape and the empty-set value of ``game`` in each case among the
    sources active there, the others switched on and given nothing: a case plays with the players it has alone, so
    that a block's numbers are, bit for bit, those of its cases alone."""
    if active is None or game.ndim == 1:
        return shapley_values(game), game[0]
    n, shape = len(active), game.shape[1:]
    flat, on = game.reshape(game.shape[0], -1), active.reshape(n, -1)
    phi, empty = np.zeros((n, flat.shape[1])), np.empty(flat.shape[1])
    # each case's players as a bit mask (bit j: source j active), to group the cases that have the same players
    codes = np.zeros(flat.shape[1], dtype=np.int64)
    for j in range(n):
        codes |= on[j].astype(np.int64) << j
    patterns, which = np.unique(codes, return_inverse=True)
    for g, pattern in enumerate(patterns.tolist()):  # the cases that have the same players, together
        cases = np.flatnonzero(which == g) if len(patterns) > 1 else np.arange(flat.shape[1])
        players = [j for j in range(n) if pattern >> j & 1]
        rest = sum(1 << j for j in range(n) if not pattern >> j & 1)
        sub = np.array([rest | sum(1 << p for b, p in enumerate(players) if m >> b & 1)
                        for m in range(2 ** len(players))])
        part = np.ascontiguousarray(flat[np.ix_(sub, cases)])
        # each case's sums run over its own subsets only, term by term (``shapley_values``): the case alone's numbers
        phi[np.ix_(players, cases)] = shapley_values(part)
        empty[cases] = part[0]
    return phi.reshape((n,) + shape), empty.reshape(shape)


def _split(value, game: np.ndarray, names: tuple, active, unit: str) -> dict:
    """``shapley.<source>_<unit>`` and ``shapley.no_source_<unit>``: ``value`` divided as the game's Shapley values
    and its empty-set value divide f(N); they sum to ``value`` (zero everywhere where f(N) is zero)."""
    value = np.asarray(value, dtype=float)
    phi, empty = _by_players(game, active)
    total = game[-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(total != 0, value / np.where(total != 0, total, 1.0), 0.0)
    out = {f"shapley.{name}_{unit}": plain(scale * p) for name, p in zip(names, phi)}
    out[f"shapley.{NO_SOURCE}_{unit}"] = plain(scale * empty)
    return out


def rms_shapley(value, agb, unit: str) -> dict:
    """The Shapley split of an RMSE verdict's ``value``: the game is the mean square b^2 + v of the sigma error."""
    names, b, v, active = subset_moments(agb)
    return _complete(_split(value, b * b + v, names, active, unit), agb, unit)


def bound_shapley(value, agb, confidence: float, sides: tuple, side_values: dict, unit: str) -> dict:
    """The Shapley split of an ``agb_error_bound`` verdict's ``value``, of the side that sets it, case by case (as
    ``e2esim.requirements.shares.bound_shares``): the game is x |x| of the side's quantile x of the sigma error."""
    names, b, v, active = subset_moments(agb)
    z = float(standard_normal_quantile(confidence))
    by_side = {}
    for side in sides:
        x = b + z * np.sqrt(v) if side == "over" else z * np.sqrt(v) - b
        by_side[side] = _split(value, x * np.abs(x), names, active, unit)
    pick = picked_side(side_values, sides)
    if isinstance(pick, str):
        return _complete(by_side[pick], agb, unit)
    chosen = pick == "over"
    return _complete({key: plain(np.where(chosen, by_side["over"][key], by_side["under"][key]))
                      for key in by_side["over"]}, agb, unit)


def _complete(out: dict, agb, unit: str) -> dict:
    """Every source of ``agb`` gets its key: zero for those not active in any case."""
    like = next(iter(out.values()))
    zero = 0.0 if np.ndim(like) == 0 else np.zeros(np.shape(like))
    return {**{f"shapley.{name}_{unit}": out.get(f"shapley.{name}_{unit}", zero) for name in agb.sources()},
            f"shapley.{NO_SOURCE}_{unit}": out[f"shapley.{NO_SOURCE}_{unit}"]}

