"""Gauss-Hermite averages over a Gaussian sigma error: the moments of the relative AGB error behind every analytic
answer of an ``AGBError`` (``e2esim.retrieval.agb_error``).

E[h(Z)], Z standard normal, from h at the probabilists' Gauss-Hermite nodes (Abramowitz & Stegun 25.4.46, with
weight e^(-z^2/2) / sqrt(2 pi)); the same operations for one case as for a block of them, so a case gets bitwise
the same numbers alone or in a block.
"""

from __future__ import annotations

import numpy as np

from e2esim.case_values import plain

HERMITE_NODES, HERMITE_WEIGHTS = np.polynomial.hermite_e.hermegauss(64)
HERMITE_WEIGHTS = HERMITE_WEIGHTS / np.sqrt(2 * np.pi)  # probabilists' Hermite: weights sum to 1


def standard_normal_quantile(probability):
    """z with P(Z <= z) = probability (e.g. 0.99865 -> 3.00, Men et al. 2021, Table III)."""
    from scipy import special  # imported here: scipy.special costs a third of a second at start-up

    return special.ndtri(probability)


def gaussian_q_stats(mapping, mean, variance, exponent=None) -> dict:
    """Mean, SD and RMSE of q = mapping(x), x ~ N(mean, variance); ``exponent``: the map is the power law
    with that exponent (evaluated in cache-sized chunks, ``power_law_q_moments``)."""
    if exponent is not None:
        m, ms = power_law_q_moments(mean, np.sqrt(variance), exponent)
    else:
        x = along(mean, 1) + np.sqrt(along(variance, 1)) * HERMITE_NODES
        q = mapping(x)
        m = hermite_average(q)
        ms = hermite_average(q**2)
    # a source without spread gives q without spread: SD 0, not the rounding noise of E[q^2] - E[q]^2
    sd = np.where(np.asarray(variance) > 0, np.sqrt(np.maximum(ms - np.square(m), 0.0)), 0.0)
    return {"mean": plain(m), "sd": plain(sd), "rmse": plain(np.sqrt(ms))}


_SHORT_RULE_NODES = 16
_SHORT_RULE_LARGEST_SPREAD = 0.1
"""Cases whose sigma estimate (sigma + e) has a relative spread sd / (sigma + mean) of at most 0.1 take the
16-node Gauss-Hermite rule instead of the 64-node one: q = (1 + x)^p - 1 is then analytic over many standard
deviations around the mean (its branch point lies beyond 10 of them), and the two rules agree to about 1e-15
relative for exponents 0.5-5 (tests/test_agb_error.py). A wider spread keeps 64 nodes."""
_SHORT_NODES, _SHORT_WEIGHTS = np.polynomial.hermite_e.hermegauss(_SHORT_RULE_NODES)
_SHORT_WEIGHTS = _SHORT_WEIGHTS / np.sqrt(2 * np.pi)
_CHUNK_VALUES = 256 * 64
"""Values of q evaluated at once in ``power_law_q_moments``: 128 kB stay in the CPU cache, where a block's
whole (4096, 64) array would not (twice the time per element)."""


def power_law_q_moments(mean, sd, exponent, sigma=None) -> tuple:
    """(E[q], E[q^2]) of q = (1 + x)^p - 1 (inverse of Men et al. 2021, eq. 16; q = -1 for x <= -1) with
    x = (mean + sd Z) / sigma, Z ~ N(0, 1) (sigma None: x = mean + sd Z), by Gauss-Hermite quadrature: 16 nodes
    where the spread is small enough (``_SHORT_RULE_LARGEST_SPREAD``), 64 otherwise.

    Per case the operations of ``power_law.agb_relative_error`` at the nodes followed by ``hermite_average``, so
    a case gets bitwise the same numbers alone or in a block; a block is evaluated in cache-sized chunks, in place.
    Arrays broadcast; the results have their broadcast shape.
    """
    fields = [mean, sd, exponent, 1.0 if sigma is None else sigma]
    fields = np.broadcast_arrays(*(np.asarray(f, dtype=float) for f in fields))
    shape = fields[0].shape
    mean, sd, exponent, scale = (f.reshape(-1) for f in fields)
    first, second = np.empty(mean.size), np.empty(mean.size)
    with np.errstate(divide="ignore", invalid="ignore"):
        short = sd <= _SHORT_RULE_LARGEST_SPREAD * (scale + mean)  # False for nan and for sigma + mean <= 0
    for cases, nodes, weights in ((np.flatnonzero(short), _SHORT_NODES, _SHORT_WEIGHTS),
                                  (np.flatnonzero(~short), HERMITE_NODES, HERMITE_WEIGHTS)):
        step = _CHUNK_VALUES // len(nodes)
        for start in range(0, len(cases), step):
            rows = cases[start:start + step]
            first[rows], second[rows] = _power_law_moments_at(mean[rows], sd[rows], exponent[rows],
                                                              None if sigma is None else scale[rows], nodes, weights)
    return first.reshape(shape), second.reshape(shape)


def _power_law_moments_at(mean, sd, exponent, sigma, nodes, weights) -> tuple:
    x = mean[:, None] + sd[:, None] * nodes
    if sigma is not None:
        x /= sigma[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.log1p(x)
        q *= exponent[:, None]
        np.expm1(q, out=q)
    q[~(x > -1.0)] = -1.0  # an estimate at or below zero: q = -1 (agb_relative_error)
    first = (q * weights).sum(-1)  # hermite_average, with this rule's weights
    np.square(q, out=q)
    return first, (q * weights).sum(-1)


def hermite_average(values):
    """E[h(Z)], Z standard normal, from h at the 64 Gauss-Hermite nodes (last axis): an element-wise product
    and numpy's sum, the same operations for one case as for a block of them."""
    return (values * HERMITE_WEIGHTS).sum(-1)


def along(x, extra: int):
    """``x`` (a number, or an array over cases) with ``extra`` trailing length-1 axes, to broadcast against
    arrays of shape case + ``extra`` further axes."""
    x = np.asarray(x, dtype=float)
    return x.reshape(x.shape + (1,) * extra) if extra > 0 else x
