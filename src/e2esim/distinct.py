"""Distinct rows of a table of integer codes (stage objects, settings, catalog numbers per case).

``np.unique(rows, axis=0)`` sorts the rows as structured records, which is slow for the few distinct rows of a
block of thousands of cases; most blocks have one. ``distinct_rows`` gives the same answer: at once when every
row is the same, otherwise by packing each row into one int64 whose order is the rows' lexicographic order.
"""

from __future__ import annotations

import numpy as np


def distinct_rows(rows) -> tuple:
    """(distinct rows in lexicographic order, index of the first row of each, index into them of every row):
    ``np.unique(rows, axis=0, return_index=True, return_inverse=True)`` of a 2-D integer array (the inverse
    flat)."""
    rows = np.asarray(rows)
    n, k = rows.shape
    if n and (k == 0 or bool((rows == rows[0]).all())):
        return rows[:1], np.zeros(1, dtype=np.int64), np.zeros(n, dtype=np.int64)
    if n and k:
        low = rows.min(0).astype(np.int64)
        spans = rows.max(0).astype(np.int64) - low
        widths = [max(int(s).bit_length(), 1) for s in spans]
        if sum(widths) <= 62:
            key = np.zeros(n, dtype=np.int64)
            for j, width in enumerate(widths):  # the first column the most significant: lexicographic order
                key = (key << width) | (rows[:, j].astype(np.int64) - low[j])
            _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
            return rows[first], first, np.ravel(inverse)
    unique, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
    return unique, first, np.ravel(inverse)


__all__ = ["distinct_rows"]
