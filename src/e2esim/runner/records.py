"""Flatten the typed results of one case into named scalars for summary.json, results.h5 and reports.

Names are dotted, units in the name or stated in docs/output-format.md (sigma errors in m^2/m^2, AGB
errors in percent, levels in dB, angles in degrees). With a backscatter error budget or a regression
uncertainty, ``agb.contribution.<name>.*`` give the relative AGB error each source causes on its own
(mean, SD, RMSE in percent, its share of the sigma error variance, and its relative sigma error) and
``budget.*`` the budget of the HV channel.
"""

from __future__ import annotations

import math

import numpy as np

from e2esim.distortion.validation import compare_with_analytic, sample_moments

_AGB_QUANTILES = {"q00135": 0.00135, "q02275": 0.02275, "q50": 0.5, "q97725": 0.97725, "q99865": 0.99865}
"""Quantiles of the relative AGB error reported for every case (3 sigma, 2 sigma and median)."""


def case_scalars(state) -> dict:
    out: dict = {}
    if state.scene is not None:
        sc = state.scene
        out.update({
            "scene.sigma_hh": sc.sigma_hh, "scene.sigma_hv": sc.sigma_hv, "scene.sigma_vv": sc.sigma_vv,
            "scene.hhvv_magnitude": sc.hhvv_magnitude, "scene.hhvv_phase_deg": math.degrees(sc.hhvv_phase_rad),
            "scene.agb_t_ha": float("nan") if sc.agb_t_ha is None else sc.agb_t_ha,
        })
    geophysical = getattr(state.calibration, "raw_faraday", None) or state.faraday
    if geophysical is not None:  # the Faraday rotation of the case (before any correction)
        out["faraday.mean_deg"] = math.degrees(geophysical.mean_rad)
        out["faraday.sd_deg"] = math.degrees(geophysical.sd_rad)
        if hasattr(geophysical, "summary"):  # a climatology: percentiles, TEC, delays
            out.update({f"faraday.{k}": v for k, v in geophysical.summary().items()})
    if state.faraday is not None and state.faraday is not geophysical:  # what the propagation sees
        out["faraday_residual.mean_deg"] = math.degrees(state.faraday.mean_rad)
        out["faraday_residual.sd_deg"] = math.degrees(state.faraday.sd_rad)
    if state.instrument is not None:
        inst = state.instrument
        out.update({"instrument.crosstalk_db": inst.crosstalk_db, "instrument.channel_imbalance_db": inst.imbalance_db,
                    "instrument.nesz_db": inst.nesz_db, "instrument.centre_frequency_hz": inst.centre_frequency_hz})
    if state.system is not None:
        out.update({"system.crosstalk_variance": state.system.crosstalk_level,
                    "system.imbalance_variance": state.system.imbalance_level,
                    "system.noise_power": state.system.noise_power})
    if hasattr(state.calibration, "scalars"):  # calibration modules report what they did and leave
        out.update(state.calibration.scalars())
    bs = state.backscatter
    if bs is not None:
        if bs.analytic is not None:
            for name, value in bs.analytic.as_dict().items():
                if name not in ("form", "sigma_hv"):
                    out[f"analytic.{name}"] = float(value)
            out["analytic.sd"] = float(bs.analytic.sd)
        if bs.montecarlo is not None:
            for name, value in sample_moments(bs.montecarlo.hv).items():
                out[f"montecarlo.{name}"] = value
            out["montecarlo.sd"] = math.sqrt(max(out["montecarlo.variance"], 0.0))
            for name, value in (bs.gaussianity or {}).items():
                out[f"montecarlo.{name}"] = value
        if bs.analytic is not None and bs.montecarlo is not None:
            cmp = compare_with_analytic(float(bs.analytic.mean), float(bs.analytic.variance), bs.montecarlo.hv,
                                        bs.montecarlo.looks, fixed_scene=bs.reference == "scene")
            for name, value in cmp.items():
                out[f"comparison.{name}"] = value
    if bs is not None and bs.budget is not None:
        out.update(_budget_scalars(bs.budget))
    if state.agb is not None:
        agb = state.agb
        out["agb.exponent"] = agb.exponent
        for basis in ("analytic", "montecarlo"):
            if agb.has(basis):
                out[f"agb.{basis}.mean_percent"] = 100 * agb.mean(basis)
                out[f"agb.{basis}.rmse_percent"] = 100 * agb.rmse(basis)
                quantiles = agb.quantile(np.array(list(_AGB_QUANTILES.values())), basis)
                for label, q in zip(_AGB_QUANTILES, quantiles):
                    out[f"agb.{basis}.{label}_percent"] = 100 * float(q)
        for basis, fraction in agb.saturated_fraction:
            out[f"agb.{basis}.saturated_fraction"] = fraction
        for c in agb.contributions:
            stats = agb.contribution_stats(c.name)
            key = f"agb.contribution.{c.name}"
            out[f"{key}.mean_percent"] = 100 * stats["mean"]
            out[f"{key}.sd_percent"] = 100 * stats["sd"]
            out[f"{key}.rmse_percent"] = 100 * stats["rmse"]
            out[f"{key}.variance_share"] = stats["variance_share"]
            out[f"{key}.sigma_mean_percent"] = stats["sigma_mean_percent"]
            out[f"{key}.sigma_sd_percent"] = stats["sigma_sd_percent"]
    for i, v in enumerate(state.verdicts):
        out[f"requirement{i}.passed"] = float(v.passed)
        out[f"requirement{i}.value"] = v.value
        out[f"requirement{i}.margin"] = v.margin
    return {k: _float(v) for k, v in out.items()}


def _budget_scalars(budget) -> dict:
    """Budget of the HV channel (relative SDs in percent, looks, SNR and MNR in dB) as ``budget.*``."""
    hv = budget.channel("hv") if budget.channels else budget
    return {f"budget.{k}": v for k, v in hv.as_dict().items()}


def _float(value) -> float:
    return float(np.real(value))
