"""Requirement modules (kind ``requirement``): verdicts on the relative AGB error.

``agb_error_bound``: the relative AGB error stays within +-bound with a one-sided confidence (Men et al.
2021, eq. 19 and Section V-B: 20 % at 99.865 %, i.e. z = 3). ``agb_rmse``: the root-mean-square relative
AGB error stays below a limit.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from e2esim.chain import RequirementVerdict
from e2esim.distortion.analytic import hv_error_moments
from e2esim.faraday.distribution import ConstantFaraday
from e2esim.retrieval.agb_error import AGBError
from e2esim.requirements.tradeoff import (
    AGBRequirement,
    axis_limits,
    first_failing_level,
    requirement_violation,
    tradeoff_curve,
)
from e2esim.errors import ConfigError
from e2esim.module import Module
from e2esim.params import Param
from e2esim.units import level_db_from_variance, variance_from_level_db

BASES = ("auto", "analytic", "montecarlo")
_PERCENT = 100.0

SOURCES = ("crosstalk", "channel_imbalance", "noise", "faraday_rotation", "gain")
"""System error sources a verdict is attributed to; the random-error budget's terms and the regression
uncertainty (when the scenario has them) are attributed by their own names."""


def attribution(state, value_of, agb=None, unit: str = "percent") -> dict:
    """How much each error source adds to a requirement's checked value, and which adds most.

    For each source the value is recomputed with that source removed, everything else kept: the system
    sources by re-evaluating the analytic model (crosstalk or channel imbalance at zero level, no noise, no
    Faraday rotation, no gain error); the budget terms (speckle and noise, temporal, calibration, area
    projection) and the regression uncertainty by taking their variance out of the total. A source's
    contribution is the checked value minus the value without it, in the requirement's unit. The parts
    need not add up (the sources interact, and quantiles are not additive), but the largest is the one
    whose improvement helps most. ``value_of`` maps an analytic ``AGBError`` to the checked value; ``agb``
    is the error the requirement checks (default: the case's); ``unit`` ends the keys,
    ``contribution.<source>_<unit>``.
    """
    bs = state.backscatter
    agb = state.agb if agb is None else agb
    if bs is None or bs.analytic is None or agb is None or agb.error_mean is None:
        return {}
    moments = _variant_moments(state)
    # what the budget and regression add to the systematic variance (m^2/m^2)^2
    extra = max(agb.error_sd**2 - float(bs.analytic.variance), 0.0)
    base = value_of(agb)

    def with_systematic(mean, sd):
        return dataclasses.replace(agb, error_mean=float(mean), error_sd=float(np.sqrt(sd**2 + extra)))

    out = {f"contribution.{name}_{unit}": (base - value_of(with_systematic(*moments[name])) if name in moments
                                           else 0.0) for name in SOURCES}
    for c in agb.contributions:
        if c.group in ("random", "regression"):
            var = max(agb.error_sd**2 - bs.sigma_hv**2 * max(c.relative_variance, 0.0), 0.0)
            out[f"contribution.{c.name}_{unit}"] = base - value_of(
                dataclasses.replace(agb, error_sd=float(np.sqrt(var))))
    return out


_VARIANT_CACHE: list = []  # [(key objects, moments)]: requirements of one case share the evaluation


def _variant_moments(state) -> dict:
    """(mean, sd) of the systematic sigma_hv error with each system source removed."""
    key = (state.backscatter, state.system, state.faraday, state.scene)
    for cached_key, value in _VARIANT_CACHE:
        if all(a is b for a, b in zip(cached_key, key)):
            return value
    bs, sysm, fr = state.backscatter, state.system, state.faraday
    # the three level variants in one vectorised evaluation: [no crosstalk, no CI, no noise]
    levels = dict(
        crosstalk_level=np.array([0.0, sysm.crosstalk_level, sysm.crosstalk_level]),
        imbalance_level=np.array([sysm.imbalance_level, 0.0, sysm.imbalance_level]),
        noise_power=np.array([sysm.noise_power, sysm.noise_power, 0.0]),
    )
    m = hv_error_moments(state.scene, sysm, fr, bs.form, bs.looks, bs.reference, **levels)
    out = {name: (m.mean[i], m.sd[i]) for i, name in enumerate(("crosstalk", "channel_imbalance", "noise"))}
    if fr.mean_rad != 0.0 or fr.sd_rad != 0.0:
        v = hv_error_moments(state.scene, sysm, ConstantFaraday(0.0), bs.form, bs.looks, bs.reference)
        out["faraday_rotation"] = (v.mean, v.sd)
    if sysm.has_gain_error:
        no_gain = dataclasses.replace(sysm, gain_offset_db=0.0, gain_sd_db=0.0)
        v = hv_error_moments(state.scene, no_gain, fr, bs.form, bs.looks, bs.reference)
        out["gain"] = (v.mean, v.sd)
    _VARIANT_CACHE[:] = [(key, out)]
    return out


def _dominant(details: dict, unit: str = "percent") -> str:
    suffix = f"_{unit}"
    parts = {k[len("contribution."):-len(suffix)]: v for k, v in details.items()
             if k.startswith("contribution.") and k.endswith(suffix)}
    return max(parts, key=parts.get) if parts else ""


SOURCE_CHOICES = ("all", "systematic")


def checked_error(module: Module, state):
    """The AGB error a requirement checks: from every source (``all``), or only from the systematic error of
    the polarimetric propagation, system distortions, Faraday rotation and noise (``systematic``, the
    criterion of Men et al. 2021), leaving out the random-error budget and the regression uncertainty."""
    agb = state.agb
    if module.config["sources"] == "all" or not agb.contributions:
        return agb
    bs = state.backscatter
    relative = None
    if bs.montecarlo is not None:
        ref = np.asarray(bs.montecarlo.reference["hv"])
        relative = bs.montecarlo.hv / (ref[:, None] if ref.ndim else ref)
    return AGBError.from_sigma_errors(
        agb.exponent, bs.sigma_hv,
        None if bs.analytic is None else float(bs.analytic.mean),
        None if bs.analytic is None else float(bs.analytic.sd),
        relative, agb.mapping,
    )


_SOURCES_PARAM = Param(
    "sources", "str", "error sources checked: all (system, Faraday rotation, noise, error budget, regression) or "
    "systematic (system distortions, Faraday rotation and noise only: the criterion of Men et al. 2021)",
    default="all", choices=SOURCE_CHOICES)


def _basis(module: Module, state, agb) -> str:
    basis = module.config["basis"]
    if basis == "auto":
        return "analytic" if agb.has("analytic") else "montecarlo"
    if not agb.has(basis):
        raise ConfigError(
            module.location.child("basis"),
            f"{basis!r} results are not computed in simulation mode {state.settings.mode!r}",
            "use basis: auto, or a simulation mode that computes them",
        )
    return basis


class AGBErrorBound(Module):
    """P(AGB overestimated by more than bound) and/or P(underestimated by more than bound) <= 1 - confidence."""

    kind = "requirement"
    type_name = "agb_error_bound"
    summary = "relative AGB error within +-bound with one-sided confidence (Men et al. 2021, eq. 19)"
    params = (
        Param("name", "str", "label in reports (null: generated)", default=None, nullable=True),
        Param("bound_percent", "float", "largest allowed relative AGB error", default=20.0, unit="%",
              exclusive_minimum=0.0, exclusive_maximum=100.0),
        Param("confidence_percent", "float", "one-sided confidence that the bound holds", default=99.865,
              unit="%", exclusive_minimum=50.0, exclusive_maximum=100.0),
        Param("side", "str", "bound overestimation, underestimation or both", default="both",
              choices=("over", "under", "both")),
        Param("basis", "str", "analytic Gaussian model or Monte Carlo samples (auto: analytic when computed)",
              default="auto", choices=BASES),
        _SOURCES_PARAM,
        Param("level_margins", "bool",
              "find by root finding how far crosstalk, channel imbalance and NESZ may degrade before the "
              "verdict flips (analytic model)", default=False),
        Param("tradeoff_curve", "bool", "trace the crosstalk/channel-imbalance trade-off curve (eq. 19) and "
              "report where it meets the axes", default=False),
        Param("curve_crosstalk_db", "float", "crosstalk range of the trade-off curve, in the instrument's "
              "level convention", default=(-50.0, -10.0), unit="dB", length=2, minimum=-200.0, maximum=0.0),
        Param("curve_points", "int", "points on the trade-off curve", default=121, minimum=2, maximum=100000),
    )
    requires = ("agb",)

    @property
    def label(self) -> str:
        c = self.config
        if c["name"]:
            return c["name"]
        sign = {"over": "+", "under": "-", "both": "+-"}[c["side"]]
        suffix = " (system errors)" if c["sources"] == "systematic" else ""
        return f"AGB error within {sign}{c['bound_percent']:g} % at {c['confidence_percent']:g} %{suffix}"

    def sides(self) -> tuple:
        return ("over", "under") if self.config["side"] == "both" else (self.config["side"],)

    def forward(self, state):
        c = self.config
        agb = checked_error(self, state)
        basis = _basis(self, state, agb)
        conf = c["confidence_percent"] / _PERCENT
        bound = c["bound_percent"] / _PERCENT
        values, details = [], {}
        for side in self.sides():
            prob = conf if side == "over" else 1 - conf
            for b in ("analytic", "montecarlo"):
                if agb.has(b):
                    details[f"{side}.{b}.quantile_percent"] = float(agb.quantile(prob, b)) * _PERCENT
                    details[f"{side}.{b}.exceedance_probability"] = agb.exceedance(bound, side, b)
            q = float(agb.quantile(prob, basis)) * _PERCENT
            values.append(q if side == "over" else -q)
        value = max(values)
        verdict_curves = {}
        if (c["level_margins"] or c["tradeoff_curve"]) and state.backscatter.analytic is not None:
            extra = max(agb.error_sd**2 - float(state.backscatter.analytic.variance), 0.0)
            reqs = [AGBRequirement(bound, conf, side, agb.exponent,
                                   relative_threshold=None if agb.mapping is None else agb.sigma_threshold(
                                       bound if side == "over" else -bound),
                                   extra_variance=extra)
                    for side in self.sides()]
            if c["level_margins"]:
                details.update(_level_margins(reqs, state))
            if c["tradeoff_curve"]:
                verdict_curves = _tradeoff_curves(reqs, state, c["curve_crosstalk_db"], c["curve_points"])
                details.update(_axis_crossings(reqs, state))
        sides = self.sides()

        def checked_value(agb_error) -> float:
            qs = [float(agb_error.quantile(conf if side == "over" else 1 - conf)) * _PERCENT for side in sides]
            return max(q if side == "over" else -q for q, side in zip(qs, sides))

        details.update(attribution(state, checked_value, agb))
        verdict = RequirementVerdict(
            name=self.label,
            passed=bool(value <= c["bound_percent"]),
            value=value,
            limit=c["bound_percent"],
            margin=c["bound_percent"] - value,
            unit="%",
            basis=basis,
            details=details,
            curves=verdict_curves,
            dominant=_dominant(details),
        )
        return state.with_(verdicts=state.verdicts + (verdict,))


def _analytic_args(state) -> dict:
    bs = state.backscatter
    return dict(scene=state.scene, system=state.system, faraday=state.faraday, form=bs.form, looks=bs.looks,
                reference=bs.reference)


def _level_margins(reqs, state) -> dict:
    """Levels (dB) at which the verdict flips, each error source varied alone, and their margins.

    ``<source>.limit_db``: the level where the first of the requirement's sides starts to fail (NaN if it
    fails at any level, +inf if it never fails); ``<source>.margin_db = limit_db - current level``.
    """
    args = _analytic_args(state)
    sysm, conv = state.system, _convention(state)
    sources = {
        "crosstalk": ("crosstalk_level", sysm.crosstalk_level, conv),
        "channel_imbalance": ("imbalance_level", sysm.imbalance_level, conv),
        "nesz": ("noise_power", sysm.noise_power, "variance"),
    }
    out = {}
    for source, (keyword, current, convention) in sources.items():
        limits = []
        for req in reqs:
            def violation(levels, req=req, keyword=keyword):
                return requirement_violation(req, **args, **{keyword: levels})
            limits.append(float(first_failing_level(violation)))
        limit = min(limits) if not any(np.isnan(limits)) else float("nan")
        limit_db = float(level_db_from_variance(limit, convention)) if np.isfinite(limit) else limit
        current_db = float(level_db_from_variance(current, convention)) if current > 0 else float("-inf")
        out[f"{source}.limit_db"] = limit_db
        out[f"{source}.margin_db"] = limit_db - current_db if np.isfinite(current_db) else float("inf")
    return out


def _axis_crossings(reqs, state) -> dict:
    """Where each trade-off curve meets the axes (Men et al. 2021, Section V-B points 3 and 6), in dB:
    the largest channel imbalance with no crosstalk and the largest crosstalk with no channel imbalance."""
    conv = _convention(state)
    args = {k: v for k, v in _analytic_args(state).items() if k in ("form", "looks", "reference")}
    out = {}
    for req in reqs:
        limits = axis_limits(req, state.scene, state.system, state.faraday, **args)
        with np.errstate(divide="ignore", invalid="ignore"):
            out[f"{req.side}.imbalance_axis_db"] = float(level_db_from_variance(limits["imbalance_limit"], conv))
            out[f"{req.side}.crosstalk_axis_db"] = float(level_db_from_variance(limits["crosstalk_limit"], conv))
    return out


def _convention(state) -> str:
    inst = state.instrument
    return inst.convention if inst is not None and inst.convention != "mixed" else "variance"


def _tradeoff_curves(reqs, state, crosstalk_db_range, points) -> dict:
    conv = _convention(state)
    x_db = np.linspace(*crosstalk_db_range, points)
    x = variance_from_level_db(x_db, conv)
    curves = {"crosstalk_db": x_db}
    for req in reqs:
        v_eps = tradeoff_curve(req, state.scene, state.system, state.faraday, x, **{
            k: v for k, v in _analytic_args(state).items() if k in ("form", "looks", "reference")})
        with np.errstate(divide="ignore", invalid="ignore"):
            curves[f"{req.side}.imbalance_db"] = level_db_from_variance(v_eps, conv)
    return curves


class AGBRelativeRMSE(Module):
    """sqrt(E[q^2]) <= limit, q the relative AGB error (bias and spread together)."""

    kind = "requirement"
    type_name = "agb_rmse"
    summary = "root-mean-square relative AGB error below a limit"
    params = (
        Param("name", "str", "label in reports (null: generated)", default=None, nullable=True),
        Param("max_percent", "float", "largest allowed RMS relative AGB error", default=20.0, unit="%",
              exclusive_minimum=0.0),
        Param("basis", "str", "analytic Gaussian model or Monte Carlo samples (auto: analytic when computed)",
              default="auto", choices=BASES),
        _SOURCES_PARAM,
    )
    requires = ("agb",)

    @property
    def label(self) -> str:
        suffix = " (system errors)" if self.config["sources"] == "systematic" else ""
        return self.config["name"] or f"AGB RMSE <= {self.config['max_percent']:g} %{suffix}"

    def forward(self, state):
        agb = checked_error(self, state)
        basis = _basis(self, state, agb)
        details = {f"{b}.rmse_percent": agb.rmse(b) * _PERCENT for b in ("analytic", "montecarlo") if agb.has(b)}
        value = agb.rmse(basis) * _PERCENT
        limit = self.config["max_percent"]
        details.update(attribution(state, lambda agb_error: agb_error.rmse("analytic") * _PERCENT, agb))
        verdict = RequirementVerdict(self.label, bool(value <= limit), value, limit, limit - value, "%", basis,
                                     details, dominant=_dominant(details))
        return state.with_(verdicts=state.verdicts + (verdict,))


class AGBAbsoluteRMSE(Module):
    """sqrt(E[(AGB_hat - AGB)^2]) <= limit in t/ha, e.g. NISAR's "20 Mg/ha RMS at 1 ha for AGB < 100 Mg/ha"
    (NISAR science requirements, ../shared/reference/mission-facts.md); 1 Mg/ha = 1 t/ha."""

    kind = "requirement"
    type_name = "agb_rmse_absolute"
    summary = "root-mean-square AGB error below a limit in t/ha (e.g. NISAR: 20 t/ha for AGB < 100 t/ha)"
    params = (
        Param("name", "str", "label in reports (null: generated)", default=None, nullable=True),
        Param("max_t_ha", "float", "largest allowed RMS AGB error", default=20.0, unit="t/ha", exclusive_minimum=0.0),
        Param("applies_below_t_ha", "float", "the requirement applies to AGB below this (null: to every AGB); "
              "cases above pass by definition and say so", default=None, unit="t/ha", exclusive_minimum=0.0,
              nullable=True),
        Param("basis", "str", "analytic Gaussian model or Monte Carlo samples (auto: analytic when computed)",
              default="auto", choices=BASES),
        _SOURCES_PARAM,
    )
    requires = ("agb", "scene")

    @property
    def label(self) -> str:
        c = self.config
        scope = f" for AGB < {c['applies_below_t_ha']:g} t/ha" if c["applies_below_t_ha"] else ""
        return c["name"] or f"AGB RMSE <= {c['max_t_ha']:g} t/ha{scope}"

    def forward(self, state):
        agb_true = state.scene.agb_t_ha
        if agb_true is None:
            raise ConfigError(self.location, "needs a scene with an AGB (agb_t_ha)",
                              "use a scene type that states its AGB, or give scene.agb_t_ha")
        agb = checked_error(self, state)
        basis = _basis(self, state, agb)
        limit = self.config["max_t_ha"]
        value = agb.rmse(basis) * agb_true
        details = {f"{b}.rmse_t_ha": agb.rmse(b) * agb_true for b in ("analytic", "montecarlo") if agb.has(b)}
        details.update(attribution(state, lambda a: a.rmse("analytic") * agb_true, agb, unit="t_ha"))
        below = self.config["applies_below_t_ha"]
        applies = below is None or agb_true < below
        details["applies"] = float(applies)
        verdict = RequirementVerdict(self.label, bool(value <= limit or not applies), value, limit, limit - value,
                                     "t/ha", basis, details, dominant=_dominant(details, "t_ha"))
        return state.with_(verdicts=state.verdicts + (verdict,))
