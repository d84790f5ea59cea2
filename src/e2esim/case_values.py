"""A value of a case alone or of a block of cases, as the stages hand it out.

A stage evaluates a case alone (0-d numbers) or a block of cases (arrays with a leading case axis) with the
same arithmetic; what it hands out is a float for the one and the array for the other (``plain``).
"""

from __future__ import annotations

import numpy as np


def plain(x):
    """A float for one case (a 0-d value), else the array of floats over the cases of a block."""
    return float(x) if np.ndim(x) == 0 else np.asarray(x, dtype=float)


__all__ = ["plain"]
