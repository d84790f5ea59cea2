"""An orbit as Earth-fixed position and velocity at any UTC instant of its span.

``StateVectorTrajectory`` interpolates state vectors (from an EO CFI file or a NISAR orbit group) with Hermite
polynomials on ``HERMITE_POINTS`` neighbouring vectors, matching position and velocity at each of them: degree
2 N - 1 = 7 for N = 4, as isce3's ``isce3::core::Orbit`` (``OrbitInterpMethod::Hermite``, 4 points) and the EO
CFI ``xo_osv_compute`` interpolation of restituted orbits do. Hermite interpolation (Stoer & Bulirsch,
Introduction to Numerical Analysis, Section 2.1.5, eq. 2.1.5.5 for the basis and Theorem 2.1.5.9 for the error):

    p(t) = sum_j [ (1 - 2 (t - t_j) l_j'(t_j)) l_j(t)^2 x_j  +  (t - t_j) l_j(t)^2 v_j ],

``l_j`` the Lagrange basis polynomials of the N nodes; the error is ``x^(2N)(xi) / (2N)! prod_j (t - t_j)^2``,
below ``r (n h)^8 / 1.3e5`` for an orbit of radius r, mean motion n and vector spacing h: under 1 mm at h = 60 s
and about 2 m at the largest spacing accepted, ``MAX_STATE_VECTOR_STEP_S`` = 600 s (low Earth orbit). The
velocity is the derivative of the same polynomial.

Times are seconds of UTC since ``epoch`` (numpy datetime64[ns]); a leap second inside a file's span is not
modelled (it shifts the later vectors by 1 s, 7 km along track: no EO CFI or NISAR file of a few days contains
one in 2025-2026, none having been announced).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError

HERMITE_POINTS = 4
"""State vectors each interpolation uses (isce3's Hermite default): degree 7 in time."""

MAX_STATE_VECTOR_STEP_S = 600.0
"""Largest spacing of state vectors interpolated (s): Hermite error about 2 m in low Earth orbit (module
docstring). Predicted-orbit files with one vector per orbit need a propagator, which e2esim does not have."""


@dataclass(frozen=True)
class Trajectory:
    """An Earth-fixed orbit over a span of UTC. ``source`` names the file, ``kind`` the format ("EO CFI state
    vectors", "NISAR orbit", "TLE"), ``start_s``/``end_s`` the span (s since ``epoch``)."""

    source: str
    kind: str
    epoch: np.datetime64
    start_s: float
    end_s: float

    def state(self, t_s):
        """Earth-fixed position (m) and Earth-relative velocity (m/s), shape ``t.shape + (3,)``, at ``t_s``
        (s since ``epoch``)."""
        raise NotImplementedError

    def seconds(self, when) -> np.ndarray:
        """Seconds since ``epoch`` of datetime64 instants."""
        return (np.asarray(when, "datetime64[ns]") - self.epoch) / np.timedelta64(1, "s")

    def instant(self, t_s) -> np.ndarray:
        """datetime64[ns] of seconds since ``epoch``."""
        return self.epoch + np.round(np.asarray(t_s, float) * 1e9).astype("int64").astype("timedelta64[ns]")

    def span_text(self) -> str:
        a, b = (str(np.datetime_as_string(self.instant(t), unit="s")) for t in (self.start_s, self.end_s))
        return f"{a} to {b} UTC"


@dataclass(frozen=True)
class StateVectorTrajectory(Trajectory):
    """State vectors (times ``t_s`` strictly increasing, positions ``position`` (n, 3) m, velocities ``velocity``
    (n, 3) m/s, Earth-fixed) interpolated by ``hermite`` (module docstring)."""

    t_s: np.ndarray = None
    position: np.ndarray = None
    velocity: np.ndarray = None

    def state(self, t_s):
        return hermite(self.t_s, self.position, self.velocity, t_s)


def check_state_vectors(source: str, t_s, position, velocity, where: str = "state vector") -> None:
    """Refuse state vectors an interpolation cannot use: fewer than ``HERMITE_POINTS``, times not strictly
    increasing, gaps over ``MAX_STATE_VECTOR_STEP_S``, positions off any Earth orbit."""
    t = np.asarray(t_s, float)
    if t.size < HERMITE_POINTS:
        raise PhysicsInputError(f"{source}: {t.size} {where}s; Hermite interpolation needs at least {HERMITE_POINTS}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
        raise PhysicsInputError(f"{source}: a {where} holds a value that is not a finite number")
    step = np.diff(t)
    if np.any(step <= 0):
        i = int(np.argmax(step <= 0)) + 1
        raise PhysicsInputError(f"{source}: {where} {i} is not later than {where} {i - 1} (times must increase)")
    if np.any(step > MAX_STATE_VECTOR_STEP_S):
        i = int(np.argmax(step > MAX_STATE_VECTOR_STEP_S)) + 1
        raise PhysicsInputError(f"{source}: {step[i - 1]:g} s between {where}s {i - 1} and {i}; at most "
                                f"{MAX_STATE_VECTOR_STEP_S:g} s are interpolated (a predicted orbit with one vector "
                                "per orbit needs a propagator)")
    radius = np.linalg.norm(position, axis=-1)
    speed = np.linalg.norm(velocity, axis=-1)
    for name, value, low, high, unit in (("position radius", radius, 6.4e6, 5e7, "m"),
                                         ("velocity", speed, 1e3, 1.2e4, "m/s")):
        bad = (value < low) | (value > high)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise PhysicsInputError(f"{source}: {where} {i} has a {name} of {value[i]:.6g} {unit}; an Earth orbit has "
                                    f"{low:g} to {high:g} {unit} (positions in m and velocities in m/s, Earth-fixed)")


def hermite(nodes_t, x, v, t):
    """Hermite interpolation of positions ``x`` and velocities ``v`` (n, 3) given at increasing ``nodes_t`` (n,),
    on the ``HERMITE_POINTS`` nodes around each of ``t`` (any shape): (position, velocity), ``t.shape + (3,)``."""
    t = np.asarray(t, float)
    flat = t.reshape(-1)
    n = len(nodes_t)
    first = np.clip(np.searchsorted(nodes_t, flat) - HERMITE_POINTS // 2, 0, n - HERMITE_POINTS)
    idx = first[:, None] + np.arange(HERMITE_POINTS)  # (m, N)
    tj = nodes_t[idx]
    dt = flat[:, None] - tj  # (m, N): t - t_j
    pos = np.zeros(flat.shape + (3,))
    vel = np.zeros(flat.shape + (3,))
    for j in range(HERMITE_POINTS):
        others = [m for m in range(HERMITE_POINTS) if m != j]
        denom = [tj[:, j] - tj[:, m] for m in others]
        lj = np.prod([dt[:, m] / d for m, d in zip(others, denom)], axis=0)
        dlj = sum(np.prod([dt[:, k] / (tj[:, j] - tj[:, k]) for k in others if k != m], axis=0) / d
                  for m, d in zip(others, denom))  # l_j'(t) by the product rule
        cj = sum(1.0 / d for d in denom)  # l_j'(t_j)
        a = 1.0 - 2.0 * dt[:, j] * cj
        xj, vj = x[idx[:, j]], v[idx[:, j]]
        pos += (a * lj**2)[:, None] * xj + (dt[:, j] * lj**2)[:, None] * vj
        da = -2.0 * cj * lj**2 + a * 2.0 * lj * dlj
        db = lj**2 + dt[:, j] * 2.0 * lj * dlj
        vel += da[:, None] * xj + db[:, None] * vj
    return pos.reshape(t.shape + (3,)), vel.reshape(t.shape + (3,))
