"""Where the analytic error models hold: their mean, variance and Gaussian 99.865 % quantiles against the exact
Monte Carlo of the same system model, level by level (docs/theory/validity.md).

The comparison isolates what the analytic models approximate: the system errors and Faraday rotation, no noise
and L -> infinity (the estimated powers are then q = diag(A C A^H) per realisation, multiplied out exactly,
``expansion.estimator_entries`` and ``stack.montecarlo.pass_operators``; noise and finite looks add near-Gaussian
terms that the models carry exactly and that only make the errors more Gaussian). For every model, case and
direction in the (crosstalk, channel imbalance) plane, the departures at each level, per channel:

* mean: |E_an - E_mc| / RMS_mc (the RMS error sqrt(E^2 + Var), so a mean near zero is not divided by itself);
* variance: Var_an / Var_mc - 1;
* quantiles: (q_an - q_mc) / h_mc at 0.135 % and 99.865 %, q_an = E_an -+ 3 SD_an (the Gaussian quantile of
  Men et al. 2021, eq. 19) and h_mc = (q_mc(99.865 %) - q_mc(0.135 %)) / 2 the Monte Carlo's half-width, so the
  departure is a fraction of the spread the requirement tests, whatever the bias.

A level holds when no departure exceeds ``TOLERANCE`` by more than ``EDGE_Z`` of its standard errors (the
sampling error of the Monte Carlo, 0.3-3 % here, must not make an exact model fail).
"""

from __future__ import annotations

from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from e2esim.distortion.expansion import estimator_entries
from e2esim.distortion.faraday_correction import FaradayCorrection
from e2esim.stack.montecarlo import pass_operators
from e2esim.units import THREE_SIGMA_AMPLITUDE, variance_from_level_db

TOLERANCE = 0.05
"""Largest departure of an analytic mean, variance or quantile from the exact Monte Carlo that still counts as
agreement (5 %), in the units of ``departures``."""
EDGE_Z = 1.0
"""A departure counts when it exceeds ``TOLERANCE`` by more than this many standard errors."""
CONFIDENCE = 0.99865
"""The one-sided confidence of the BIOMASS requirement (z = 3), at which the quantiles are compared."""
DIRECTIONS = {
    "equal": (0.0, 0.0),
    "specification": (0.0, -4.0),
    "crosstalk": (0.0, None),
    "imbalance": (None, 0.0),
}
"""Directions in the plane of the levels: offsets (dB) of the crosstalk and channel-imbalance levels from the
level scanned, None for an absent term. ``specification``: the imbalance 4 dB below the crosstalk, as the BIOMASS
specification (-30 dB and -34 dB) and Men et al. (2021), Figs. 9-10."""
CHECKS = ("mean", "variance", "quantile")


@dataclass(frozen=True)
class Departures:
    """Departures of one level (``departures``): values (C,) per channel and their standard errors."""

    mean: np.ndarray
    variance: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    mean_se: np.ndarray
    variance_se: np.ndarray
    lower_se: np.ndarray
    upper_se: np.ndarray

    def fails(self, check: str, tolerance: float = TOLERANCE, z: float = EDGE_Z) -> np.ndarray:
        """Per channel: is the departure beyond ``tolerance`` by more than ``z`` standard errors?"""
        if check == "quantile":
            return (self._beyond(self.lower, self.lower_se, tolerance, z)
                    | self._beyond(self.upper, self.upper_se, tolerance, z))
        return self._beyond(getattr(self, check), getattr(self, f"{check}_se"), tolerance, z)

    def record(self) -> dict:
        """Every departure and standard error per channel, as lists (for a JSON file)."""
        return {name: np.asarray(getattr(self, name)).tolist() for name in self.__dataclass_fields__}

    def worst(self, check: str) -> float:
        """The largest departure of ``check`` over the channels (signed: its sign says which way)."""
        values = np.concatenate([self.lower, self.upper]) if check == "quantile" else getattr(self, check)
        return float(values[np.argmax(np.abs(values))])

    @staticmethod
    def _beyond(value, se, tolerance, z):
        return np.abs(value) - z * se > tolerance


def departures(errors: np.ndarray, mean, variance, confidence: float = CONFIDENCE) -> Departures:
    """Departures of analytic moments ``mean``, ``variance`` (C,) from simulated errors (M, C) (module docstring);
    standard errors by the delta method (mean, variance) and from the order statistics (quantiles)."""
    e = np.asarray(errors, float)
    m = e.shape[0]
    mc_mean, mc_var = e.mean(0), e.var(0, ddof=1)
    rms = np.sqrt(mc_var + mc_mean**2)
    kurt = np.mean((e - mc_mean) ** 4, 0) / mc_var**2
    z = NormalDist().inv_cdf(confidence)
    probs = np.array([1 - confidence, confidence])
    ordered = np.sort(e, axis=0)
    q = _order_quantiles(ordered, probs)  # (2, C)
    half = (q[1] - q[0]) / 2
    sd = np.sqrt(np.clip(variance, 0.0, None))
    analytic = np.stack([mean - z * sd, mean + z * sd])
    # SE of a sample quantile: sqrt(p (1 - p) / M) / density, the density from the spacing of nearby quantiles
    step = max(20.0 / m, 1e-4)
    spacing = (_order_quantiles(ordered, probs + step) - _order_quantiles(ordered, probs - step)) / (2 * step)
    q_se = np.sqrt(probs * (1 - probs) / m)[:, None] * spacing
    dq = (analytic - q) / half
    return Departures(
        mean=(mean - mc_mean) / rms, variance=variance / mc_var - 1.0, lower=dq[0], upper=dq[1],
        mean_se=np.sqrt(mc_var / m) / rms, variance_se=np.abs(variance / mc_var) * np.sqrt((kurt - 1) / m),
        lower_se=q_se[0] / half, upper_se=q_se[1] / half)


def _order_quantiles(ordered: np.ndarray, probs: np.ndarray) -> np.ndarray:
    """Quantiles (P, C) of sorted samples (M, C), interpolated linearly between order statistics (numpy's
    default ``np.quantile`` rule)."""
    pos = np.asarray(probs) * (ordered.shape[0] - 1)
    lo = np.floor(pos).astype(int)
    frac = (pos - lo)[:, None]
    return ordered[lo] * (1 - frac) + ordered[np.minimum(lo + 1, ordered.shape[0] - 1)] * frac


def direction_levels(level_db, direction: str) -> tuple:
    """(V_delta, V_eps): the variances of a level (dB, 3-sigma amplitude label) along a direction."""
    offsets = DIRECTIONS[direction]
    return tuple(0.0 if off is None else float(variance_from_level_db(level_db + off, THREE_SIGMA_AMPLITUDE))
                 for off in offsets)


def single_pass_errors(scene, system, faraday, rng: np.random.Generator, realisations: int,
                       correction: FaradayCorrection | None = None) -> np.ndarray:
    """Exact errors (M, 3) of (sigma_hh, sigma_hv, sigma_vv) under the full model of Men et al. (2021), eq. (1),
    without noise and for L -> infinity: q = diag(A C A^H) - diag(C), A multiplied out per realisation."""
    correction = correction or FaradayCorrection()
    errs = system.sample(rng, realisations)
    omega = faraday.sample(rng, realisations)
    a = estimator_entries(errs.delta, errs.f, omega, correction.estimate(rng, omega), errs.gain)  # (3, 3, M)
    c = np.asarray(scene.matrix)
    power = np.real(np.einsum("pcm,cd,pdm->mp", a, c, a.conj()))
    return power - np.real(np.diag(c))


def stack_errors(scene, errors, faraday, combination, rng: np.random.Generator, realisations: int,
                 correct_copol: bool = True) -> np.ndarray:
    """Exact errors (M, 3) of a multi-pass estimate (``stack.montecarlo``) without noise, L -> infinity: the
    combined signal covariance sum_r c_r sum_nm w_rn w_rm^* A_n C_nm A_m^H against its error-free value."""
    n = scene.passes
    delta, f, gain = errors.sample(rng, realisations, n)
    omega = faraday.sample(rng, realisations, n)
    a = pass_operators(delta, f, omega, gain, correct_copol)  # (M, N, 3, 3)
    blocks = np.asarray(scene.matrix).reshape(n, 3, n, 3).transpose(0, 2, 1, 3)  # C_nm
    cw = combination.weights
    weights = np.einsum("r,rn,rm->nm", combination.coefficients, cw, cw.conj())
    signal = np.einsum("nm,xnpc,nmcd,xmqd->xpq", weights, a, blocks, a.conj(), optimize=True)
    ideal = np.einsum("nm,nmpq->pq", weights, blocks)
    return np.real(np.diagonal(signal, axis1=-2, axis2=-1)) - np.real(np.diag(ideal))
