"""The saturating backscatter-biomass model of Ahmed, Siqueira & Hensley (2014), eq. (1).

``sigma(M) = beta0 (1 - exp(-beta1 M)) + beta2 M^alpha exp(-beta1 M)``, M the AGB (t/ha), alpha fixed
(0.2 in the paper, "an empirically determined factor"). sigma(0) = 0; for large M sigma tends to the
saturation level beta0.

Shape (derived here, used for the inversion): ``d sigma / dM = exp(-beta1 M) h(M)`` with
``h(M) = beta0 beta1 + beta2 M^(alpha - 1) (alpha - beta1 M)``. For beta2 > 0 and 0 < alpha < 1, h
decreases strictly (``h'(M) = alpha beta2 M^(alpha-2) (alpha - 1 - beta1 M) < 0``) from +inf to -inf, so
sigma rises to a single peak at the root M* of h and then falls back towards beta0 from above: the
model is invertible on [0, M*] only, and backscatter at or above sigma(M*) has no AGB estimate (it is
*saturated*). For beta2 = 0 the model increases to the asymptote beta0 (M* = inf). In practice M* is
often far beyond any forest (sigma(M*) exceeds beta0 by a negligible amount), so a cap ``agb_max`` (the
AGB range the model is trusted over) decides where saturation starts.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.retrieval.models import (
    BELOW_RANGE,
    INVALID,
    INVERTED,
    SATURATED,
    Branch,
    Inversion,
    RetrievalModel,
    bisect_increasing,
    ols_batch,
)

ALPHA_DEFAULT = 0.2
"""Exponent alpha of eq. (1), "fixed to 0.2" (Ahmed et al. 2014, Section II-A)."""

BETA0_MAX = 10.0  # m^2/m^2: a saturation level above +10 dB is not a forest
BETA1_MAX = 1.0  # 1/(t/ha): saturation within ~1 t/ha is not a forest either
"""Physical domain of the fitted coefficients: 0 < beta0 <= BETA0_MAX, 0 < beta1 <= BETA1_MAX. Fits that
run out of it (the degenerate solutions of flat-looking data, beta1 -> inf) count as failed."""
_BETA1_GRID = np.logspace(-5, 0, 61)  # 1/(t/ha): candidate beta1 for the variable-projection start
_PEAK_SEARCH = (1e-9, 1e9)  # t/ha: bracket of the root of h(M) (h > 0 at the left end, < 0 at the right)
_SIGMAS_KEPT = 4096  # sigma values a model keeps for the bisections of one-value inversions (a few hundred kB)
_GRID_AGB = np.concatenate([[0.0], np.logspace(-6, 6, 2401)])  # t/ha: fallback branch search


@dataclass(frozen=True)
class SaturatingModel(RetrievalModel):
    """Eq. (1) of Ahmed et al. (2014). Coefficients ``params = (beta0, beta1, beta2)``.

    beta0 : saturation level (m^2/m^2), > 0. beta1 : rate (1 / (t/ha)), > 0. beta2 : low-AGB scale
    (m^2/m^2 per (t/ha)^alpha). alpha : fixed exponent (not fitted), 0 < alpha.
    """

    beta0: float
    beta1: float
    beta2: float
    alpha: float = ALPHA_DEFAULT

    param_names = ("beta0", "beta1", "beta2")
    default_fit_space = "linear"

    def __post_init__(self):
        if not (self.beta0 > 0 and self.beta1 > 0 and np.isfinite(self.beta2)):
            raise PhysicsInputError(
                f"the saturating model needs beta0 > 0, beta1 > 0 and a finite beta2; got "
                f"({self.beta0}, {self.beta1}, {self.beta2})")
        if not self.alpha > 0:
            raise PhysicsInputError(f"alpha must be > 0, got {self.alpha}")

    @property
    def params(self) -> np.ndarray:
        return np.array([self.beta0, self.beta1, self.beta2], dtype=float)

    def with_params(self, params) -> SaturatingModel:
        b0, b1, b2 = np.asarray(params, dtype=float)
        return SaturatingModel(float(b0), float(b1), float(b2), self.alpha)

    def params_valid(self, params) -> np.ndarray:
        params = np.asarray(params, dtype=float)
        b0, b1 = params[..., 0], params[..., 1]
        return np.all(np.isfinite(params), axis=-1) & (b0 > 0) & (b0 <= BETA0_MAX) & (b1 > 0) & (b1 <= BETA1_MAX)

    # forward model --------------------------------------------------------------------------------------
    def evaluate(self, agb, params=None, **covariates):
        """Eq. (1): beta0 (1 - e^{-beta1 M}) + beta2 M^alpha e^{-beta1 M}."""
        b0, b1, b2 = self._own_split if params is None else _split(params)
        m = np.maximum(np.asarray(agb, dtype=float), 0.0)  # np.clip(x, 0.0, None) is this maximum, a call less
        e = np.exp(-b1 * m)
        return b0 * (1.0 - e) + b2 * m**self.alpha * e

    @cached_property
    def _own_split(self) -> tuple:
        """``_split`` of the model's own coefficients, made once (an inversion evaluates eq. 1 some fifty times)."""
        return _split(self.params)

    def param_jacobian(self, agb, params=None, **covariates):
        """Eq. (5) for eq. (1): (1 - e, M e (beta0 - beta2 M^alpha), M^alpha e), shape (..., n, 3)."""
        b0, b1, b2 = _split(self._params(params))
        m = np.clip(np.asarray(agb, dtype=float), 0.0, None)
        e = np.exp(-b1 * m)
        ma = m**self.alpha
        return np.stack(np.broadcast_arrays(1.0 - e, m * e * (b0 - b2 * ma), ma * e), axis=-1)

    def agb_derivative(self, agb, params=None, **covariates):
        """d sigma / dM = e^{-beta1 M} [beta0 beta1 + beta2 M^(alpha-1) (alpha - beta1 M)]."""
        b0, b1, b2 = _split(self._params(params))
        m = np.clip(np.asarray(agb, dtype=float), 0.0, None)
        e = np.exp(-b1 * m)
        with np.errstate(divide="ignore", invalid="ignore"):
            low = b2 * m ** (self.alpha - 1.0) * (self.alpha - b1 * m)
        if self.alpha < 1:
            at_zero = np.where(b2 == 0, 0.0, np.copysign(np.inf, b2))
        else:
            at_zero = b2 * (self.alpha == 1)
        low = np.where(m > 0, low, at_zero)
        return e * (b0 * b1 + low)

    def _batch_functions(self, agb, covariates):
        """Cached M and M^alpha for the batched solver (the power is the costly part of eq. 1)."""
        m = np.clip(np.asarray(agb, dtype=float), 0.0, None)
        ma = m**self.alpha

        def fun(p, idx):
            mi = m[idx]
            e = np.exp(-p[:, 1:2] * mi)
            return p[:, 0:1] * (1.0 - e) + p[:, 2:3] * ma[idx] * e

        def jac(p, idx):
            mi, mai = m[idx], ma[idx]
            e = np.exp(-p[:, 1:2] * mi)
            out = np.empty(mi.shape + (3,))
            out[..., 0] = 1.0 - e
            out[..., 1] = mi * e * (p[:, 0:1] - p[:, 2:3] * mai)
            out[..., 2] = mai * e
            return out

        return fun, jac

    # branch and inversion --------------------------------------------------------------------------------
    def peak_agb(self) -> float:
        """M* where sigma peaks (t/ha): the root of h(M) (module docstring); +inf if sigma never peaks."""
        return self._peak

    @cached_property
    def _peak(self) -> float:
        """``peak_agb``, searched once per model (every inversion's ``branch`` asks it)."""
        b0, b1, b2, a = self.beta0, self.beta1, self.beta2, self.alpha
        if b2 == 0:
            return np.inf
        if b2 > 0 and a < 1:
            def h(m):
                return b0 * b1 + b2 * m ** (a - 1.0) * (a - b1 * m)
            lo, hi = np.log(_PEAK_SEARCH[0]), np.log(_PEAK_SEARCH[1])
            # h is decreasing in M: bisection on ln M for the sign change (-h is increasing).
            root = bisect_increasing(lambda t: -h(np.exp(t)), 0.0, lo, hi, iterations=200)
            return float(np.exp(root))
        return self._branch_numeric().agb_high

    def branch(self, agb_max: float | None = None) -> Branch:
        """The increasing branch used for inversion, limited to AGB <= agb_max; made once per cap (a threshold's
        bisection inverts some hundred times with the same cap: ``RelativeErrorMap.threshold``)."""
        cap = np.inf if agb_max is None else float(agb_max)
        made = self._branches
        if cap not in made:
            made[cap] = self._branch(cap)
        return made[cap]

    @cached_property
    def _branches(self) -> dict:
        """{cap (t/ha): its ``Branch``}, each made when first asked."""
        return {}

    def _branch(self, cap: float) -> Branch:
        """``branch`` of the cap ``cap`` (t/ha, +inf for none)."""
        if self.beta2 >= 0 and self.alpha < 1:
            low = 0.0
            peak = self.peak_agb()
        else:
            numeric = self._branch_numeric()
            low, peak = numeric.agb_low, numeric.agb_high
        high = min(peak, cap)
        if high <= low:
            raise PhysicsInputError(f"agb_max = {cap:g} t/ha is below the start of the model's increasing branch "
                                    f"({low:g} t/ha)")
        sigma_high = float(self.sigma(high)) if np.isfinite(high) else self.beta0
        notes = ()
        if np.isfinite(peak) and peak <= cap:
            notes = (f"sigma peaks at {peak:.4g} t/ha (sigma = {sigma_high:.4g}) and decreases beyond",)
        return Branch(low, high, float(self.sigma(low)), sigma_high, notes)

    def _branch_numeric(self) -> Branch:
        """Branch from a dense grid: from the minimum of sigma to the first peak after it."""
        s = self.sigma(_GRID_AGB)
        i_low = int(np.argmin(s[: max(np.argmax(s), 1) + 1]))
        rising = np.diff(s[i_low:]) > 0
        falls = np.flatnonzero(~rising)
        i_high = i_low + (int(falls[0]) if falls.size else rising.size)
        high = float(_GRID_AGB[i_high]) if falls.size else np.inf
        return Branch(float(_GRID_AGB[i_low]), high, float(s[i_low]), float(s[i_high]))

    def invert(self, sigma, agb_max: float | None = None, **covariates) -> Inversion:
        """AGB from sigma on the increasing branch (numerical: eq. 1 has no closed-form inverse).

        sigma <= sigma(branch start) (0 for beta2 >= 0): below range, AGB = branch start. sigma >= the
        largest value on the branch below ``agb_max``: saturated, AGB = agb_max (+inf without a cap).
        """
        s = np.asarray(sigma, dtype=float)
        br = self.branch(agb_max)
        cap = np.inf if agb_max is None else float(agb_max)
        finite = np.isfinite(s)
        below = finite & (s <= br.sigma_low)
        sat = finite & (s >= br.sigma_high)
        inside = finite & ~below & ~sat
        agb = np.full(s.shape, np.nan)
        agb = np.where(below, br.agb_low, agb)
        agb = np.where(sat, cap, agb)
        if np.any(inside):
            target = s[inside]
            if np.isinf(br.agb_high):  # beta2 = 0: closed form
                agb[inside] = -np.log1p(-target / self.beta0) / self.beta1
            else:
                func = self._sigma_kept if target.size == 1 else self.sigma
                agb[inside] = bisect_increasing(func, target, br.agb_low, br.agb_high)
        status = np.select([~finite, below, sat], [INVALID, BELOW_RANGE, SATURATED], INVERTED).astype(np.int8)
        return Inversion(agb, status, br.sigma_high, cap)

    def _sigma_kept(self, agb: np.ndarray) -> np.ndarray:
        """``sigma`` at an array of one AGB, each value computed once per model (the last ``_SIGMAS_KEPT`` kept): a
        threshold's bisection (``RelativeErrorMap.threshold``) inverts some hundred nearby values, and one value's
        bisection steps through the midpoints of the others' up to where their targets part."""
        kept, key = self._sigmas, agb.tobytes()
        if key not in kept:
            if len(kept) >= _SIGMAS_KEPT:
                kept.clear()
            kept[key] = self.sigma(agb)
        return kept[key]

    @cached_property
    def _sigmas(self) -> dict:
        """{the bytes of an array of one AGB: its ``sigma``} (``_sigma_kept``)."""
        return {}

    # fitting ---------------------------------------------------------------------------------------------
    def initial_guess(self, agb, sigma, **covariates):
        """Variable projection: for each beta1 on a grid the model is linear in (beta0, beta2); the beta1
        with the smallest residual (and beta0 > 0) gives the start. Shape (..., 3)."""
        one = np.ndim(agb) == 1
        agb = np.atleast_2d(np.clip(np.asarray(agb, dtype=float), 0.0, None))
        sigma = np.atleast_2d(np.asarray(sigma, dtype=float))
        nb, n = agb.shape
        g = _BETA1_GRID.size
        e = np.exp(-_BETA1_GRID[None, :, None] * agb[:, None, :])  # (B, G, n)
        design = np.stack([1.0 - e, agb[:, None, :] ** self.alpha * e], axis=-1).reshape(nb * g, n, 2)
        y = np.broadcast_to(sigma[:, None, :], (nb, g, n)).reshape(nb * g, n)
        coef, ssr, ok = ols_batch(design, np.nan_to_num(y))
        coef = coef.reshape(nb, g, 2)
        ssr = np.where((ok & (coef.reshape(nb * g, 2)[:, 0] > 0)).reshape(nb, g), ssr.reshape(nb, g), np.inf)
        best = np.argmin(ssr, axis=1)
        rows = np.arange(nb)
        guess = np.stack([coef[rows, best, 0], _BETA1_GRID[best], coef[rows, best, 1]], axis=-1)
        fallback = ~np.isfinite(ssr[rows, best])
        guess[fallback] = self.params
        return guess[0] if one else guess


def _split(params):
    params = np.asarray(params, dtype=float)
    return params[..., None, 0], params[..., None, 1], params[..., None, 2]
