"""The residual calibration error at every date of the mission, and the cheapest schedule that keeps it within
limits (issue 25, items 2 to 6; docs/theory/calibration-campaign.md).

``run_campaign`` finds every acquisition of every site (``visibility``), what each visit measures (``visits``),
and combines the visits a schedule uses with the drift of each parameter by the Kalman filter of ``drift``. A
schedule uses every transponder pass of the commissioning phase (the antenna and polarimetric characterisation of
Quegan et al. 2018, Section 4) and afterwards ``transponder_per_year`` of them in each mission year, spread evenly
over those the orbit and the acquisition plan offer (``repeat_orbit``), plus every acquisition of the targets of
opportunity it names.

``search_schedules`` evaluates every schedule of 0..``max_per_year`` transponder passes per year and every subset of
the targets of opportunity in one batched filter, and keeps the cheapest one whose residuals stay within the
limits (the residual levels that meet the AGB requirement, flowed down by ``e2esim allocate`` or ``e2esim solve``)
at every date after commissioning.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from e2esim.campaign.antenna import ANTENNA_PARAMETERS, gain_rows, swath_gain_variance
from e2esim.campaign.drift import YEAR_DAYS, DriftModel, joint_residual_variance, residual_variance
from e2esim.campaign.repeat_orbit import POINT_SITES
from e2esim.campaign.sites import PARAMETERS
from e2esim.campaign.visibility import site_visits
from e2esim.campaign.visit_ionosphere import (
    SOLAR_F107,
    SOLAR_SUNSPOTS,
    VisitIonosphereSettings,
    faraday_at_visits,
    visit_geometry,
    visit_ionosphere,
)
from e2esim.campaign.visits import visit_variances
from e2esim.errors import PhysicsInputError
from e2esim.orbit.sunsync import SunSynchronousOrbit
from e2esim.orbit.timeline import BIOMASS_LAUNCH


@dataclass(frozen=True)
class CampaignSetup:
    """Everything a campaign depends on. days : mission length (days). step_days : spacing of the residual
    dates. commissioning_days : the phase that uses every transponder pass. schedule_days : the span the schedule
    covers (no visit used after it; None: the mission). faraday_residual_rad : SD of the
    Faraday rotation left after correction at a visit. drift : {parameter: DriftModel}."""

    orbit: SunSynchronousOrbit
    sites: tuple
    drift: dict
    days: float
    near: float
    far: float
    step_days: float = 1.0
    commissioning_days: float = 91.0
    ionosphere: VisitIonosphereSettings = field(default_factory=lambda: VisitIonosphereSettings(
        BIOMASS_LAUNCH, SOLAR_F107["max"], SOLAR_SUNSPOTS["max"], 435e6))
    first_node_s: float = 0.0
    schedule_days: float | None = None
    track: object = None  # the drifting repeat track (``repeat_orbit.RepeatTrack`` of ``orbit``); None: no repeat

    def __post_init__(self):
        if not self.sites:
            raise PhysicsInputError("a campaign needs at least one calibration site", key="sites")
        names = [s.name for s in self.sites]
        if len(set(names)) != len(names):
            raise PhysicsInputError(f"site names repeat: {names}", key="sites")
        if self.schedule_days is not None and self.schedule_days > self.days + 1e-6:
            raise PhysicsInputError(f"a schedule of {self.schedule_days:g} days is longer than the mission "
                                    f"({self.days:g} days); allowed: at most the mission", key="schedule_years")


@dataclass(frozen=True)
class Acquisitions:
    """Every acquisition of every site (time order per site): site index, day, incidence (rad), pass, the
    Faraday rotation from the climatology (rad), the variance of its correction's residual (rad^2), log10 C_kL of
    the screen, and the variance of each parameter's estimate ({parameter: (n,)})."""

    site: np.ndarray
    day: np.ndarray
    incidence: np.ndarray
    pass_name: np.ndarray
    variance: dict
    faraday_rad: np.ndarray = None
    faraday_residual_variance: np.ndarray = None
    log10_ckl: np.ndarray = None
    gain_rows: np.ndarray = None  # (n, 3): what each gain measurement sees of (gain offset, pointing, pattern)


def find_acquisitions(setup: CampaignSetup) -> Acquisitions:
    """Every acquisition of every site over the mission; a site the mission never sees is an error."""
    found = []
    for site in setup.sites:
        v = site_visits(setup.orbit, site.lat, site.lon, setup.days, setup.near, setup.far, setup.first_node_s,
                        site.name, track=setup.track, point=site.type in POINT_SITES)
        if v.size == 0:
            raise PhysicsInputError(
                f"site {site.name} ({np.degrees(site.lat):.2f}, {np.degrees(site.lon):.2f} deg) is never seen in "
                f"{setup.days:g} days at incidence {np.degrees(setup.near):.2f}-{np.degrees(setup.far):.2f} deg "
                f"from this orbit; remove it or move it into the orbit's reach", key="sites")
        found.append((v, visit_geometry(setup.orbit, site, v, setup.first_node_s, setup.ionosphere)))
    omegas = faraday_at_visits([g for _, g in found], setup.ionosphere)
    parts = []
    for i, (site, (v, geometry), omega) in enumerate(zip(setup.sites, found, omegas)):
        ion = visit_ionosphere(site, geometry, omega, setup.ionosphere)
        parts.append((i, v, visit_variances(site, v.incidence, ion.faraday_variance, ion.peak_loss_variance_db2),
                      ion))
    return Acquisitions(
        site=np.concatenate([np.full(v.size, i) for i, v, _, _ in parts]),
        day=np.concatenate([v.day for _, v, _, _ in parts]),
        incidence=np.concatenate([v.incidence for _, v, _, _ in parts]),
        pass_name=np.concatenate([v.pass_name for _, v, _, _ in parts]),
        variance={p: np.concatenate([w[p] for _, _, w, _ in parts]) for p in PARAMETERS},
        faraday_rad=np.concatenate([ion.omega for *_, ion in parts]),
        faraday_residual_variance=np.concatenate([ion.faraday_variance for *_, ion in parts]),
        log10_ckl=np.concatenate([ion.log10_ckl for *_, ion in parts]),
        gain_rows=gain_rows(np.concatenate([v.incidence for _, v, _, _ in parts]), setup.near, setup.far))


def transponder_mask(acq: Acquisitions, sites: tuple, per_year: int | None, commissioning_days: float,
                     days: float) -> np.ndarray:
    """Which transponder passes a schedule uses: all in commissioning, then ``per_year`` per mission year spread
    evenly over the passes the orbit offers that year (None: all)."""
    is_tr = np.array([site.type == "transponder" for site in sites])[acq.site]
    use = is_tr & (acq.day < commissioning_days)
    after = is_tr & ~use
    if per_year is None:
        return use | after
    for y in range(int(np.ceil(days / YEAR_DAYS))):
        idx = np.flatnonzero(after & (acq.day >= y * YEAR_DAYS) & (acq.day < (y + 1) * YEAR_DAYS))
        if idx.size and per_year > 0:
            pick = np.unique(np.round(np.linspace(0, idx.size - 1, min(per_year, idx.size) + 2)[1:-1]).astype(int)
                             if per_year < idx.size else np.arange(idx.size))
            use[idx[pick]] = True
    return use


@dataclass(frozen=True)
class CampaignResult:
    """Residual variance of each parameter on each date: {parameter: (D,)} (gain dB^2, crosstalk and imbalance
    linear; ``gain`` is the swath's gain error, with its parts ``gain_offset``, ``pointing`` and ``pattern`` in dB^2,
    ``antenna``); ``used``: which acquisitions the schedule used."""

    days: np.ndarray
    variance: dict
    acquisitions: Acquisitions
    used: np.ndarray


def run_campaign(setup: CampaignSetup, per_year: int | None, opportunity: tuple,
                 acq: Acquisitions | None = None) -> CampaignResult:
    """The residual of every parameter at every date for one schedule (``opportunity``: names of the targets of
    opportunity used)."""
    acq = acq or find_acquisitions(setup)
    days = np.arange(0.0, setup.days + 1e-9, setup.step_days)
    used = _used(setup, acq, per_year, opportunity)
    order = np.argsort(acq.day)
    var = {}
    for p in PARAMETERS:
        var.update(parameter_residual(setup, p, days, acq, order, np.where(used, acq.variance[p], np.inf)[order]))
    return CampaignResult(days, var, acq, used)


NO_DRIFT = DriftModel(0.0)  # a parameter the setup's drift leaves out (the antenna's pointing and pattern): no error


def parameter_residual(setup: CampaignSetup, parameter: str, days, acq: Acquisitions, order, variance) -> dict:
    """{name: residual variance on ``days``} of one parameter for visits in time ``order`` with ``variance`` ((V,) or
    (S, V), in that order). The gain is estimated jointly with the antenna's pointing and elevation pattern
    (``antenna``): it gives ``gain`` (the swath's gain error) and its parts ``gain_offset``, ``pointing``,
    ``pattern``; crosstalk and imbalance give themselves."""
    if parameter != "gain":
        return {parameter: residual_variance(setup.drift[parameter], days, acq.day[order], variance)}
    models = tuple(setup.drift.get(name, NO_DRIFT) for name in ("gain", "pointing", "pattern"))
    parts = joint_residual_variance(models, days, acq.day[order], acq.gain_rows[order], variance)
    return {"gain": swath_gain_variance(parts), **dict(zip(ANTENNA_PARAMETERS, parts))}


def _used(setup, acq, per_year, opportunity) -> np.ndarray:
    names = [s.name for s in setup.sites]
    unknown = [o for o in opportunity if o not in names]
    if unknown:
        raise PhysicsInputError(f"targets of opportunity {unknown} are not among the sites {names}",
                                key="opportunity")
    tr = transponder_mask(acq, setup.sites, per_year, setup.commissioning_days, setup.days)
    too = np.isin(acq.site, [names.index(o) for o in opportunity]) & np.array(
        [site.type != "transponder" for site in setup.sites], dtype=bool)[acq.site]
    within = acq.day <= (setup.days if setup.schedule_days is None else setup.schedule_days)
    return (tr | too) & within


def margins_db(variance: dict, limits: dict) -> dict:
    """Margin of each parameter (dB, > 0 inside) of residual variances against limits (same units): 10 log10 of
    the limit over the residual for crosstalk and imbalance variances, 20 log10 of the SD ratio for the gain."""
    out = {}
    for p, lim in limits.items():
        v = np.maximum(variance[p], 1e-300)  # a new array: the steps below work in it (no (S, D) temporaries)
        out[p] = np.multiply(np.log10(np.divide(lim, v, out=v), out=v), 10, out=v)
    return out


@dataclass(frozen=True)
class ScheduleSearch:
    """Every schedule tried and the cheapest one that keeps the limits: per_year (S,), opportunity (tuple of name
    tuples), cost (S,), margin_db (S,): the smallest margin over parameters and dates after commissioning; best:
    index of the answer or None when no schedule keeps the limits."""

    per_year: np.ndarray
    opportunity: tuple
    cost: np.ndarray
    margin_db: np.ndarray
    best: int | None


def _distinct_rows(mask: np.ndarray) -> tuple:
    """The distinct rows of a boolean matrix and, for each row, the index of its distinct row."""
    packed = np.ascontiguousarray(np.packbits(mask, axis=1))
    keys = packed.view(np.dtype((np.void, packed.shape[1]))).ravel()
    _, first, which = np.unique(keys, return_index=True, return_inverse=True)
    return mask[first], which


def schedule_grid(setup: CampaignSetup, max_per_year: int, acq: Acquisitions) -> tuple:
    """Every schedule of 0..``max_per_year`` transponder passes per year and every subset of the targets of
    opportunity: the (per_year, opportunity) pairs and which acquisitions each uses ((S, n) boolean)."""
    too = [s.name for s in setup.sites if s.type != "transponder"]
    subsets = [c for k in range(len(too) + 1) for c in itertools.combinations(too, k)]
    grid = [(n, c) for n in range(max_per_year + 1) for c in subsets]
    return grid, np.array([_used(setup, acq, n, c) for n, c in grid])


def schedule_residuals(setup: CampaignSetup, used: np.ndarray, acq: Acquisitions, parameters=PARAMETERS) -> dict:
    """{parameter: (S, D)} residual variance on every date of every schedule (``used``: (S, n)); schedules that
    differ only in sites that do not measure a parameter leave the same residual of it: one filter each."""
    days = np.arange(0.0, setup.days + 1e-9, setup.step_days)
    order = np.argsort(acq.day)
    out = {}
    for p in parameters:
        informative = used[:, order] & np.isfinite(acq.variance[p][order])[None, :]
        distinct, which = _distinct_rows(informative)
        v = parameter_residual(setup, p, days, acq, order, np.where(distinct, acq.variance[p][order][None, :], np.inf))
        out[p] = v[p][which]
    return out


def search_schedules(setup: CampaignSetup, limits: dict, max_per_year: int, opportunity_cost: float = 1.0,
                     acq: Acquisitions | None = None) -> ScheduleSearch:
    """Cost = transponder passes per year + ``opportunity_cost`` per target of opportunity used; the answer is the
    cheapest schedule whose smallest margin is >= 0 (ties: the larger margin)."""
    acq = acq or find_acquisitions(setup)
    days = np.arange(0.0, setup.days + 1e-9, setup.step_days)
    after = days >= setup.commissioning_days
    grid, used = schedule_grid(setup, max_per_year, acq)
    variance = schedule_residuals(setup, used, acq, tuple(limits))
    worst = np.full(len(grid), np.inf)
    for p, lim in limits.items():
        worst = np.minimum(worst, margins_db({p: variance[p][:, after]}, {p: lim})[p].min(axis=1))
    cost = schedule_cost(grid, opportunity_cost)
    return ScheduleSearch(np.array([n for n, _ in grid]), tuple(c for _, c in grid), cost, worst,
                          cheapest(cost, worst))


def schedule_cost(grid: list, opportunity_cost: float = 1.0) -> np.ndarray:
    """Transponder passes per year + ``opportunity_cost`` per target of opportunity, of each schedule."""
    return np.array([n + opportunity_cost * len(c) for n, c in grid], float)


def cheapest(cost: np.ndarray, margin: np.ndarray) -> int | None:
    """Index of the cheapest schedule whose margin is >= 0 (ties: the larger margin); None when none is."""
    ok = np.flatnonzero(margin >= 0)
    return None if ok.size == 0 else int(ok[np.lexsort((-margin[ok], cost[ok]))[0]])


def worst_candidates(variance: np.ndarray) -> np.ndarray:
    """Indices of the dates no other date dominates (``variance``: (P, D), one row per parameter): a date whose
    residual variances are all at most another date's cannot be the worst epoch of an error that grows with each
    variance, so the worst epoch of the AGB error is among these (the Pareto-maximal dates)."""
    v, first = np.unique(np.asarray(variance, float).T, axis=0, return_index=True)
    # a date that dominates another has a larger (or, rounded, equal) sum and, at an equal sum, is larger
    # lexicographically: in this order every dominating date comes first, so one pass against the undominated
    # dates found so far decides each (O(D F) for F undominated dates instead of the O(D^2) comparison table)
    order = np.lexsort(tuple(-v[:, j] for j in range(v.shape[1] - 1, -1, -1)) + (-v.sum(axis=1),))
    front = np.empty_like(v)
    kept = []
    for i in order:
        if not np.any(np.all(front[:len(kept)] >= v[i], axis=1)):
            front[len(kept)] = v[i]
            kept.append(i)
    return np.sort(first[np.array(kept, dtype=np.intp)])


DEFAULT_DRIFT = {"gain": DriftModel(0.5), "crosstalk": DriftModel(0.01), "imbalance": DriftModel(0.05),
                 "pointing": DriftModel(0.0), "pattern": DriftModel(0.0)}
