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

import math
from math import factorial

import numpy as np

from e2esim.requirements.base import plain
from e2esim.requirements.shares import picked_side
from e2esim.retrieval.gauss_hermite import standard_normal_quantile

NO_SOURCE = "no_source"
"""The key of the part of the checked value that the error model keeps with every source taken away:
``shapley.no_source_<unit>``."""


def _subset_parts(agb) -> tuple:
    """(names, means, variances, extra, active, shape): the game's moments in two factors. The mean and variance
    of the error model's own k sources (``ErrorModel.source_subsets``, (2^k,) + its case shape, by the mask of the
    own sources switched on), and ``extra`` ((2^(n-k),) + the case shape, by the mask t of the other n - k sources
    switched on): the variance the added terms keep (as ``AGBError.without``: the added variance less that of the
    terms left out, never negative). Subset m = t 2^k + o has the mean means[o] and the variance variances[o] +
    extra[t], the sum ``subset_moments`` forms: its numbers, without its (2^n,) + case shape copies of each."""
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
    if others:
        # the variance of the terms left out, added term by term in one order (a case gets the same bits alone as
        # in a block)
        switched_on = np.arange(2 ** (n - k))
        left_out = np.zeros((2 ** (n - k),) + shape)
        for j, (_, var) in enumerate(others):
            off = ((switched_on >> j) & 1 == 0).astype(float).reshape((-1,) + (1,) * len(shape))
            left_out = left_out + off * var
        extra = np.maximum(added - left_out, 0.0)
    else:
        extra = np.broadcast_to(added, shape)[None]
    active = np.stack([np.broadcast_to(x, shape) for x in own_active] + [np.broadcast_to(var != 0, shape)
                                                                          for _, var in others]) if n else None
    own_shape = (2**k,) + shape
    return (names, np.broadcast_to(np.asarray(means, dtype=float), own_shape),
            np.broadcast_to(np.asarray(variances, dtype=float), own_shape), extra, active, shape)


def _over_subsets(own: np.ndarray, extra: np.ndarray, shape: tuple) -> np.ndarray:
    """own[o] + extra[t] for every subset m = t 2^k + o: (2^n,) + ``shape``, a new C-contiguous array."""
    return np.add(own[None], extra[:, None]).reshape((-1,) + shape)


def subset_moments(agb) -> tuple:
    """(names, b, v, active): the sources of ``agb`` active in some case, the mean b and variance v of the sigma error
    (m^2/m^2, (m^2/m^2)^2), shape (2^n,) + the case shape, with only the sources of each subset switched on (subset
    mask m: bit k set where source k is on; m = 2^n - 1 is ``agb`` itself), and where each source is active, (n,) +
    the case shape (None without sources). A source not active in a case changes nothing there, exactly."""
    names, means, variances, extra, active, shape = _subset_parts(agb)
    b = np.ascontiguousarray(np.broadcast_to(means[None], (len(extra),) + means.shape)).reshape((-1,) + shape)
    return names, b, _over_subsets(variances, extra, shape), active


class _Game:
    """The game of ``_subset_parts`` over the subsets (module docstring), formed a chunk of cases at a time
    (``chunk``): a block's whole (2^n,) + case shape game (2^12 x 4096 cases: 134 MB) went through memory three
    times; a chunk's stays in the cache. Every element is the same, bit for bit, as the whole game's (the same
    elementwise operations on the same numbers). ``finish(rows, cols)`` makes f in place from rows = v_S (the
    subsets' variances) of the cases ``cols``."""

    def __init__(self, agb, finish):
        names, means, variances, extra, active, shape = _subset_parts(agb)
        self.names, self.active, self.shape, self._finish = names, active, shape, finish
        cases = math.prod(shape)
        self.means, self.variances = means.reshape(len(means), cases), variances.reshape(len(means), cases)
        self.extra = np.broadcast_to(extra, (len(extra),) + shape).reshape(len(extra), cases)
        self._buffer = None  # the array of the last chunk, reused by the next (``chunk``)

    @property
    def size(self) -> int:
        return len(self.means) * len(self.extra)

    def chunk(self, cols=slice(None), reuse: bool = True) -> np.ndarray:
        """f (2^n, cases) of the cases ``cols`` (a slice of the flat case axis); ``reuse``: in the array of the
        previous chunk (the next call overwrites it: fresh arrays per chunk cost page faults)."""
        v, e = self.variances[:, cols], self.extra[:, cols]
        shape = (len(e), len(v), v.shape[1])
        if not reuse:
            rows = np.empty(shape)
        else:
            if self._buffer is None or self._buffer.size < math.prod(shape):
                self._buffer = np.empty(math.prod(shape))
            rows = self._buffer[:math.prod(shape)].reshape(shape)
        np.add(v[None], e[:, None], out=rows)  # own[o] + extra[t] for m = t 2^k + o, as ``_over_subsets``
        rows = rows.reshape(self.size, v.shape[1])
        self._finish(rows, self.means[:, cols], cols)
        return rows

    def row(self, m: int) -> np.ndarray:
        """f(S) of subset mask ``m`` in every case, in the case shape."""
        k = len(self.means).bit_length() - 1
        o, t = m & (2**k - 1), m >> k
        rows = np.add(self.variances[o], self.extra[t])[None]
        self._finish(rows, self.means[o][None], slice(None))
        return rows[0].reshape(self.shape)

    def whole(self) -> np.ndarray:
        """The game (2^n,) + case shape."""
        return self.chunk(reuse=False).reshape((self.size,) + self.shape)


def _rms_game(agb) -> _Game:
    """f(S) = b_S^2 + v_S over the subsets (module docstring), formed in place."""

    def finish(rows, means, cols):
        view = rows.reshape((-1,) + means.shape)
        np.add((means * means)[None], view, out=view)  # b*b + v, as the expression writes it

    return _Game(agb, finish)


def _bound_game(agb, z: float, sign) -> _Game:
    """f(S) = x_S |x_S| of the quantile x = z s + sign b (sign +1: "over", b + z s; -1: "under", z s - b; a float,
    or per case), formed in place. z s + (-b) is z s - b bit for bit (IEEE 754 defines x - y as x + (-y)), so a
    block whose cases pick different sides plays each case's own game."""
    flat_sign = sign if np.ndim(sign) == 0 else np.reshape(sign, -1)

    def finish(rows, means, cols):
        np.sqrt(rows, out=rows)
        np.multiply(rows, z, out=rows)
        signed = (flat_sign if np.ndim(flat_sign) == 0 else flat_sign[cols]) * means
        view = rows.reshape((-1,) + means.shape)
        np.add(view, signed[None], out=view)
        np.multiply(rows, np.abs(rows), out=rows)

    return _Game(agb, finish)


CHUNK_BYTES = 2**21
"""The size of one player's terms for a chunk of cases in ``shapley_values``: in a core's cache (2 MiB)."""


def shapley_values(f: np.ndarray) -> np.ndarray:
    """phi (n,) + case shape of the game ``f`` ((2^n,) + case shape, indexed by the subset's bit mask): the Shapley
    value of every player (module docstring).

    Each case's phi_i is the sum of its terms weight(S) [f(S + i) - f(S)] added one by one from 0.0 in the order of
    the subsets' masks, so that it is the same, bit for bit, alone or in a block of any size and layout. The terms of
    one player are formed at once: the subsets without i are m = a 2^(i+1) + c (c < 2^i), so f seen as (2^(n-1-i), 2,
    2^i, cases) holds f(S) at [a, 0, c] and f(S + i) at [a, 1, c], in the masks' order. ``_in_order`` adds them."""
    n = int(f.shape[0]).bit_length() - 1
    flat = f.reshape(2**n, -1)
    return _values_in_chunks(n, flat.shape[1], lambda cols: flat[:, cols]).reshape((n,) + f.shape[1:])


def _values_in_chunks(n: int, cases: int, part_of) -> np.ndarray:
    """``shapley_values`` (n, cases) of a game of n players whose rows (2^n, chunk) for the cases of a slice are
    ``part_of(slice)``: a chunk of cases at a time, its terms in the cache."""
    masks = np.arange(2**n)
    sizes = sum((masks >> j) & 1 for j in range(n)) if n else np.zeros(1, dtype=int)  # |S| of every subset mask
    by_size = np.array([factorial(s) * factorial(n - s - 1) / factorial(n) for s in range(n)] + [0.0])
    weight = by_size[sizes]  # |S|! (n - |S| - 1)! / n!, the same numbers computed once per size
    phi = np.empty((n, cases))
    step = max(2, CHUNK_BYTES // (8 * 2 ** max(n - 1, 0)))
    space = np.empty(2 ** max(n - 1, 0) * min(step, cases))  # one player's terms, reused (no page faults)
    for start in range(0, cases, step):
        part = part_of(slice(start, start + step))
        for i in range(n):
            pairs = part.reshape(2 ** (n - 1 - i), 2, 2**i, part.shape[1])
            terms = space[:2 ** (n - 1) * part.shape[1]].reshape(2 ** (n - 1 - i), 2**i, part.shape[1])
            np.subtract(pairs[:, 1], pairs[:, 0], out=terms)  # C order, whatever f's layout
            terms *= weight.reshape(2 ** (n - 1 - i), 2, 2**i)[:, 0, :, None]
            phi[i, start:start + step] = _in_order(terms.reshape(2 ** (n - 1), part.shape[1]))
    return phi


def _in_order(terms: np.ndarray) -> np.ndarray:
    """The sums over axis 0 of ``terms`` (rows, cases), each case's terms added one by one from 0.0 in the rows'
    order: 0.0 + t_0 + t_1 + ... (the start from 0.0 makes a sum of -0.0 terms +0.0, as a loop from zeros does).
    For two cases or more, numpy's reduction over axis 0 of a C-contiguous 2-D array (an F-ordered one would be
    summed pairwise down its contiguous rows: made C-contiguous first) does exactly that: its
    iterator puts the contiguous case axis inside (the result's stride along the rows is 0, so the input's strides
    order the axes) and goes through the rows in order, adding row r to the running sums (an element-wise add,
    never the pairwise summation numpy uses along a contiguous reduced axis); tests/test_budget_shapley.py checks it
    against the loop bit for bit. One case's terms would be a reduction along a contiguous axis, which numpy sums
    pairwise: ``np.add.accumulate`` adds them in order by definition (each partial sum is the previous plus one)."""
    if terms.shape[1] >= 2:
        return np.add.reduce(np.ascontiguousarray(terms), axis=0, initial=0.0)
    return np.add.accumulate(np.concatenate((np.zeros((1, 1)), terms)), axis=0)[-1]


def _played(game: _Game) -> tuple:
    """``_by_players`` of ``game``: where every case has every player (a map's cases), with the game formed a chunk
    of cases at a time (``_Game.chunk``), the same numbers."""
    if game.active is None or game.shape == () or np.all(game.active):
        phi = _values_in_chunks(len(game.names), math.prod(game.shape), game.chunk)
        return phi.reshape((len(game.names),) + game.shape), game.row(0)
    return _by_players(game.whole(), game.active)


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
        cases = np.flatnonzero(which == g) if len(patterns) > 1 else slice(None)
        players = [j for j in range(n) if pattern >> j & 1]
        # the game's rows of each subset of the players, the others switched on (every row: the game itself)
        rows = flat
        if len(players) < n:
            masks, sub = np.arange(2 ** len(players)), np.full(2 ** len(players), (2**n - 1) & ~pattern)
            for b, p in enumerate(players):
                sub |= ((masks >> b) & 1) << p
            rows = flat[sub]
        part = rows if isinstance(cases, slice) else rows[:, cases]
        # each case's sums run over its own subsets only, term by term (``shapley_values``): the case alone's numbers
        phi[players if isinstance(cases, slice) else np.ix_(players, cases)] = shapley_values(part)
        empty[cases] = part[0]
    return phi.reshape((n,) + shape), empty.reshape(shape)


def _split(value, game: _Game, unit: str) -> dict:
    """``shapley.<source>_<unit>`` and ``shapley.no_source_<unit>``: ``value`` divided as the game's Shapley values
    and its empty-set value divide f(N); they sum to ``value`` (zero everywhere where f(N) is zero)."""
    value = np.asarray(value, dtype=float)
    phi, empty = _played(game)
    total = game.row(game.size - 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(total != 0, value / np.where(total != 0, total, 1.0), 0.0)
    out = {f"shapley.{name}_{unit}": plain(scale * p) for name, p in zip(game.names, phi)}
    out[f"shapley.{NO_SOURCE}_{unit}"] = plain(scale * empty)
    return out


def rms_shapley(value, agb, unit: str) -> dict:
    """The Shapley split of an RMSE verdict's ``value``: the game is the mean square b^2 + v of the sigma error."""
    return _complete(_split(value, _rms_game(agb), unit), agb, unit)


def bound_shapley(value, agb, confidence: float, sides: tuple, side_values: dict, unit: str) -> dict:
    """The Shapley split of an ``agb_error_bound`` verdict's ``value``, of the side that sets it, case by case (as
    ``e2esim.requirements.shares.bound_shares``): the game is x |x| of the side's quantile x of the sigma error.
    Each case plays the game of its own side only (a block whose cases pick both: the sign of b per case)."""
    z = float(standard_normal_quantile(confidence))
    pick = picked_side(side_values, sides)
    sign = (1.0 if pick == "over" else -1.0) if isinstance(pick, str) else np.where(pick == "over", 1.0, -1.0)
    return _complete(_split(value, _bound_game(agb, z, sign), unit), agb, unit)


def _complete(out: dict, agb, unit: str) -> dict:
    """Every source of ``agb`` gets its key: zero for those not active in any case."""
    like = next(iter(out.values()))
    zero = 0.0 if np.ndim(like) == 0 else np.zeros(np.shape(like))
    return {**{f"shapley.{name}_{unit}": out.get(f"shapley.{name}_{unit}", zero) for name in agb.sources()},
            f"shapley.{NO_SOURCE}_{unit}": out[f"shapley.{NO_SOURCE}_{unit}"]}

