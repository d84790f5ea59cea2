"""The scan of a search range before root finding: where the margins change sign (``e2esim.flowdown.inverse``,
``e2esim.flowdown.boundary``)."""

from __future__ import annotations

import numpy as np


def scan_brackets(xs: np.ndarray, m: np.ndarray) -> tuple:
    """From margins ``m`` (..., S) at the scan points ``xs`` (S,): the state of every element, its bracket (a, b)
    and margins there (the first sign change from the low end), which side meets ("at most": the values below),
    and how many sign changes the scan saw."""
    nan = np.any(np.isnan(m), axis=-1)
    good = m >= 0
    changes = good[..., 1:] != good[..., :-1]
    first = np.argmax(changes, axis=-1)
    state = np.full(m.shape[:-1], "met at", dtype=object)
    state[np.all(good, axis=-1)] = "every value meets it"
    state[np.all(~good, axis=-1)] = "no value meets it"
    state[~nan & np.all(m == m[..., :1], axis=-1)] = "no effect"
    state[nan] = "not applicable"
    take = np.take_along_axis
    fa, fb = take(m, first[..., None], -1)[..., 0], take(m, first[..., None] + 1, -1)[..., 0]
    return state, xs[first], xs[first + 1], fa, fb, fa >= 0, changes.sum(axis=-1)


SCAN = 9
"""Points of the search range evaluated before root finding (its ends included, one batched run): the first sign
change from the low end is bracketed, so a region that passes only inside the range is found too, if it is wider
than an eighth of the range (a narrower one can fall between two points: narrow the bounds around it)."""
