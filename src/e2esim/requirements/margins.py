"""How far each error level may degrade before a requirement fails, and the crosstalk/channel-imbalance
trade-off curves: root finding on the bounds' violation at changed levels of the error model (``AGBBound``: asked
of the AGB error; ``ModelBound``: of an error model alone; ``e2esim.requirements.tradeoff``).

Neither runs past the measured validity range of the error model's analytic moments (``ErrorModel.validity``,
docs/theory/validity.md): a limit or axis crossing beyond its edge is reported as +inf ("holds as far as the
analytic model can tell"), the curve has no points there (NaN), and the details carry the edge,
``validity_edge_db`` in the instrument's convention; ``validity_note`` says so in the verdict's notes."""

from __future__ import annotations

import numpy as np

from e2esim.case_values import plain
from e2esim.distortion.validity import describe_level
from e2esim.requirements.level_search import first_failing_levels
from e2esim.requirements.tradeoff import TRADEOFF_LEVELS, bound_tradeoff_curves, bounds_axis_limits
from e2esim.units import level_db_from_variance, variance_from_level_db

INSTRUMENT_LEVELS = ("crosstalk", "channel_imbalance")
"""Levels stated in the instrument's own dB convention (the others are powers: 10 log10 of the level)."""


def level_convention(case) -> str:
    """The dB convention of the instrument's crosstalk and channel-imbalance levels ("variance" if unknown)."""
    if "instrument" not in case:
        return "variance"
    return case.common("instrument", "level convention", lambda inst: inst.level_convention)


def stated_levels_db(case) -> dict:
    """The levels the scenario states for the instrument, before calibration, in dB: crosstalk and channel
    imbalance in the instrument's convention (omitted when the two use different conventions: no single
    convention to compare them in), the NESZ (dB). For a block of cases, arrays over its cases."""
    if "instrument" not in case:
        return {}
    out = {"nesz": case.column("instrument", "NESZ (dB)", lambda inst: float(inst.nesz_db))}
    if case.common("instrument", "stated convention", lambda inst: inst.convention) != "mixed":
        out["crosstalk"], out["channel_imbalance"] = case.column(
            "instrument", "stated crosstalk and imbalance (dB)",
            lambda inst: (float(inst.crosstalk_db), float(inst.imbalance_db)))
    return out


def validity_edge(model) -> float | None:
    """The largest crosstalk or channel-imbalance variance the analytic model speaks for, or None (unknown)."""
    validity = getattr(model, "validity", None)
    return None if validity is None else validity.search_limit


def validity_note(model) -> str | None:
    """The verdict note on margins and curves that stop at the model's validity edge, or None."""
    validity = getattr(model, "validity", None)
    if validity is None:
        return None
    return (f"level margins and trade-off curves stop at the edge of the validity range of the {validity.model}, "
            f"{describe_level(validity.search_limit)}: a crosstalk or channel-imbalance limit beyond it is given as "
            "infinite and the curve has no points there; the Gaussian quantiles of eq. (19) behind them hold in a "
            "narrower range, and near a crosstalk limit the Monte Carlo's are larger (docs/theory/validity.md)")


def _capped(limit, edge):
    """Limits beyond the validity edge as +inf (NaN, failing at every level, stays)."""
    return limit if edge is None else np.where(limit > edge, np.inf, limit)


def _edge_db(model, convention: str) -> dict:
    edge = validity_edge(model)
    return {} if edge is None else {"validity_edge_db": float(level_db_from_variance(edge, convention))}


def level_margins(bounds, convention: str, stated_db: dict | None = None) -> dict:
    """Levels (dB) at which the verdict flips, each level of the error model varied alone, and their margins.

    ``<level>.limit_db``: the level where the first of the requirement's sides starts to fail (NaN if it
    fails at any level, +inf if it never fails); ``<level>.residual_db``: the model's current level, the
    residual after calibration; ``<level>.margin_db = limit_db - residual_db``. With ``stated_db`` (the
    specification as the scenario states it, ``stated_levels_db``) also ``<level>.spec_db`` and
    ``<level>.spec_margin_db = limit_db - spec_db``. The crosstalk and channel-imbalance levels are in the
    instrument's ``convention``, the others (the noise power, as the NESZ) as 10 log10 of the level. Numbers
    for one case, arrays over the cases of a block (the error model's ``value`` has their shape).
    """
    stated_db = stated_db or {}
    model = bounds[0].model
    cases = np.shape(model.value)
    edge = validity_edge(model)
    out = _edge_db(model, convention)
    for level, current in model.levels.items():
        conv = convention if level in INSTRUMENT_LEVELS else "variance"
        limits = first_failing_levels(bounds, lambda v, level=level: {level: v}, cases,
                                      bisect=level in getattr(model, "costly_levels", ()))
        limit = np.minimum.reduce(limits)
        limit = np.where(np.any(np.isnan(limits), axis=0), np.nan, limit)
        if level in INSTRUMENT_LEVELS:
            limit = _capped(limit, edge)
        current = np.asarray(current, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            limit_db = np.where(np.isfinite(limit), level_db_from_variance(limit, conv), limit)
            current_db = np.where(current > 0, level_db_from_variance(current, conv), -np.inf)
            margin_db = np.where(np.isfinite(current_db), limit_db - current_db, np.inf)
        out[f"{level}.limit_db"] = plain(limit_db)
        out[f"{level}.margin_db"] = plain(margin_db)
        out[f"{level}.residual_db"] = plain(current_db)
        if level in stated_db:
            spec_db = np.asarray(stated_db[level], dtype=float)
            out[f"{level}.spec_db"] = plain(spec_db)
            with np.errstate(invalid="ignore"):
                out[f"{level}.spec_margin_db"] = plain(np.where(np.isfinite(spec_db), limit_db - spec_db, np.inf))
    return out


def has_tradeoff_plane(model) -> bool:
    return all(level in model.levels for level in TRADEOFF_LEVELS)


def axis_crossings(bounds, convention: str) -> dict:
    """Where each trade-off curve meets the axes (Men et al. 2021, Section V-B points 3 and 6), in dB:
    the largest channel imbalance with no crosstalk and the largest crosstalk with no channel imbalance (+inf
    beyond the model's validity edge)."""
    model = bounds[0].model
    edge = validity_edge(model)
    out = _edge_db(model, convention)
    for req, found in zip(bounds, bounds_axis_limits(bounds)):
        limits = {k: _capped(np.asarray(v, dtype=float), edge) for k, v in found.items()}
        with np.errstate(divide="ignore", invalid="ignore"):
            out[f"{req.side}.imbalance_axis_db"] = plain(level_db_from_variance(limits["imbalance_limit"], convention))
            out[f"{req.side}.crosstalk_axis_db"] = plain(level_db_from_variance(limits["crosstalk_limit"], convention))
    return out


def tradeoff_curves(bounds, convention: str, crosstalk_db_range, points: int) -> dict:
    """The trade-off curve of every side: channel imbalance (dB) against crosstalk (dB), in ``convention``; NaN
    where either level would be beyond the model's validity edge."""
    x_db = np.linspace(*crosstalk_db_range, points)
    x = variance_from_level_db(x_db, convention)
    edge = validity_edge(bounds[0].model)
    curves = {"crosstalk_db": x_db}
    for req, v_eps in zip(bounds, bound_tradeoff_curves(bounds, x)):
        if edge is not None:
            v_eps = np.where((v_eps > edge) | (x > edge), np.nan, v_eps)
        with np.errstate(divide="ignore", invalid="ignore"):
            curves[f"{req.side}.imbalance_db"] = level_db_from_variance(v_eps, convention)
    return curves
