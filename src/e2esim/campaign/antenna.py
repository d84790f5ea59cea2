"""The gain, the antenna elevation pattern and the pointing as separate parameters of the campaign (issue 25, item 3).

A visit that measures the radiometric gain measures the two-way gain at its own elevation angle. With u the
visit's position across the swath (u = (2 theta - theta_near - theta_far) / (theta_far - theta_near), -1 at the near
edge, +1 at the far edge; the incidence theta stands for the elevation angle, which it determines monotonically),
the error of the gain in dB at u is, to second order in u,

    e(u) = g + u b + (u^2 - 1/3) c,

* g, the gain offset: the swath-mean gain error (dB);
* b, the pointing: an elevation mis-pointing delta moves the two-way pattern G(u) (dB) to G(u - delta), whose
  change -G'(u) delta is linear in u across the swath for a beam that is quadratic in dB about its centre
  (G = -k u^2, so -G' delta = 2 k u delta); b is that change at the far edge (dB);
* c, the pattern: an error in the elevation pattern's curvature (its width), even in u; (u^2 - 1/3) has zero mean
  across the swath, so it does not alias into g (dB at the edge, relative to the mean).

Each is a parameter of the Kalman state with its own drift (``drift.DriftModel``: the pattern and pointing change
with the antenna's thermal state), estimated jointly by the visits (``drift.joint_residual_variance``, visit row
(1, u, u^2 - 1/3)): a transponder seen at several elevation angles separates them; visits at one elevation angle
estimate one combination only. The chain's gain error is that of a pixel anywhere in the swath (u uniform on
[-1, 1]): E[e(u)^2] = Var g + Var b / 3 + (4/45) Var c (E[u] = E[u (u^2 - 1/3)] = E[u^2 - 1/3] = 0, E[u^2] = 1/3,
E[(u^2 - 1/3)^2] = 1/5 - 2/9 + 1/9 = 4/45); the cross-covariances drop out for the same reason.
"""

from __future__ import annotations

import numpy as np

ANTENNA_PARAMETERS = ("gain_offset", "pointing", "pattern")
SWATH_WEIGHTS = (1.0, 1.0 / 3.0, 4.0 / 45.0)
"""E[row(u)_j^2] for u uniform on [-1, 1]: the weights of each parameter's variance in the swath's gain error."""


def swath_position(incidence, near: float, far: float) -> np.ndarray:
    """u of the module docstring (-1 near edge, +1 far edge) of incidences (rad)."""
    return (2.0 * np.asarray(incidence, float) - near - far) / (far - near)


def gain_rows(incidence, near: float, far: float) -> np.ndarray:
    """(n, 3) rows (1, u, u^2 - 1/3) of the visits' gain measurements."""
    u = swath_position(incidence, near, far)
    return np.stack([np.ones_like(u), u, u * u - 1.0 / 3.0], axis=-1)


def swath_gain_variance(parts) -> np.ndarray:
    """The gain error variance of a pixel anywhere in the swath from the variances of (g, b, c): sum of
    ``SWATH_WEIGHTS`` times them (module docstring)."""
    return sum(w * np.asarray(v, float) for w, v in zip(SWATH_WEIGHTS, parts))


__all__ = ["ANTENNA_PARAMETERS", "SWATH_WEIGHTS", "gain_rows", "swath_gain_variance", "swath_position"]
