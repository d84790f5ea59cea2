"""How an estimator combines the passes of a stack: single date, multi-date average, ground cancellation.

Every estimator of this module is a sum of squared linear combinations of the passes' images of one channel,

    sigma_hat = sum_r c_r |sum_n w_rn I_n|^2 = y^H Q y,  Q = sum_r c_r w_r^* w_r^T    (ground-cancellation.md, eq. 5)

with y = (I_1, ..., I_N) the N images of the channel at one pixel (averaged over the looks afterwards):

* single date: w = e_d, one pass;
* multi-date average without cancellation: w_r = e_r, c_r = 1/N;
* ground cancellation (BIOMASS Processing Suite AGB ATBD, Section 3.4; Mariotti d'Alessandro et al. 2020):
  two images, I_GN = I_1 - I_2 (ATBD eq. 3.4); three or more, for each reference image r the image at
  k_z0 = pi / z_0 (z_0 the emphasised height, eq. 3.5) is interpolated linearly along k_z between the two
  nearest passes after demodulation by exp(-j k_z z_0 / 2) and re-modulated (eqs. 3.6-3.8), and subtracted from
  the reference (eq. 3.9); k_z is relative to the reference and +-k_z0 is taken whichever the stack brackets
  (the narrower bracket when both); |I_GN|^2 is averaged over the references that need no extrapolation
  (multi-reference, eqs. 3.11-3.12). The weights of reference r are therefore
  w_r = e_r - (1 - t) e^{j (k0 - k_a) z0/2} e_a - t e^{j (k0 - k_b) z0/2} e_b, t = (k0 - k_a)/(k_b - k_a).

The estimator's expected value for a stack covariance is sum_mn Q_mn C_nm; the combined 3x3 covariance
sum_r c_r sum_mn w_rn w_rm^* C_nm is the ground-cancelled (hh, hv, vv) covariance a multi-channel estimator reads.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from e2esim.errors import PhysicsInputError

ESTIMATORS = ("single_date", "multi_date", "ground_cancelled")
CANCELLATIONS = ("interpolated", "subtraction")
BPS_EMPHASISED_HEIGHT_M = 30.0
"""z_0 of the operational processor (BPS AGB ATBD Section 3.4.2, ``emphasizedForestHeight``)."""


@dataclass(frozen=True, eq=False)
class PassCombination:
    """sigma_hat = sum_r c_r |w_r . y|^2 (eq. 5).

    weights : (R, N) complex linear combinations w_r. coefficients : (R,) positive c_r. kind : one of
    ``ESTIMATORS``. label : e.g. "ground cancelled, z0 = 30 m, references 1, 3".
    """

    weights: np.ndarray
    coefficients: np.ndarray
    kind: str
    label: str = ""

    def __post_init__(self):
        w = np.atleast_2d(np.asarray(self.weights, complex))
        c = np.atleast_1d(np.asarray(self.coefficients, float))
        if c.shape != (w.shape[0],) or np.any(c <= 0):
            raise PhysicsInputError(f"need one positive coefficient per combination, got {c} for {w.shape[0]}")
        w.setflags(write=False)
        c.setflags(write=False)
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "coefficients", c)

    @property
    def passes(self) -> int:
        return self.weights.shape[1]

    @functools.cached_property
    def matrix(self) -> np.ndarray:
        """Q = sum_r c_r w_r^* w_r^T (N x N, Hermitian PSD): sigma_hat = y^H Q y. Computed once (read only): the
        analytic moments read it at every evaluation of a margin's or trade-off curve's root finding."""
        w = self.weights
        q = np.einsum("r,rm,rn->mn", self.coefficients, w.conj(), w)
        q.setflags(write=False)
        return q

    @property
    def noise_gain(self) -> float:
        """tr Q: the noise power of the estimate per unit noise power in each pass's image."""
        return float(np.real(np.trace(self.matrix)))

    @property
    def noise_diversity(self) -> float:
        """(tr Q)^2 / tr Q^2: independent noise samples the estimate averages (N for the average, 1 for one
        combination)."""
        q = self.matrix
        return float(np.real(np.trace(q)) ** 2 / np.real(np.trace(q @ q)))

    @functools.cached_property
    def traces(self) -> tuple[float, float]:
        """(tr Q, tr Q^2), real parts: the noise terms of the analytic moments read them at every evaluation of a
        root finding's step, so they are derived once."""
        q = self.matrix
        return float(np.real(np.trace(q))), float(np.real(np.trace(q @ q)))

    def value(self, channel_matrix: np.ndarray) -> float:
        """tr(Q Y) for the N x N covariance Y of one channel across the passes (Y_nm = <I_n I_m*>)."""
        return float(np.real(np.trace(self.matrix @ np.asarray(channel_matrix))))

    def speckle_diversity(self, channel_matrix: np.ndarray) -> float:
        """(tr QY)^2 / tr(QYQY): the equivalent number of independent speckle samples of the estimate (1 for one
        image, N^2 / sum |gamma_mn|^2 for the average of N images with inter-pass coherences gamma_mn;
        ground-cancellation.md, eq. 17). It replaces the speckle-identical assumption of repeat passes."""
        q, y = self.matrix, np.asarray(channel_matrix)
        qy = q @ y
        return float(np.real(np.trace(qy)) ** 2 / np.real(np.trace(qy @ qy)))

    def combined_covariance(self, blocks: np.ndarray) -> np.ndarray:
        """sum_r c_r sum_mn w_rn w_rm^* C_nm: the combined (hh, hv, vv) covariance from the (N, N, 3, 3) blocks
        C_nm = <s_n s_m^H> (for ground cancellation, the ground-cancelled covariance)."""
        return np.einsum("r,rn,rm,nmij->ij", self.coefficients, self.weights, self.weights.conj(), blocks)


def single_date(passes: int, date: int = 0) -> PassCombination:
    """The image of one pass (0-based index ``date``)."""
    if not 0 <= date < passes:
        raise PhysicsInputError(f"date index {date} is outside the stack of {passes} passes")
    return PassCombination(np.eye(passes)[[date]], [1.0], "single_date", f"single date (pass {date + 1})")


def multi_date(passes: int) -> PassCombination:
    """The average of the N single-date intensities (no cancellation)."""
    return PassCombination(np.eye(passes), np.full(passes, 1.0 / passes), "multi_date",
                           f"average of {passes} dates without cancellation")


def subtraction(passes: int, first: int = 0, second: int = 1) -> PassCombination:
    """I_GN = I_a - I_b (BPS AGB ATBD eq. 3.4)."""
    if first == second or not (0 <= first < passes and 0 <= second < passes):
        raise PhysicsInputError(f"subtraction needs two different passes of {passes}, got {first + 1}, {second + 1}")
    w = np.zeros((1, passes))
    w[0, first], w[0, second] = 1.0, -1.0
    return PassCombination(w, [1.0], "ground_cancelled", f"ground cancelled: pass {first + 1} - pass {second + 1}")


def interpolated(kz_rad_m, emphasised_height_m: float = BPS_EMPHASISED_HEIGHT_M) -> PassCombination:
    """Multi-reference interpolated ground cancellation at k_z0 = pi / z_0 (BPS AGB ATBD eqs. 3.5-3.12)."""
    kz = np.asarray(kz_rad_m, float)
    n = kz.size
    z0 = float(emphasised_height_m)
    if n < 2 or z0 <= 0:
        raise PhysicsInputError(f"interpolated ground cancellation needs 2 or more passes and z0 > 0, got {n}, {z0}")
    k0 = np.pi / z0
    rows, refs = [], []
    for ref in range(n):
        rel = kz - kz[ref]
        best = None
        for sign in (1.0, -1.0):
            target = sign * k0
            below = [i for i in range(n) if rel[i] <= target]
            above = [i for i in range(n) if rel[i] >= target]
            if not below or not above:
                continue  # would need extrapolation
            a = max(below, key=lambda i: rel[i])
            b = min(above, key=lambda i: rel[i])
            span = rel[b] - rel[a]
            if best is None or span < best[0]:
                best = (span, target, a, b)
        if best is None:
            continue
        span, target, a, b = best
        t = 0.0 if span == 0 else (target - rel[a]) / span
        w = np.zeros(n, complex)
        w[ref] += 1.0
        w[a] -= (1 - t) * np.exp(1j * (target - rel[a]) * z0 / 2)
        w[b] -= t * np.exp(1j * (target - rel[b]) * z0 / 2)
        rows.append(w)
        refs.append(ref + 1)
    if not rows:
        raise PhysicsInputError(f"no reference pass brackets k_z0 = pi/z0 = {k0:.4f} rad/m within the stack's k_z "
                                f"{np.round(kz, 4).tolist()} rad/m: lower z0 or widen the baselines")
    return PassCombination(np.array(rows), np.full(len(rows), 1.0 / len(rows)), "ground_cancelled",
                           f"ground cancelled at z0 = {z0:g} m (references {', '.join(map(str, refs))})")
