"""Budgets that add up: each error source's share of a requirement's checked value (docs/theory/error-budget.md).

The checked values are statistics of the Gaussian sigma error e (mean b, variance v; m^2/m^2) carried through the
monotone map to the relative AGB error (``AGBError``). Each source i is measured by what it adds to the two moments,
from the AGB error without it (``AGBError.without``): b_i = b - b_(-i), v_i = v - v_(-i). Independent sources add,
b = sum b_i and v = sum v_i, and the statistic is split by the Euler principle (Tasche 2008, "Capital allocation
to business units and sub-portfolios: the Euler principle", arXiv:0708.2542, Sections 2 and 4.1: the Euler
contribution of a homogeneous risk measure; for the standard deviation Cov(X_i, X) / sd(X), for a Gaussian
quantile E[X_i] + z Cov(X_i, X) / sd(X)):

* RMSE: the mean square b^2 + v, each source b_i b + v_i (docs/theory/error-budget.md, eq. 2);
* the quantile at confidence P (``agb_error_bound``): x_P = b + z s (s = sqrt(v), z = Phi^-1(P); the "under"
  side z -> -z), each source b_i + z v_i / s (eq. 3).

The checked value is then divided in proportion to these parts (eq. 4), so the shares sum to it exactly. What the
parts leave over, (b - sum b_i) b + (v - sum v_i) for the RMSE and alike for the quantile, is where the error model
couples its sources (a source's effect depends on another's: crosstalk, channel imbalance and Faraday rotation act
through the same system model, Men et al. 2021, eqs. 11-12); it is its own line, ``share.interactions_<unit>``, and
zero where the sources add.
"""

from __future__ import annotations

import numpy as np

from e2esim.case_values import plain
from e2esim.retrieval.gauss_hermite import standard_normal_quantile

INTERACTIONS = "interactions"
"""The key of the share no single source accounts for: ``share.interactions_<unit>``."""


def source_moments(agb) -> tuple:
    """(b, v, {source: (b_i, v_i)}): the mean and variance of the total sigma error (m^2/m^2) and what each source
    of ``agb.sources()`` adds to them (zero where it is not active)."""
    b = np.asarray(agb.error_mean, dtype=float)
    v = np.square(np.asarray(agb.error_sd, dtype=float))
    parts = {}
    for name in agb.sources():
        variant, inactive = agb.without(name)
        if variant is None:
            parts[name] = (np.zeros_like(b), np.zeros_like(v))
            continue
        db = b - np.asarray(variant.error_mean, dtype=float)
        dv = v - np.square(np.asarray(variant.error_sd, dtype=float))
        if inactive is not None:
            db, dv = np.where(inactive, 0.0, db), np.where(inactive, 0.0, dv)
        parts[name] = (db, dv)
    return b, v, parts


def rms_parts(agb) -> tuple:
    """(total, {source: part}) of the mean square b^2 + v of the sigma error (Euler: b_i b + v_i)."""
    b, v, parts = source_moments(agb)
    return b * b + v, {name: db * b + dv for name, (db, dv) in parts.items()}


def quantile_parts(agb, confidence: float, side: str) -> tuple:
    """(total, {source: part}) of the Gaussian quantile x = b + z s of the sigma error ("over": P = confidence;
    "under": b - z s, the quantile at 1 - confidence), by Euler: b_i + z v_i / s."""
    b, v, parts = source_moments(agb)
    z = float(standard_normal_quantile(confidence)) * (1.0 if side == "over" else -1.0)
    s = np.sqrt(v)
    with np.errstate(divide="ignore", invalid="ignore"):
        per_sd = {name: np.where(s > 0, dv / np.where(s > 0, s, 1.0), 0.0) for name, (_, dv) in parts.items()}
    return b + z * s, {name: parts[name][0] + z * per_sd[name] for name in parts}


def shares(value, total, parts: dict, unit: str) -> dict:
    """``share.<source>_<unit>``: ``value`` divided in proportion to ``parts`` of ``total`` (eq. 4), and
    ``share.interactions_<unit>``, the rest; they sum to ``value`` exactly (to rounding). Where the total is zero
    every share is zero."""
    value = np.asarray(value, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(total != 0, value / np.where(total != 0, total, 1.0), 0.0)
    out = {f"share.{name}_{unit}": plain(scale * part) for name, part in parts.items()}
    attributed = sum((np.asarray(x) for x in out.values()), np.zeros_like(value))
    out[f"share.{INTERACTIONS}_{unit}"] = plain(value - attributed)
    return out


def picked_side(side_values: dict, sides: tuple):
    """For each case, the side whose value is the checked one (the largest; "over" on a tie), as ``largest``
    takes it: a str for one case, an object array for a block."""
    if len(sides) == 1:
        return sides[0]
    over, under = (np.asarray(side_values[s], dtype=float) for s in ("over", "under"))
    pick = np.where(over >= under, "over", "under")
    return str(pick) if pick.ndim == 0 else pick.astype(object)


def bound_shares(value, agb, confidence: float, sides: tuple, side_values: dict, unit: str) -> dict:
    """The shares of an ``agb_error_bound`` verdict: of the side that sets its value, case by case."""
    pick = picked_side(side_values, sides)
    by_side = {side: quantile_parts(agb, confidence, side) for side in sides}
    if isinstance(pick, str):
        total, parts = by_side[pick]
    else:
        over, under = by_side["over"], by_side["under"]
        chosen = pick == "over"
        total = np.where(chosen, over[0], under[0])
        parts = {name: np.where(chosen, over[1][name], under[1][name]) for name in over[1]}
    return shares(value, total, parts, unit)

