"""The backscatter error budget of Ahmed, Siqueira & Hensley (2014), eqs. (20)-(38), vectorised.

``backscatter_budget(inputs, sigma)`` evaluates every term for any number of cases at once (all inputs
broadcast together) and returns a ``BackscatterBudget``: each named contribution as a relative variance
of sigma0 (``(Delta sigma / sigma)^2``) and their total.

The total error of eq. (20), ``Delta sigma = Delta sigma_s + Delta sigma_t + Delta sigma_c + Delta sigma_a``
(speckle and noise, temporal variability, calibration, area projection), is a sum of error terms. Their
sizes are standard deviations of independent random errors, so ``combination="independent"`` (default)
adds the variances of the four groups, and the variances of the three calibration terms of eq. (30)
(electronics, pointing, DEM: independent sources). ``combination="linear"`` adds the standard deviations
as printed, an upper bound. Within eq. (21) speckle, thermal and multiplicative noise always add
linearly: that is the exact spread of a multi-looked intensity with the noise level subtracted.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

import numpy as np

from e2esim.budget.area import area_projection_error, dem_averaging_factor, slope_error
from e2esim.budget.calibration import (
    BEAM_SHAPING_UNIFORM,
    dem_calibration_error,
    dem_pointing_error,
    pointing_calibration_error,
    random_calibration_error,
)
from e2esim.budget.geometry import azimuth_resolution, broadening_factor, number_of_looks, range_resolution
from e2esim.budget.noise import inverse_mnr, islr_db, quantisation_noise_ratio_db, snr, speckle_noise_terms
from e2esim.errors import PhysicsInputError

COMBINATIONS = ("independent", "linear")
TERMS = ("speckle", "thermal_noise", "multiplicative_noise", "temporal", "calibration_random",
         "calibration_pointing", "calibration_dem", "area_projection")
"""Named contributions, each a relative standard deviation of sigma0."""
GROUPS = {
    "speckle_noise": ("speckle", "thermal_noise", "multiplicative_noise"),  # eq. (21), linear sum
    "temporal": ("temporal",),  # Delta sigma_t, eq. (44) for UAVSAR
    "calibration": ("calibration_random", "calibration_pointing", "calibration_dem"),  # eq. (30)
    "area_projection": ("area_projection",),  # eq. (36)
}
"""The four terms of eq. (20) and the named contributions that make them up."""


def _db(x):
    return 10.0 ** (np.asarray(x, dtype=float) / 10.0)


@dataclass(frozen=True)
class BudgetInputs:
    """Instrument, processing and observation parameters of the budget, SI units and radians.

    Every field broadcasts against the others (scalars for one case, arrays for many).

    Instrument and processing (Table III): bandwidth_hz (B, eq. 23); antenna_length_m (L_az, eq. 24);
    range_resolution_m, azimuth_resolution_m : override eqs. (23)/(24) when given;
    eta_range, eta_azimuth : window pedestals (eqs. 25, 29); range_broadening, azimuth_broadening :
    override eq. (25); islr_range_db, islr_azimuth_db : override eq. (29); nesz : noise-equivalent sigma0
    (linear, eq. 26); quantisation_bits (b, eq. 28); ambiguity_ratio_db (AMB_t, eq. 27);
    random_calibration_db (Delta sigma_dB, eq. 31); pointing_error_rad (Delta theta, eqs. 33-34);
    elevation_beamwidth_rad, azimuth_beamwidth_rad (theta_1/2); beam_shaping (k);
    dem_height_error_m (Delta h_dem), dem_posting_m (L_dem; A_dem = L_dem^2).
    Observation (Table IV): area_m2 (A_g); incidence_rad (theta_i); slope_range_rad, slope_azimuth_rad
    (tau_rho, tau_s); slant_range_m (rho); observations (N_ot, all repeat observations);
    diverse_observations (N_os, speckle-diverse ones, <= N_ot); temporal_relative_sd (Delta sigma_t /
    sigma) or temporal_sd_m2m2 (Delta sigma_t in m^2/m^2, eq. 44; used when given).
    combination : "independent" or "linear" (module docstring); cap_dem_factor : limit the DEM
    averaging factor of eqs. (30) and (36) to 1.
    """

    bandwidth_hz: object = None
    antenna_length_m: object = None
    range_resolution_m: object = None
    azimuth_resolution_m: object = None
    eta_range: object = 1.0
    eta_azimuth: object = 1.0
    range_broadening: object = None
    azimuth_broadening: object = None
    islr_range_db: object = None
    islr_azimuth_db: object = None
    nesz: object = 0.0
    quantisation_bits: object = 8
    ambiguity_ratio_db: object = np.inf
    random_calibration_db: object = 0.0
    pointing_error_rad: object = 0.0
    elevation_beamwidth_rad: object = 1.0
    azimuth_beamwidth_rad: object = 1.0
    beam_shaping: object = BEAM_SHAPING_UNIFORM
    dem_height_error_m: object = 0.0
    dem_posting_m: object = 30.0
    area_m2: object = 10_000.0
    incidence_rad: object = np.radians(40.0)
    slope_range_rad: object = 0.0
    slope_azimuth_rad: object = 0.0
    slant_range_m: object = 10_000.0
    observations: object = 1
    diverse_observations: object = 1
    temporal_relative_sd: object = 0.0
    temporal_sd_m2m2: object = None
    combination: str = "independent"
    cap_dem_factor: bool = False

    def replace(self, **changes) -> BudgetInputs:
        return replace(self, **changes)

    def check(self) -> None:
        """Raise ``PhysicsInputError`` for impossible values (names the field, the value, what is allowed)."""
        if self.combination not in COMBINATIONS:
            raise PhysicsInputError(f"combination must be one of {COMBINATIONS}, got {self.combination!r}")
        if self.range_resolution_m is None and self.bandwidth_hz is None:
            raise PhysicsInputError("the budget needs bandwidth_hz (eq. 23) or range_resolution_m")
        if self.azimuth_resolution_m is None and self.antenna_length_m is None:
            raise PhysicsInputError("the budget needs antenna_length_m (eq. 24) or azimuth_resolution_m")
        positive = ("bandwidth_hz", "antenna_length_m", "range_resolution_m", "azimuth_resolution_m",
                    "range_broadening", "azimuth_broadening", "elevation_beamwidth_rad", "azimuth_beamwidth_rad",
                    "beam_shaping", "dem_posting_m", "area_m2", "slant_range_m", "observations",
                    "diverse_observations", "quantisation_bits")
        for name in positive:
            v = getattr(self, name)
            if v is not None and not np.all(np.asarray(v, float) > 0):
                raise PhysicsInputError(f"{name} must be > 0, got {np.min(v)}")
        non_negative = ("nesz", "random_calibration_db", "pointing_error_rad", "dem_height_error_m",
                        "temporal_relative_sd")
        for name in non_negative:
            v = getattr(self, name)
            if v is not None and not np.all(np.asarray(v, float) >= 0):
                raise PhysicsInputError(f"{name} must be >= 0, got {np.min(v)}")
        for name in ("eta_range", "eta_azimuth"):
            v = np.asarray(getattr(self, name), float)
            if not np.all((v >= 0) & (v <= 1)):
                raise PhysicsInputError(f"{name} (window pedestal) must be in [0, 1], got {v}")
        if not np.all((np.asarray(self.incidence_rad) > 0) & (np.asarray(self.incidence_rad) < np.pi / 2)):
            raise PhysicsInputError(f"incidence must be in (0, 90) degrees, got {np.degrees(self.incidence_rad)}")
        if np.any(np.asarray(self.incidence_rad) - np.asarray(self.slope_range_rad) <= 0):
            raise PhysicsInputError("the range slope must be smaller than the incidence angle (no radar shadow "
                                    "or layover in eq. 37)")
        if np.any(np.asarray(self.diverse_observations, float) > np.asarray(self.observations, float)):
            raise PhysicsInputError("diverse_observations (N_os) cannot exceed observations (N_ot)")
        if self.temporal_sd_m2m2 is not None and not np.all(np.asarray(self.temporal_sd_m2m2, float) >= 0):
            raise PhysicsInputError(f"temporal_sd_m2m2 must be >= 0, got {self.temporal_sd_m2m2}")


@dataclass(frozen=True)
class BackscatterBudget:
    """Error budget of sigma0 for one or many cases (arrays of the broadcast shape of the inputs).

    sigma : backscatter (m^2/m^2) the budget is for. looks : N (eq. 22). range_resolution_m,
    azimuth_resolution_m, range_broadening, azimuth_broadening : eqs. (23)-(25). pixel_area_m2 : A_pix.
    snr : eq. (26). inverse_mnr : 1/MNR (eq. 27). islr_range, islr_azimuth, qnr : linear ratios (eqs. 28-29).
    dem_pointing_error_rad : eq. (35). slope_error_rad : eq. (38). area_error : Delta A_c / A_c (eq. 37).
    dem_factor : sqrt(A_dem / A_pix) / sqrt(N). relative_sd : dict TERMS -> Delta sigma / sigma (>= 0).
    combination : how groups and calibration terms combine. channels : names of a trailing channel axis
    (e.g. ("hh", "hv", "vv")) or None. observations, diverse_observations : N_ot, N_os. groups : the terms
    of eq. (20) included in the total (default all four). speckle_distribution : how a Monte Carlo draws the
    speckle-and-noise term: "gamma" (the exact law of an intensity averaged over 1/v independent looks,
    v its relative variance) or "gaussian".
    """

    sigma: np.ndarray
    looks: np.ndarray
    range_resolution_m: np.ndarray
    azimuth_resolution_m: np.ndarray
    range_broadening: np.ndarray
    azimuth_broadening: np.ndarray
    pixel_area_m2: np.ndarray
    snr: np.ndarray
    inverse_mnr: np.ndarray
    islr_range: np.ndarray
    islr_azimuth: np.ndarray
    qnr: np.ndarray
    dem_pointing_error_rad: np.ndarray
    slope_error_rad: np.ndarray
    area_error: np.ndarray
    dem_factor: np.ndarray
    relative_sd: dict
    combination: str = "independent"
    channels: tuple | None = None
    observations: np.ndarray = field(default=None)
    diverse_observations: np.ndarray = field(default=None)
    groups: tuple = tuple(GROUPS)
    speckle_distribution: str = "gamma"

    def with_(self, **changes) -> BackscatterBudget:
        """Copy with fields replaced (e.g. ``channels``, ``groups``)."""
        return replace(self, **changes)

    # variances --------------------------------------------------------------------------------------
    @property
    def contributions(self) -> dict:
        """Relative variance ``(Delta sigma / sigma)^2`` of every named contribution."""
        return {name: sd**2 for name, sd in self.relative_sd.items()}

    def group_sd(self, group: str) -> np.ndarray:
        """Relative SD of a term of eq. (20): linear sum within eq. (21); eq. (30) per ``combination``."""
        members = [self.relative_sd[m] for m in GROUPS[group]]
        if group == "speckle_noise" or self.combination == "linear":
            return sum(members)
        return np.sqrt(sum(m**2 for m in members))

    @property
    def group_variances(self) -> dict:
        """Relative variance of each included term of eq. (20)."""
        return {g: self.group_sd(g) ** 2 for g in self.groups}

    @property
    def total_variance(self) -> np.ndarray:
        """Relative variance of the total error of eq. (20) over the included groups."""
        if not self.groups:
            return np.zeros(np.shape(self.sigma))
        if self.combination == "linear":
            return sum(self.group_sd(g) for g in self.groups) ** 2
        return sum(self.group_variances.values())

    @property
    def total_sd(self) -> np.ndarray:
        return np.sqrt(self.total_variance)

    def variance(self, name: str) -> np.ndarray:
        """Relative variance of a named contribution, a group of eq. (20), or "total"."""
        if name == "total":
            return self.total_variance
        if name in GROUPS:
            return self.group_sd(name) ** 2
        if name in self.relative_sd:
            return self.relative_sd[name] ** 2
        raise KeyError(f"unknown budget term {name!r}; terms: {', '.join(TERMS)}; groups: {', '.join(GROUPS)}")

    def absolute_sd(self, name: str = "total") -> np.ndarray:
        """Delta sigma (m^2/m^2) of a contribution, group or the total."""
        return np.sqrt(self.variance(name)) * self.sigma

    def channel(self, name: str) -> BackscatterBudget:
        """The budget of one channel (trailing axis named in ``channels``)."""
        if self.channels is None or name not in self.channels:
            raise KeyError(f"no channel {name!r} in this budget (channels: {self.channels})")
        i = self.channels.index(name)

        def take(v):
            a = np.asarray(v)
            return a[..., i] if a.ndim and a.shape[-1] == len(self.channels) else a

        values = {f.name: getattr(self, f.name) for f in fields(self)}
        out = {k: (take(v) if isinstance(v, np.ndarray) else v) for k, v in values.items()}
        out["relative_sd"] = {k: take(v) for k, v in self.relative_sd.items()}
        out["channels"] = None
        return BackscatterBudget(**out)

    def as_dict(self) -> dict:
        """Scalars of a single-case budget: relative SDs (%) of every term, group and the total."""
        out = {f"{name}.relative_sd_percent": 100 * float(np.squeeze(sd)) for name, sd in self.relative_sd.items()}
        for g in GROUPS:
            out[f"{g}.relative_sd_percent"] = 100 * float(np.squeeze(self.group_sd(g)))
        out["total.relative_sd_percent"] = 100 * float(np.squeeze(self.total_sd))
        out["looks"] = float(np.squeeze(self.looks))
        out["snr_db"] = float(10 * np.log10(np.squeeze(self.snr)))
        out["mnr_db"] = float(-10 * np.log10(np.squeeze(self.inverse_mnr)))
        return out

    def scalars(self) -> dict:
        """Output scalars (``budget.*``): ``as_dict`` of the HV channel (of the budget itself if single-channel)."""
        return (self.channel("hv") if self.channels else self).as_dict()


def backscatter_budget(inputs: BudgetInputs, sigma) -> BackscatterBudget:
    """Every term of eqs. (20)-(38) for backscatter ``sigma`` (m^2/m^2), vectorised over all inputs."""
    inputs.check()
    sigma = np.asarray(sigma, dtype=float)
    if not np.all(sigma > 0):
        raise PhysicsInputError(f"the budget needs sigma > 0 m^2/m^2, got {np.min(sigma)}")
    i = inputs
    dr = range_resolution(i.bandwidth_hz) if i.range_resolution_m is None else np.asarray(i.range_resolution_m, float)
    ds = (azimuth_resolution(i.antenna_length_m) if i.azimuth_resolution_m is None
          else np.asarray(i.azimuth_resolution_m, float))
    kr = broadening_factor(i.eta_range) if i.range_broadening is None else np.asarray(i.range_broadening, float)
    ks = broadening_factor(i.eta_azimuth) if i.azimuth_broadening is None else np.asarray(i.azimuth_broadening, float)
    looks = number_of_looks(i.area_m2, i.incidence_rad, dr, ds, kr, ks)  # eq. (22)
    pixel_area = dr * ds  # A_pix of Table III (SLC pixel)
    islr_r = _db(islr_db(i.eta_range) if i.islr_range_db is None else i.islr_range_db)
    islr_s = _db(islr_db(i.eta_azimuth) if i.islr_azimuth_db is None else i.islr_azimuth_db)
    qnr = _db(quantisation_noise_ratio_db(i.quantisation_bits))
    inv_mnr = inverse_mnr(islr_r, islr_s, _db(i.ambiguity_ratio_db), qnr)  # eq. (27)
    with np.errstate(divide="ignore"):
        snr_lin = snr(sigma, i.nesz)  # eq. (26); inf without noise
    speckle, thermal, mult = speckle_noise_terms(looks, i.observations, i.diverse_observations, snr_lin, inv_mnr)
    not_ = np.asarray(i.observations, float)
    nos = np.asarray(i.diverse_observations, float)
    dem_area = np.asarray(i.dem_posting_m, float) ** 2
    factor = dem_averaging_factor(dem_area, pixel_area, looks, i.cap_dem_factor)
    cal_random = np.abs(random_calibration_error(i.random_calibration_db)) / np.sqrt(not_)  # eqs. (30)-(31)
    cal_pointing = np.abs(pointing_calibration_error(i.pointing_error_rad, i.elevation_beamwidth_rad,
                                                     i.azimuth_beamwidth_rad, i.beam_shaping)) / np.sqrt(not_)
    cal_dem = factor / np.sqrt(nos) * dem_calibration_error(i.dem_height_error_m, i.slant_range_m,
                                                            i.elevation_beamwidth_rad, i.beam_shaping)
    dtau = slope_error(i.dem_height_error_m, i.dem_posting_m, i.slope_range_rad)  # eq. (38), tau_x = tau_rho
    area_err = area_projection_error(i.incidence_rad, i.slope_range_rad, i.slope_azimuth_rad, dtau)  # eq. (37)
    area = factor / np.sqrt(nos) * np.abs(area_err)  # eq. (36)
    if i.temporal_sd_m2m2 is not None:
        temporal = np.asarray(i.temporal_sd_m2m2, float) / sigma
    else:
        temporal = np.asarray(i.temporal_relative_sd, float)
    terms = dict(zip(TERMS, (speckle, thermal, mult, temporal, cal_random, cal_pointing, cal_dem, area)))
    shape = np.broadcast_shapes(sigma.shape, *(np.shape(v) for v in terms.values()), np.shape(looks))
    bc = lambda v: np.broadcast_to(np.asarray(v, float), shape)
    return BackscatterBudget(
        sigma=bc(sigma), looks=bc(looks), range_resolution_m=bc(dr), azimuth_resolution_m=bc(ds),
        range_broadening=bc(kr), azimuth_broadening=bc(ks), pixel_area_m2=bc(pixel_area), snr=bc(snr_lin),
        inverse_mnr=bc(inv_mnr), islr_range=bc(islr_r), islr_azimuth=bc(islr_s), qnr=bc(qnr),
        dem_pointing_error_rad=bc(dem_pointing_error(i.dem_height_error_m, i.slant_range_m)),
        slope_error_rad=bc(dtau), area_error=bc(area_err), dem_factor=bc(factor),
        relative_sd={k: bc(v) for k, v in terms.items()}, combination=i.combination,
        observations=bc(not_), diverse_observations=bc(nos),
    )
