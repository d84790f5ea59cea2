"""Requirement modules (kind ``requirement``): verdicts on the relative AGB error.

``agb_error_bound``: the relative AGB error stays within +-bound with a one-sided confidence (Men et al.
2021, eq. 19 and Section V-B: 20 % at 99.865 %, i.e. z = 3). ``agb_rmse``: the root-mean-square relative
AGB error stays below a limit. ``agb_rmse_absolute``: the same in t/ha (NISAR). Each verdict carries the
contribution of every error source (``e2esim.requirements.attribution``) and, on request, how far each
error level may degrade and the crosstalk/channel-imbalance trade-off curve
(``e2esim.requirements.margins``): all asked of the case's AGB error (``e2esim.retrieval.agb_variants``), which
holds the propagation's error model, so they work for any propagation module that provides one.
"""

from __future__ import annotations

import numpy as np

from e2esim.case_values import plain
from e2esim.module import fail
from e2esim.params import Param
from e2esim.requirements.allocation import ALLOCATION_PARAMS, allocation_details
from e2esim.requirements.attribution import attribution, can_attribute, dominant
from e2esim.requirements.base import (
    PERCENT,
    Requirement,
    agb_requirement_params,
    basis_of,
    checked_error,
    largest,
    scope_suffix,
    truth,
)
from e2esim.requirements.margins import (
    axis_crossings,
    has_tradeoff_plane,
    level_convention,
    level_margins,
    stated_levels_db,
    tradeoff_curves,
    validity_note,
)
from e2esim.requirements.shapley import bound_shapley, rms_shapley
from e2esim.requirements.shares import bound_shares, rms_parts, shares
from e2esim.requirements.tradeoff import AGBBound
from e2esim.requirements.uncertainty import largest_side, verdict_uncertainty
from e2esim.requirements.verdict import RequirementVerdict


class AGBErrorBound(Requirement):
    """P(AGB overestimated by more than bound) and/or P(underestimated by more than bound) <= 1 - confidence."""

    type_name = "agb_error_bound"
    batched = True
    summary = "relative AGB error within +-bound with one-sided confidence (Men et al. 2021, eq. 19)"
    params = agb_requirement_params(
        Param("bound_percent", "float", "largest allowed relative AGB error", default=20.0, unit="%",
              exclusive_minimum=0.0, exclusive_maximum=100.0),
        Param("confidence_percent", "float", "one-sided confidence that the bound holds", default=99.865,
              unit="%", exclusive_minimum=50.0, exclusive_maximum=100.0),
        Param("side", "str", "bound overestimation, underestimation or both", default="both",
              choices=("over", "under", "both")),
        after=(
            Param("level_margins", "bool",
                  "find by root finding how far crosstalk, channel imbalance and NESZ may degrade before the "
                  "verdict flips (analytic model)", default=False),
            Param("tradeoff_curve", "bool", "trace the crosstalk/channel-imbalance trade-off curve (eq. 19) and "
                  "report where it meets the axes", default=False),
            Param("curve_crosstalk_db", "float", "crosstalk range of the trade-off curve, in the instrument's "
                  "level convention", default=(-50.0, -10.0), unit="dB", length=2, minimum=-200.0, maximum=0.0,
                  convert=False),
            Param("curve_points", "int", "points on the trade-off curve", default=121, minimum=2, maximum=100000),
            *ALLOCATION_PARAMS,
        ),
    )

    @property
    def label(self) -> str:
        c = self.config
        if c["name"]:
            return c["name"]
        sign = {"over": "+", "under": "-", "both": "+-"}[c["side"]]
        return f"AGB error within {sign}{c['bound_percent']:g} % at {c['confidence_percent']:g} %{scope_suffix(c)}"

    def sides(self) -> tuple:
        return ("over", "under") if self.config["side"] == "both" else (self.config["side"],)

    def evaluate(self, case):
        c = self.config
        agb = checked_error(self, case)
        basis = basis_of(self, case, agb)
        conf = self.si["confidence_fraction"]
        bound = self.si["bound_fraction"]
        values, details, notes = [], {}, []
        side_values, side_errors, sampling = {}, {}, []
        bounds = [AGBBound(agb, bound, conf, side, case.services.memo) for side in self.sides()]
        for side, side_bound in zip(self.sides(), bounds):
            prob = conf if side == "over" else 1 - conf
            sign = 1.0 if side == "over" else -1.0
            # the side's threshold, derived once (only where an analytic answer asks it): the exceedance, its
            # standard error and the margins and curves below share it
            f = {"relative_threshold": side_bound.relative_threshold} if agb.has("analytic") else {}
            for b in ("analytic", "montecarlo"):
                if agb.has(b):
                    details[f"{side}.{b}.quantile_percent"] = plain(agb.quantile(prob, b)) * PERCENT
                    details[f"{side}.{b}.exceedance_probability"] = agb.exceedance(
                        bound, side, b, **(f if b == "analytic" else {}))
                    side_values.setdefault(b, []).append(sign * details[f"{side}.{b}.quantile_percent"])
                    side_errors.setdefault(b, []).append(plain(agb.standard_error("quantile", b, prob)) * PERCENT)
            if agb.has("montecarlo"):
                details[f"{side}.montecarlo.exceedance_probability_standard_error"] = agb.standard_error(
                    "exceedance", "montecarlo", bound, side, **f)
                sampling.append(agb.sampling_standard_error("quantile", prob) * PERCENT)
            q = plain(agb.quantile(prob, basis)) * PERCENT
            values.append(q if side == "over" else -q)
        value = largest(values)
        picked = {b: largest_side(side_values[b], side_errors[b]) for b in side_values}
        mc_sampling = largest_side(side_values["montecarlo"], sampling)[1] if sampling else None
        sure, sure_notes = verdict_uncertainty(agb, basis, {b: v for b, (v, _) in picked.items()},
                                               {b: e for b, (_, e) in picked.items()}, mc_sampling,
                                               c["bound_percent"] - value, "%")
        details.update(sure)
        notes.extend(sure_notes)
        verdict_curves = {}
        model = agb.error_model
        if (c["level_margins"] or c["tradeoff_curve"]) and model.unavailable is not None:
            notes.append(f"no level margins or trade-off curve: {model.unavailable}")
        elif c["level_margins"] or c["tradeoff_curve"]:
            convention = level_convention(case)
            if validity_note(model) is not None:
                notes.append(validity_note(model))
            if c["level_margins"]:
                details.update(level_margins(bounds, convention, stated_levels_db(case)))
            if c["tradeoff_curve"] and not has_tradeoff_plane(model):
                notes.append("no trade-off curve: the error model has no crosstalk and channel-imbalance levels "
                             f"(its levels: {', '.join(model.levels) or 'none'})")
            elif c["tradeoff_curve"]:
                verdict_curves = tradeoff_curves(bounds, convention, c["curve_crosstalk_db"], c["curve_points"])
                details.update(axis_crossings(bounds, convention))
        sides = self.sides()

        def checked_value(agb_error):
            qs = [plain(agb_error.quantile(conf if side == "over" else 1 - conf)) * PERCENT for side in sides]
            return largest([q if side == "over" else -q for q, side in zip(qs, sides)])

        contributions, why_not = attribution(checked_value, agb)
        details.update(contributions)
        if can_attribute(agb):
            side_values = {side: (1.0 if side == "over" else -1.0) * plain(
                agb.quantile(conf if side == "over" else 1 - conf)) for side in sides}
            details.update(bound_shares(value, agb, conf, sides, side_values, "percent"))
            details.update(bound_shapley(value, agb, conf, sides, side_values, "percent"))
        details.update(allocation_details(self, details, agb.sources(), c["bound_percent"], value, "percent"))
        return RequirementVerdict(
            name=self.label,
            passed=truth(value <= c["bound_percent"]),
            value=value,
            limit=c["bound_percent"],
            margin=c["bound_percent"] - value,
            unit="%",
            basis=basis,
            details=details,
            curves=verdict_curves,
            dominant=dominant(details),
            notes=tuple(notes) + why_not,
        )


class AGBRelativeRMSE(Requirement):
    """sqrt(E[q^2]) <= limit, q the relative AGB error (bias and spread together)."""

    type_name = "agb_rmse"
    batched = True
    summary = "root-mean-square relative AGB error below a limit"
    params = agb_requirement_params(Param("max_percent", "float", "largest allowed RMS relative AGB error",
                                          default=20.0, unit="%", exclusive_minimum=0.0),
                                    after=ALLOCATION_PARAMS)

    @property
    def label(self) -> str:
        return self.config["name"] or f"AGB RMSE <= {self.config['max_percent']:g} %{scope_suffix(self.config)}"

    def evaluate(self, case):
        agb = checked_error(self, case)
        basis = basis_of(self, case, agb)
        bases = [b for b in ("analytic", "montecarlo") if agb.has(b)]
        details = {f"{b}.rmse_percent": agb.rmse(b) * PERCENT for b in bases}
        value = agb.rmse(basis) * PERCENT
        limit = self.config["max_percent"]
        sure, sure_notes = verdict_uncertainty(
            agb, basis, {b: details[f"{b}.rmse_percent"] for b in bases},
            {b: agb.standard_error("rmse", b) * PERCENT for b in bases},
            agb.sampling_standard_error("rmse") * PERCENT if agb.has("montecarlo") else None, limit - value, "%")
        details.update(sure)
        contributions, notes = attribution(lambda agb_error: agb_error.rmse("analytic") * PERCENT, agb)
        details.update(contributions)
        if can_attribute(agb):
            details.update(shares(value, *rms_parts(agb), "percent"))
            details.update(rms_shapley(value, agb, "percent"))
        details.update(allocation_details(self, details, agb.sources(), limit, value, "percent"))
        return RequirementVerdict(self.label, truth(value <= limit), value, limit, limit - value, "%", basis,
                                  details, dominant=dominant(details), notes=tuple(notes) + sure_notes)


class AGBAbsoluteRMSE(Requirement):
    """sqrt(E[(AGB_hat - AGB)^2]) <= limit in t/ha, e.g. NISAR's "20 Mg/ha RMS at 1 ha for AGB < 100 Mg/ha"
    (the NISAR L2 biomass requirement, NISAR Science Users' Handbook, NASA/JPL 2019); 1 Mg/ha = 1 t/ha."""

    type_name = "agb_rmse_absolute"
    batched = True
    summary = "root-mean-square AGB error below a limit in t/ha (e.g. NISAR: 20 t/ha for AGB < 100 t/ha)"
    params = agb_requirement_params(
        Param("max_t_ha", "float", "largest allowed RMS AGB error", default=20.0, unit="t/ha", exclusive_minimum=0.0),
        Param("applies_below_t_ha", "float", "the requirement applies to AGB below this (null: to every AGB); "
              "cases at or above it are not applicable: no pass, no fail, no margin", default=None, unit="t/ha",
              exclusive_minimum=0.0, nullable=True),
        after=ALLOCATION_PARAMS,
    )
    needs = (*Requirement.needs, "scene.covariance")

    @property
    def label(self) -> str:
        c = self.config
        scope = f" for AGB < {c['applies_below_t_ha']:g} t/ha" if c["applies_below_t_ha"] else ""
        return c["name"] or f"AGB RMSE <= {c['max_t_ha']:g} t/ha{scope}{scope_suffix(c)}"

    def evaluate(self, case):
        agb_true = case.column("scene.covariance", "scene AGB",
                               lambda v: np.nan if v.agb_t_ha is None else float(v.agb_t_ha))
        if np.any(np.isnan(agb_true)):
            raise fail(self, "needs a scene with an AGB (agb_t_ha)",
                       "use a scene type that states its AGB, or give scene.agb_t_ha")
        agb = checked_error(self, case)
        basis = basis_of(self, case, agb)
        limit = self.config["max_t_ha"]
        value = agb.rmse(basis) * agb_true
        bases = [b for b in ("analytic", "montecarlo") if agb.has(b)]
        details = {f"{b}.rmse_t_ha": agb.rmse(b) * agb_true for b in bases}
        contributions, notes = attribution(lambda a: a.rmse("analytic") * agb_true, agb, unit="t_ha")
        details.update(contributions)
        if can_attribute(agb):
            details.update(shares(value, *rms_parts(agb), "t_ha"))
            details.update(rms_shapley(value, agb, "t_ha"))
        details.update(allocation_details(self, details, agb.sources(), limit, value, "t_ha"))
        below = self.config["applies_below_t_ha"]
        applies = True if below is None else truth(np.asarray(agb_true) < below)
        sure, sure_notes = verdict_uncertainty(
            agb, basis, {b: details[f"{b}.rmse_t_ha"] for b in bases},
            {b: plain(np.asarray(agb.standard_error("rmse", b)) * agb_true) for b in bases},
            plain(agb.sampling_standard_error("rmse") * np.asarray(agb_true)) if agb.has("montecarlo") else None,
            limit - value, "t/ha", applies)
        details.update(sure)
        return RequirementVerdict(self.label, truth(np.asarray(value) <= limit), value, limit, limit - value, "t/ha",
                                  basis, details, dominant=dominant(details, "t_ha"), notes=tuple(notes) + sure_notes,
                                  applicable=applies, reason="" if below is None else f"the case's AGB is not below "
                                  f"{below:g} t/ha, the range the requirement applies to")
