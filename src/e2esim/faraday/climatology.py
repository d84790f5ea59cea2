"""Faraday-rotation climatology of a site: the distribution of Omega over its acquisitions.

For every acquisition of an ``AcquisitionGeometry`` (date, pass, swath position) the IRI electron
density and the geomagnetic field give the path integral F = int N_e B.k ds (``e2esim.ionosphere.slant``),
hence Omega = A F / f^2 (Quegan et al. 2018, eq. 3) at the radar frequency. The day-to-day variability
about the IRI monthly median multiplies each acquisition's TEC by the log-normal factors of
``e2esim.ionosphere.variability``. The samples Omega_i X_j, with the acquisition weights, form an
``EmpiricalFaraday`` that the sigma_hv error chain consumes through its circular moments (analytic
mode, Men et al. 2021, eq. 9) or by sampling (Monte Carlo).

The climatologies of a block of map cases are one ``FaradayClimatology`` with a leading case axis (``of_cells``,
made by the ``global_climatology`` ionosphere): per case the acquisitions are the swath positions of its cell's
pass (NaN where the pass cannot see the cell, with weight 0), its statistics are computed for the whole block
(``e2esim.faraday.climatology_rows``) and ``item`` gives a case's one-case climatology, bit for bit the one the case
gets alone. A one-case climatology is a block of one: its statistics come from the same rows (bit for bit the
one-case formulas of ``EmpiricalFaraday``, tests/test_faraday_climatology.py).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from e2esim.block import Batched
from e2esim.faraday.climatology_rows import row_statistics
from e2esim.faraday.distribution import EVEN_NODES, EVEN_WEIGHTS, PERCENTILES, EmpiricalFaraday, weighted_percentiles  # noqa: F401
from e2esim.ionosphere.propagation import faraday_rotation_integral, phase_advance, range_delay
from e2esim.ionosphere.slant import PathIntegrals, SlantSettings, path_integrals
from e2esim.ionosphere.variability import lognormal_nodes


@dataclass(frozen=True)
class MapCells:
    """Where the cases of a block of map climatologies are: latitude and longitude (deg) and month, (B,) each. A
    case's site and label are written when the case is asked for (``FaradayClimatology.item``), not for every
    case of a map."""

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    month: np.ndarray

    def site(self, i: int) -> str:
        return f"{float(self.lat_deg[i]):g}N {float(self.lon_deg[i]):g}E"

    def take(self, positions) -> MapCells:
        return MapCells(self.lat_deg[positions], self.lon_deg[positions], self.month[positions])

    @staticmethod
    def concatenate(parts: list) -> MapCells:
        return MapCells(*(np.concatenate([getattr(p, name) for p in parts]) for name in ("lat_deg", "lon_deg",
                                                                                         "month")))


_CASE_AXIS = ("samples", "acquisition_omega", "vtec", "stec", "b_dot_k", "range_delay_m", "phase_advance_rad",
              "pass_label", "acquisition_weight", "frequency_hz", "f107")
"""The fields of a ``FaradayClimatology`` that carry the leading case axis of a block."""


@dataclass(frozen=True, eq=False)
class FaradayClimatology(Batched, EmpiricalFaraday):
    """Omega from a climatology: samples (rad) and weights, plus what produced them; one case, or a block of map
    cases with a leading case axis (module docstring).

    Per acquisition i (arrays of shape (n,), at the IRI median, before day-to-day variability):
    acquisition_omega : Omega (rad). vtec, stec : vertical (at the pierce point) and slant TEC along the
    ray below the satellite (electrons/m^2). b_dot_k : density-weighted mean B.k along the ray (T).
    range_delay_m : slant range delay r_sd (m, eq. 7b). phase_advance_rad : one-way phase advance (rad,
    eq. 7a). pass_label : "dawn"/"dusk"/..., acquisition_weight : weight of each acquisition.
    Settings: frequency_hz, f107 (sfu), variability (coefficient of variation of TEC), variability_factors
    (the log-normal nodes X_j), method (slant integration), site (label).

    With a case axis (``of_cells``): the per-acquisition arrays, samples and frequency_hz, f107 carry a leading
    axis of B cases (acquisitions a case does not have: NaN, weight 0); weights is None (equal acquisition
    weights per case); cells says where each case is (``MapCells``). Such a climatology answers what the batched
    stages and writers read for every case (``mean_rad``, ``sd_rad``, ``trig_moments``, ``even_quadrature``,
    ``scalar_columns``); ``item`` gives a case's one-case climatology for anything else.
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
    cells: MapCells | None = field(default=None, repr=False)

    def __post_init__(self):
        if self.case_shape == ():
            super().__post_init__()
        else:  # a block of map cases: its statistics are computed row by row (``row_statistics``)
            object.__setattr__(self, "_w", None)

    @classmethod
    def of_cells(cls, faraday, stec, vtec, frequency_hz, f107, pass_label, cells: MapCells, variability: float,
                 nodes: int, method: str) -> FaradayClimatology:
        """The climatologies of B map cases from the path integrals of each case's cell at every swath position
        (faraday F in T el/m^2, slant and vertical TEC in el/m^2: (B, positions), NaN where the pass cannot see
        the cell), as ``climatology_from_integrals`` gives each alone: frequency_hz, f107 (sfu), pass_label
        (B,); variability, nodes, method shared."""
        frequency_hz = np.asarray(frequency_hz, float)
        f = frequency_hz[:, None]
        seen = np.isfinite(faraday)
        count = seen.sum(-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            b_dot_k = np.where(stec > 0, faraday / stec, np.nan)
            weight = np.where(seen, 1.0 / count[:, None], 0.0)
        omega = faraday_rotation_integral(faraday, f)
        x = lognormal_nodes(variability, nodes)
        return cls(samples=(omega[:, :, None] * x).reshape(len(omega), -1), weights=None, label="global climatology",
                   acquisition_omega=omega, vtec=vtec, stec=stec, b_dot_k=b_dot_k, range_delay_m=range_delay(stec, f),
                   phase_advance_rad=phase_advance(stec, f),
                   pass_label=np.broadcast_to(np.asarray(pass_label, dtype=object)[:, None], omega.shape),
                   acquisition_weight=weight, variability_factors=x, frequency_hz=frequency_hz,
                   f107=np.asarray(f107, float), variability=float(variability), method=method, cells=cells)

    # The case axis (``e2esim.block.Batched``) ------------------------------------------------------------------
    @property
    def case_shape(self) -> tuple:
        """() for one case, (B,) for a block of B map cases."""
        return np.shape(self.frequency_hz)

    def block_item(self, i: int) -> FaradayClimatology:
        """Case i's one-case climatology, made once per block: a map cell's case is asked for it by every product
        that holds it (the error model, its wrappers, the AGB error, the kept products), which share it as the
        per-case engine shares one climatology between the stages of a case."""
        i = int(i)
        if i not in self._items:
            self._items[i] = self._case(i)
        return self._items[i]

    def _case(self, i: int) -> FaradayClimatology:
        """Case i alone, with the arithmetic of ``climatology_from_integrals`` on the acquisitions it has."""
        seen = np.isfinite(self.acquisition_omega[i])
        n = int(seen.sum())
        omega, x = self.acquisition_omega[i][seen], self.variability_factors
        w_acq = np.full(n, 1.0 / n)
        f107, pass_label = float(self.f107[i]), str(self.pass_label[i, 0])
        where = self.cells.site(i)
        return FaradayClimatology(
            samples=(omega[:, None] * x[None, :]).ravel(), weights=np.repeat(w_acq / w_acq.sum(), x.size) / x.size,
            label=f"global climatology {where}, month {int(self.cells.month[i])}, {pass_label}, F10.7 {f107:g} sfu",
            acquisition_omega=omega, vtec=self.vtec[i][seen], stec=self.stec[i][seen], b_dot_k=self.b_dot_k[i][seen],
            range_delay_m=self.range_delay_m[i][seen], phase_advance_rad=self.phase_advance_rad[i][seen],
            pass_label=np.asarray([pass_label] * n), acquisition_weight=w_acq, variability_factors=x,
            frequency_hz=float(self.frequency_hz[i]), f107=f107, variability=self.variability, method=self.method,
            site=where)

    def take(self, positions) -> FaradayClimatology:
        return dataclasses.replace(self, cells=self.cells.take(positions),
                                   **{name: getattr(self, name)[positions] for name in _CASE_AXIS})

    @classmethod
    def concatenate(cls, parts: list) -> FaradayClimatology:
        return dataclasses.replace(parts[0], cells=MapCells.concatenate([p.cells for p in parts]),
                                   **{name: np.concatenate([getattr(p, name) for p in parts]) for name in _CASE_AXIS})

    @cached_property
    def _items(self) -> dict:
        """The one-case climatologies of a block made so far, by case (``item``)."""
        return {}

    @cached_property
    def _statistics(self) -> dict:
        """The statistics of every case (``row_statistics``; one case is a block of one)."""
        rows = (lambda a: a) if self.case_shape else (lambda a: np.asarray(a)[None])
        return row_statistics(rows(self.acquisition_omega), {
            "vtec": rows(self.vtec), "stec": rows(self.stec), "range_delay": rows(self.range_delay_m),
            "b_dot_k": rows(self.b_dot_k)}, self.variability_factors, rows(self.acquisition_weight))

    def _per_case(self, values: np.ndarray):
        """``values`` (B, ...) as the climatology's cases have them: the array of a block, one case's value."""
        return values if self.case_shape else values[0]

    # Statistics of every case (``row_statistics``) -------------------------------------------------------------
    @property
    def mean_rad(self):
        """The mean of Omega (rad); (B,) for a block."""
        return self._per_case(self._statistics["mean"])

    @property
    def sd_rad(self):
        """The SD of Omega (rad); (B,) for a block."""
        return self._per_case(self._statistics["sd"])

    @property
    def mean_abs_rad(self):
        return self._per_case(self._statistics["mean_abs"])

    def trig_moments(self) -> dict:
        """``FaradayDistribution.trig_moments``, Men et al. (2021), eq. (9a-d); {name: (B,)} for a block."""
        s = self._statistics
        cos2, cos4, sin2 = s["phi2"].real, s["phi4"].real, s["phi2"].imag
        return {name: self._per_case(value) for name, value in {
            "c4": (3 + 4 * cos2 + cos4) / 8, "s4": (3 - 4 * cos2 + cos4) / 8, "c2s2": (1 - cos4) / 8,
            "cs": sin2 / 2}.items()}

    @cached_property
    def _even_weights(self) -> np.ndarray:
        phi = self._statistics["phi"]
        moments = np.stack([np.ones(len(phi)), phi[:, 0], (1 + phi[:, 1]) / 2, (3 * phi[:, 0] + phi[:, 2]) / 4,
                            (3 + 4 * phi[:, 1] + phi[:, 3]) / 8], axis=-1)
        weights = self._per_case(np.matmul(EVEN_WEIGHTS[None], moments[:, :, None])[:, :, 0])  # case by case
        weights.setflags(write=False)
        return weights

    def even_quadrature(self) -> tuple:
        """``FaradayDistribution.even_quadrature``: the nodes (5,) and the weights (5,), (B, 5) for a block."""
        return EVEN_NODES, self._even_weights

    def scalar_columns(self) -> dict:
        """``scalars`` of every case: {name: (B,)}, in its order ((1,) for one case)."""
        s = self._statistics
        n = len(s["mean"])
        out = {"mean_deg": np.degrees(s["mean"]), "sd_deg": np.degrees(s["sd"]),
               "omega_mean_deg": np.degrees(s["mean"]), "omega_sd_deg": np.degrees(s["sd"]),
               "omega_mean_abs_deg": np.degrees(s["mean_abs"]), "vtec_mean_tecu": s["vtec"] / 1e16,
               "stec_mean_tecu": s["stec"] / 1e16, "range_delay_mean_m": s["range_delay"],
               "b_dot_k_mean_ut": s["b_dot_k"] * 1e6, "f107_sfu": np.broadcast_to(self.f107, (n,)).astype(float),
               "frequency_mhz": np.broadcast_to(self.frequency_hz, (n,)) / 1e6,
               "tec_variability": np.full(n, float(self.variability))}
        for k, p in enumerate(PERCENTILES):
            out[f"omega_p{p:g}_deg".replace(".", "_")] = np.degrees(s["percentiles"][:, k])
        return out

    def scalars(self) -> dict:
        """Output scalars of one case: those of any distribution and the ``summary`` of the climatology."""
        return {name: float(column[0]) for name, column in self.scalar_columns().items()}

    def summary(self) -> dict:
        """Scalars for reports of one case: Omega mean, SD, mean |Omega|, percentiles (deg); TEC (TECU); delays."""
        out = self.scalars()
        del out["mean_deg"], out["sd_deg"]
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
