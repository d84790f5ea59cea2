"""Faraday-rotation climatology of a site: the distribution of Omega over its acquisitions.

For every acquisition of an ``AcquisitionGeometry`` (date, pass, swath position) the IRI electron
density and the geomagnetic field give the path integral F = int N_e B.k ds (``e2esim.ionosphere.slant``),
hence Omega = A F / f^2 (Quegan et al. 2018, eq. 3) at the radar frequency. The day-to-day variability
about the IRI monthly median multiplies each acquisition's TEC by the log-normal factors of
``e2esim.ionosphere.variability``. The samples Omega_i X_j, with the acquisition weights, form an
``EmpiricalFaraday`` that the sigma_hv error chain consumes through its circular moments (analytic
mode, Men et al. 2021, eq. 9) or by sampling (Monte Carlo).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from e2esim.faraday.distribution import PERCENTILES, EmpiricalFaraday, weighted_percentiles  # noqa: F401
from e2esim.ionosphere.propagation import faraday_rotation_integral, phase_advance, range_delay
from e2esim.ionosphere.slant import PathIntegrals, SlantSettings, path_integrals
from e2esim.ionosphere.variability import lognormal_nodes


@dataclass(frozen=True, eq=False)
class FaradayClimatology(EmpiricalFaraday):
    """Omega from a climatology: samples (rad) and weights, plus what produced them.

    Per acquisition i (arrays of shape (n,), at the IRI median, before day-to-day variability):
    acquisition_omega : Omega (rad). vtec, stec : vertical (at the pierce point) and slant TEC along the
    ray below the satellite (electrons/m^2). b_dot_k : density-weighted mean B.k along the ray (T).
    range_delay_m : slant range delay r_sd (m, eq. 7b). phase_advance_rad : one-way phase advance (rad,
    eq. 7a). pass_label : "dawn"/"dusk"/..., acquisition_weight : weight of each acquisition.
    Settings: frequency_hz, f107 (sfu), variability (coefficient of variation of TEC), variability_factors
    (the log-normal nodes X_j), method (slant integration), site (label).
    """

    acquisition_omega: np.ndarray = field(default=None, repr=False)
    vtec: np.ndarray = field(default=None, repr=False)
    stec: np.ndarray = field(default=None, repr=False)
    b_dot_k: np.ndarray = field(default=None, repr=False)
    range_delay_m: np.ndarray = field(default=None, repr=False)
    phase_advance_rad: np.ndarray = field(default=None, repr=False)
    pass_label: np.ndarray = field(default=None, repr=False)
    acquisition_weight: np.ndarray = field(default=None, repr=False)
    variability_factors: np.ndarray = field(default=None, repr=False)
    frequency_hz: float = float("nan")
    f107: float = float("nan")
    variability: float = 0.0
    method: str = ""
    site: str = ""

    @property
    def mean_abs_rad(self) -> float:
        return float(np.dot(self._w, np.abs(self.samples)))

    def scalars(self) -> dict:
        """Output scalars: those of any distribution and the ``summary`` of the climatology."""
        return {**super().scalars(), **self.summary()}

    def summary(self) -> dict:
        """Scalars for reports: Omega mean, SD, mean |Omega|, percentiles (deg); TEC (TECU); delays. Computed once
        per climatology (the writers ask for every product's scalars, and a climatology is shared by many cases);
        a copy each time."""
        memo = self.__dict__.setdefault("_summary_memo", {})
        if "summary" not in memo:
            memo["summary"] = self._summary()
        return dict(memo["summary"])

    def _summary(self) -> dict:
        w = self.acquisition_weight / self.acquisition_weight.sum()
        out = {
            "omega_mean_deg": np.degrees(self.mean_rad), "omega_sd_deg": np.degrees(self.sd_rad),
            "omega_mean_abs_deg": np.degrees(self.mean_abs_rad),
            "vtec_mean_tecu": float(np.dot(w, self.vtec)) / 1e16, "stec_mean_tecu": float(np.dot(w, self.stec)) / 1e16,
            "range_delay_mean_m": float(np.dot(w, self.range_delay_m)),
            "b_dot_k_mean_ut": float(np.dot(w, self.b_dot_k)) * 1e6,
            "f107_sfu": self.f107, "frequency_mhz": self.frequency_hz / 1e6, "tec_variability": self.variability,
        }
        out.update(
            {f"omega_p{p:g}_deg".replace(".", "_"): v for p, v in self.percentiles_deg().items()}
        )  # no dots in names
        return out

    def describe(self) -> str:
        p = self.percentiles_deg((2.275, 50.0, 97.725))
        return (f"climatology {self.site}: mean {np.degrees(self.mean_rad):.3g} deg, SD {np.degrees(self.sd_rad):.3g} "
                f"deg, 95 % in [{p[2.275]:.3g}, {p[97.725]:.3g}] deg")


def climatology_from_integrals(integrals: PathIntegrals, level: int, frequency_hz: float, variability: float,
                               nodes: int, acquisition_weight=None, pass_label=None, site: str = "",
                               label: str = "climatology") -> FaradayClimatology:
    """The ``FaradayClimatology`` at one solar level of precomputed path integrals."""
    far, stec, vtec = integrals.faraday[level], integrals.stec[level], integrals.vtec[level]
    n = far.size
    w_acq = np.full(n, 1.0 / n) if acquisition_weight is None else np.asarray(acquisition_weight, float)
    omega = faraday_rotation_integral(far, frequency_hz)
    x = lognormal_nodes(variability, nodes)
    samples = (omega[:, None] * x[None, :]).ravel()
    weights = np.repeat(w_acq / w_acq.sum(), x.size) / x.size
    with np.errstate(invalid="ignore", divide="ignore"):
        bk = np.where(stec > 0, far / stec, integrals.b_dot_k_pierce)
    return FaradayClimatology(
        samples=samples, weights=weights, label=label, acquisition_omega=omega, vtec=vtec, stec=stec, b_dot_k=bk,
        range_delay_m=range_delay(stec, frequency_hz), phase_advance_rad=phase_advance(stec, frequency_hz),
        pass_label=np.asarray(pass_label if pass_label is not None else [""] * n), acquisition_weight=w_acq,
        variability_factors=x, frequency_hz=float(frequency_hz), f107=float(integrals.f107[level]),
        variability=float(variability), method=integrals.method, site=site,
    )


def site_path_integrals(geometry, f107_levels, settings: SlantSettings, cache=None) -> PathIntegrals:
    """Path integrals of every acquisition of an ``AcquisitionGeometry``; ``cache`` (an object with ``get`` and
    ``put``, e.g. ``e2esim.io.array_cache.ArrayCache``, handed in by the runner) keeps them between runs."""
    dates = [d.astype("datetime64[D]").item() for d in geometry.time_utc]
    desc = {"f107": [float(f) for f in f107_levels], "settings": settings_description(settings)}
    arrays = {"target": geometry.target_ecef, "satellite": geometry.satellite_ecef,
              "time": geometry.time_utc.astype("int64")}
    if cache is not None:
        stored = cache.get("site", desc, arrays, ("vtec", "stec", "faraday", "b_dot_k_pierce", "pierce_zenith", "f107"))
        if stored is not None:
            return PathIntegrals(stored["vtec"], stored["stec"], stored["faraday"], stored["b_dot_k_pierce"],
                                 stored["pierce_zenith"], tuple(stored["f107"].tolist()), settings.method)
    result = path_integrals(geometry.target_ecef, geometry.satellite_ecef, dates, geometry.ut_h, f107_levels, settings)
    if cache is not None:
        cache.put(
            "site",
            desc,
            arrays,
            {
                "vtec": result.vtec,
                "stec": result.stec,
                "faraday": result.faraday,
                "b_dot_k_pierce": result.b_dot_k_pierce,
                "pierce_zenith": result.pierce_zenith,
                "f107": np.array(result.f107),
            },
            {"description": desc, "site": geometry.site.name},
        )
    return result


def settings_description(settings: SlantSettings) -> dict:
    return {"method": settings.method, "shell_height_m": settings.shell_height_m,
            "bottom_height_m": settings.bottom_height_m, "layer_step_m": settings.layer_step_m,
            "field_step_m": settings.field_step_m, "fof2_model": settings.fof2_model,
            "monthly_medians": settings.monthly_medians,
            "field": {"kind": settings.field.kind, "epoch": settings.field.epoch, "model": settings.field.model,
                      "b0_tesla": settings.field.b0_tesla}}
