"""Trade-off between crosstalk and channel imbalance: Men et al. (2021), eq. (19) and Appendix B.

A requirement "the relative AGB error stays below ``bound`` (side "over") or above ``-bound`` (side
"under") with one-sided confidence ``confidence``" holds when (eq. 19, sign-adjusted)

    over:  b + z sigma_e <= f_max sigma_hv        under:  b - z sigma_e >= f_min sigma_hv

with ``z = Phi^-1(confidence)``, ``f_max``/``f_min`` from eq. (16), b and sigma_e the mean and SD of the
sigma_hv error. The trade-off curve is where equality holds, in the plane of crosstalk level V_delta and
channel-imbalance level V_eps (variances; plotted in dB with a stated convention).

Two ways to trace it, cross-checked in the tests:

* ``tradeoff_curve``: vectorised root finding on an error model's moments (``e2esim.error_model``: any
  propagation module, any form, gain error and finite looks included);
* ``ConicTradeoff``: the closed form of Appendix B for the paper form, where b is linear and
  sigma_e^2 quadratic in (V_eps, V_delta), so the curve is a conic (eqs. B2-B7).

The same root finding (``e2esim.requirements.level_search``) gives the level at which a requirement starts to fail
for any level an error model has (``first_failing_level``): the margins of the requirement modules.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from operator import attrgetter

import numpy as np

from e2esim.case_values import plain
from e2esim.distortion.analytic import hv_error_moments  # the closed form of Appendix B is for this model
from e2esim.errors import PhysicsInputError
from e2esim.requirements.level_search import (  # noqa: F401  (re-exported: the search belongs to the interface)
    LEVEL_SEARCH_RANGE,
    first_failing_level,
    first_failing_levels,
)
from e2esim.retrieval.agb_error import standard_normal_quantile
from e2esim.retrieval.power_law import sigma_relative_error

SIDES = ("over", "under")


@dataclass(frozen=True)
class AGBRequirement:
    """One-sided bound on the relative AGB error: P(q > bound) <= 1 - confidence ("over") or
    P(q < -bound) <= 1 - confidence ("under"). bound and confidence are fractions (0.2, 0.99865).

    exponent : power-law exponent p (eq. 16). relative_threshold : the relative sigma_hv error at the bound
        when the retrieval model is not a power law (from its ``RelativeErrorMap``); None: eq. (16).
    extra_variance : variance (m^2/m^2)^2 added to the systematic error's, from the random-error budget and
        the regression uncertainty (they do not depend on the system-error levels).
    """

    bound: float
    confidence: float
    side: str
    exponent: float
    relative_threshold: float | None = None
    extra_variance: float = 0.0

    def __post_init__(self):
        if self.side not in SIDES:
            raise PhysicsInputError(f"side must be one of {SIDES}, got {self.side!r}")
        if not (0 < self.bound < 1 or (self.side == "over" and self.bound > 0)):
            raise PhysicsInputError("bound must be > 0 (and < 1 for underestimation)")
        if not 0.5 < self.confidence < 1:
            raise PhysicsInputError("confidence must be between 0.5 and 1")

    @property
    def z(self) -> float:
        """Standardised error z_alpha of eq. (19), > 0 (3.00 for 99.865 %)."""
        return float(standard_normal_quantile(self.confidence))

    @property
    def f(self):
        """f_max (> 0) or f_min (< 0): relative sigma_hv error at the AGB bound, eq. (16) (an array over cases
        when the exponent is one)."""
        if self.relative_threshold is not None:
            return plain(self.relative_threshold)
        level = self.bound if self.side == "over" else -self.bound
        return plain(sigma_relative_error(level, self.exponent))

    def violation(self, mean, sd, sigma_hv):
        """Signed distance from the limit of eq. (19) (m^2/m^2): <= 0 passes, > 0 fails. ``mean`` and ``sd`` have
        the shape of the levels; ``sigma_hv``, the exponent and the extra variance are per case (shape C, aligned
        on the leading axes)."""
        mean, sd = np.asarray(mean), np.asarray(sd)
        extra = _aligned(self.extra_variance, sd)
        sd = np.where(extra != 0, np.sqrt(sd**2 + extra), sd)
        f_sigma = _aligned(self.f, mean) * _aligned(sigma_hv, mean)
        if self.side == "over":
            return mean + self.z * sd - f_sigma
        return f_sigma - (mean - self.z * sd)


def _aligned(x, like):
    """``x`` (per case, shape C) with trailing length-1 axes to broadcast against ``like`` (shape C + levels)."""
    x = np.asarray(x, dtype=float)
    return x.reshape(x.shape + (1,) * (np.ndim(like) - x.ndim)) if x.ndim and np.ndim(like) > x.ndim else x



@dataclass(frozen=True)
class AGBBound:
    """A requirement module's one-sided bound, asked of the AGB error it checks: ``AGBError.bound_violation`` at
    the error model's changed levels (eq. 19 with every source the AGB error holds). What the margins and
    trade-off curves of the requirement modules solve, and what the verdict's exceedance probabilities ask.
    memo : the run's ``KernelMemo`` (``case.services.memo``), which keeps a retrieval map's threshold for the other
    requirements and cases with the same map and level; None: the threshold is derived here."""

    agb: object
    bound: float
    confidence: float
    side: str
    memo: object = field(default=None, compare=False, repr=False)

    @property
    def model(self):
        return self.agb.error_model

    @cached_property
    def relative_threshold(self):
        """f of eq. (19), the relative sigma_hv error at the side's level (``AGBError.sigma_threshold``: eq. 16, or
        a bisection of the retrieval model's map), derived once for every level the margins and curves ask."""
        return self.agb.sigma_threshold(self.bound if self.side == "over" else -self.bound, self.memo)

    moments_source = property(attrgetter("agb"))
    """What ``moments_at`` asks: bounds with the same source share its evaluations (``first_failing_levels``)."""

    def moments_at(self, **levels):
        return self.agb.moments_under(**levels)

    def violation_of(self, moments):
        """The violation from ``moments_at``'s answer at the levels (the same numbers as ``violation_at``)."""
        return self.agb.bound_violation_of(moments, self.bound, self.confidence, self.side, self.relative_threshold)

    def violation_at(self, **levels):
        return self.violation_of(self.moments_at(**levels))


@dataclass(frozen=True)
class ModelBound:
    """An ``AGBRequirement`` asked of an error model alone (stand-alone trade-off studies, the verification)."""

    requirement: AGBRequirement
    model: object

    side = property(lambda self: self.requirement.side)
    moments_source = property(attrgetter("model"))
    violation_at = AGBBound.violation_at

    def moments_at(self, **levels):
        return self.model.moments(**levels)

    def violation_of(self, moments):
        return self.requirement.violation(moments.mean, moments.sd, self.model.value)


TRADEOFF_LEVELS = ("crosstalk", "channel_imbalance")
"""The plane of the trade-off curve: levels an error model must have for it."""


def tradeoff_curve(requirement: AGBRequirement, model, crosstalk_levels) -> np.ndarray:
    """``bound_tradeoff_curve`` of ``requirement`` on the error model alone."""
    return bound_tradeoff_curve(ModelBound(requirement, model), crosstalk_levels)


def bound_tradeoff_curve(bound, crosstalk_levels) -> np.ndarray:
    """Channel-imbalance level V_eps on the trade-off curve for each crosstalk level V_delta.

    By root finding on ``bound.violation_at`` (``first_failing_level``): V_eps is the largest
    channel-imbalance variance that still meets the requirement. NaN where the crosstalk level alone
    already breaks it; +inf where no channel-imbalance level up to 1 does.
    """
    return bound_tradeoff_curves([bound], crosstalk_levels)[0]


def bound_tradeoff_curves(bounds, crosstalk_levels) -> list:
    """``bound_tradeoff_curve`` of each of ``bounds`` (of one error model), the scan shared
    (``first_failing_levels``)."""
    x = np.atleast_1d(np.asarray(crosstalk_levels, dtype=float))
    cases = np.shape(bounds[0].model.value)  # () for one case, (B,) for a block
    levels = x.reshape((1,) * len(cases) + x.shape + (1,))
    return first_failing_levels(bounds, lambda v_eps: {"crosstalk": levels, "channel_imbalance": v_eps},
                                cases + x.shape)


def axis_limits(requirement: AGBRequirement, model) -> dict:
    """``bound_axis_limits`` of ``requirement`` on the error model alone."""
    return bound_axis_limits(ModelBound(requirement, model))


def bound_axis_limits(bound) -> dict:
    """Where the trade-off curve meets the axes: the largest V_eps with no crosstalk and the largest
    V_delta with no channel imbalance (variances). Men et al. (2021), Section V-B, points 3 and 6."""
    return bounds_axis_limits([bound])[0]


def bounds_axis_limits(bounds) -> list:
    """``bound_axis_limits`` of each of ``bounds`` (of one error model), the scans shared (``first_failing_levels``)."""
    cases = np.shape(bounds[0].model.value)
    imbalance = first_failing_levels(bounds, lambda v: {"crosstalk": 0.0, "channel_imbalance": v}, cases)
    crosstalk = first_failing_levels(bounds, lambda v: {"crosstalk": v, "channel_imbalance": 0.0}, cases)
    return [{"imbalance_limit": plain(i), "crosstalk_limit": plain(c)} for i, c in zip(imbalance, crosstalk)]


@dataclass(frozen=True)
class ConicTradeoff:
    """Closed-form trade-off curve of Men et al. (2021), Appendix B (paper form of the moments).

    ``b = a0 + a1 V_eps + a2 V_delta`` (B2a; a0 = sigma_n/2) and
    ``sigma_e^2 = b1 V_eps + b2 V_eps^2 + b3 V_delta^2 + b4 V_eps V_delta`` (B2b). With
    ``A0 = (f sigma_hv - a0)/z``, ``A1 = a1/z``, ``A2 = a2/z`` (B3) the curve is the conic
    ``P1 V_eps^2 + P2 V_delta^2 + P3 V_eps V_delta + P4 V_eps + P5 V_delta - P6 = 0`` (B4), restricted to
    the branch where ``A0 - A1 V_eps - A2 V_delta >= 0`` (sigma_e >= 0). For "under", z is negative
    as in the paper.
    """

    a0: float
    a1: float
    a2: float
    b1: float
    b2: float
    b3: float
    b4: float
    z: float
    f_sigma: float

    @classmethod
    def from_moments(cls, requirement: AGBRequirement, scene, system, faraday) -> ConicTradeoff:
        if system.has_gain_error:
            raise PhysicsInputError("the conic of Appendix B has no gain error; use tradeoff_curve")
        u = 1e-3  # exact polynomial: any positive probe level gives the same coefficients

        def moments(x, e):
            m = hv_error_moments(scene, system, faraday, "paper", crosstalk_level=x, imbalance_level=e)
            return float(m.mean), float(m.variance)

        m00, _ = moments(0.0, 0.0)
        m0e, v0e = moments(0.0, u)
        _, v02e = moments(0.0, 2 * u)
        mx0, vx0 = moments(u, 0.0)
        _, vxe = moments(u, u)
        b2 = (v02e - 2 * v0e) / (2 * u * u)
        z = requirement.z if requirement.side == "over" else -requirement.z
        return cls(
            a0=m00,
            a1=(m0e - m00) / u,
            a2=(mx0 - m00) / u,
            b1=v0e / u - b2 * u,
            b2=b2,
            b3=vx0 / u**2,
            b4=(vxe - vx0 - v0e) / u**2,
            z=z,
            f_sigma=requirement.f * scene.sigma_hv,
        )

    # eq. (B3)-(B4) ----------------------------------------------------------------------------
    @property
    def a_coefficients(self) -> tuple[float, float, float]:
        """(A0, A1, A2) of eq. (B3)."""
        return (self.f_sigma - self.a0) / self.z, self.a1 / self.z, self.a2 / self.z

    @property
    def p_coefficients(self) -> tuple:
        """(P1, ..., P6) of eq. (B4)."""
        a0, a1, a2 = self.a_coefficients
        return (
            self.b2 - a1**2,
            self.b3 - a2**2,
            self.b4 - 2 * a1 * a2,
            self.b1 + 2 * a0 * a1,
            2 * a0 * a2,
            a0**2,
        )

    def imbalance_for_crosstalk(self, crosstalk_levels) -> np.ndarray:
        """V_eps on the curve for each V_delta (the smallest admissible root of B4; NaN if none)."""
        p1, p2, p3, p4, p5, p6 = self.p_coefficients
        a0, a1, a2 = self.a_coefficients
        x = np.asarray(crosstalk_levels, dtype=float)
        qa, qb, qc = p1, p3 * x + p4, p2 * x**2 + p5 * x - p6
        disc = qb**2 - 4 * qa * qc
        with np.errstate(invalid="ignore", divide="ignore"):
            sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
            roots = np.stack([(-qb - sq) / (2 * qa), (-qb + sq) / (2 * qa)], -1)
        ok = (roots >= 0) & (a0 - a1 * roots - a2 * x[..., None] >= -1e-12 * abs(a0))
        roots = np.where(ok, roots, np.inf)
        best = roots.min(-1)
        return np.where(np.isfinite(best), best, np.nan)

    # eq. (B5)-(B7) ----------------------------------------------------------------------------
    @property
    def rotation(self) -> float:
        """phi with tan 2 phi = P3 / (P2 - P1), eq. (B5)."""
        p1, p2, p3, *_ = self.p_coefficients
        return 0.5 * np.arctan2(p3, p2 - p1)

    @property
    def standard_form(self) -> dict:
        """C0..C4 of (B6), centre and semi-axis parameters B1, B2 of (B7), and the conic's kind.

        (B7) as printed has ``C3^2 / (4 C1^2)`` and ``C4^2 / (4 C2^2)`` in B1 and B2; completing the
        square gives ``C3^2 / (4 C1)`` and ``C4^2 / (4 C2)`` (docs/errata.md).
        """
        p1, p2, p3, p4, p5, p6 = self.p_coefficients
        c, s = np.cos(self.rotation), np.sin(self.rotation)
        c1 = p1 * c**2 + p2 * s**2 - p3 * c * s
        c2 = p1 * s**2 + p2 * c**2 + p3 * c * s
        c3 = p4 * c - p5 * s
        c4 = p4 * s + p5 * c
        c0 = p6
        numerator = c0 + c3**2 / (4 * c1) + c4**2 / (4 * c2)
        b1, b2 = numerator / c1, numerator / c2
        kind = "hyperbola" if b1 * b2 < 0 else ("ellipse" if b1 > 0 and b2 > 0 else "degenerate")
        return {"C0": c0, "C1": c1, "C2": c2, "C3": c3, "C4": c4, "B1": b1, "B2": b2,
                "centre": (-c3 / (2 * c1), -c4 / (2 * c2)), "kind": kind}

    def standard_form_residual(self, imbalance_levels, crosstalk_levels) -> np.ndarray:
        """Left side of (B7) minus 1 at points (V_eps, V_delta): zero on the curve."""
        sf = self.standard_form
        c, s = np.cos(self.rotation), np.sin(self.rotation)
        ve, vd = np.asarray(imbalance_levels), np.asarray(crosstalk_levels)
        x = c * ve - s * vd  # inverse of (B5)
        y = s * ve + c * vd
        x0, y0 = sf["centre"]
        return (x - x0) ** 2 / sf["B1"] + (y - y0) ** 2 / sf["B2"] - 1.0
