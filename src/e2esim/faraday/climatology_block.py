"""The Faraday-rotation climatologies of a block of map cases at once (``e2esim.block.Batched``).

What the ``global_climatology`` ionosphere provides as ``faraday.geophysical`` for a block of a map sweep: per
case, the path integrals of its cell's swath positions (NaN where the pass cannot see the cell), from which
``cell_climatology`` makes the one-case ``FaradayClimatology`` (``item``). The statistics every case needs
(the output scalars, the circular moments of the error model) are computed for the whole block with the
one-case formulas and a leading case axis, cases grouped by how many swath positions see their cell (their
sample count): Omega = A F / f^2 (Quegan et al. 2018, eq. 3), samples Omega_i X_j with the log-normal nodes
X_j of the day-to-day TEC variability (Rishbeth & Mendillo 2001; ``e2esim.ionosphere.variability``), the
weighted mean, SD and percentiles of ``EmpiricalFaraday`` and the circular moments phi_k = E[exp(i k Omega)]
(Men et al. 2021, eqs. 9-10).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from e2esim.block import Batched
from e2esim.faraday.climatology import FaradayClimatology, climatology_from_integrals
from e2esim.faraday.distribution import EVEN_NODES, EVEN_WEIGHTS, PERCENTILES
from e2esim.ionosphere.propagation import faraday_rotation_integral, range_delay
from e2esim.ionosphere.slant import PathIntegrals
from e2esim.ionosphere.variability import lognormal_nodes

_EVEN_HARMONICS = np.array([2.0, 4.0, 6.0, 8.0])  # the phi_k behind FaradayDistribution.even_quadrature


def cell_climatology(faraday, stec, vtec, frequency_hz: float, f107: float, variability: float, nodes: int,
                     method: str, pass_label: str, lat_deg: float, lon_deg: float, month: int) -> FaradayClimatology:
    """The ``FaradayClimatology`` of one map cell from its path integrals per swath position (F in T el/m^2,
    slant and vertical TEC in el/m^2; NaN where the pass cannot see the cell), as the site climatologies give
    (``climatology_from_integrals``)."""
    seen = np.isfinite(faraday)
    n = int(seen.sum())
    integrals = PathIntegrals(vtec[seen][None], stec[seen][None], faraday[seen][None], np.full(n, np.nan),
                              np.full(n, np.nan), (f107,), method)
    where = f"{lat_deg:g}N {lon_deg:g}E"
    return climatology_from_integrals(
        integrals, 0, frequency_hz, variability, nodes, None, [pass_label] * n, where,
        label=f"global climatology {where}, month {month}, {pass_label}, F10.7 {f107:g} sfu")


@dataclass(frozen=True, eq=False)
class FaradayClimatologyBlock(Batched):
    """The ``FaradayClimatology`` of B map cases (module docstring).

    faraday, stec, vtec : (B, swath positions) path integrals of each case's cell (NaN: not seen).
    frequency_hz, f107 (sfu), lat_deg, lon_deg, month : (B,). pass_label : (B,) text. variability, nodes,
    method : the settings every case shares (TEC coefficient of variation, log-normal nodes, slant method).
    """

    faraday: np.ndarray
    stec: np.ndarray
    vtec: np.ndarray
    frequency_hz: np.ndarray
    f107: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    month: np.ndarray
    pass_label: np.ndarray
    variability: float
    nodes: int
    method: str
    _memo: dict = field(default_factory=dict, init=False, repr=False, compare=False)  # a fresh one per take, join

    def __len__(self) -> int:
        return len(self.faraday)

    def item(self, i: int) -> FaradayClimatology:
        """Case i's ``FaradayClimatology``, made once per block: a map cell's case is asked for it by every product
        that holds it (the error model, its wrappers, the AGB error, the kept products), which share it as the
        per-case engine shares one climatology between the stages of a case."""
        items = self._memo.setdefault("items", {})
        i = int(i)
        if i not in items:
            items[i] = cell_climatology(self.faraday[i], self.stec[i], self.vtec[i], float(self.frequency_hz[i]),
                                        float(self.f107[i]), self.variability, self.nodes, self.method,
                                        str(self.pass_label[i]), float(self.lat_deg[i]), float(self.lon_deg[i]),
                                        int(self.month[i]))
        return items[i]

    # What the stages and writers read, for every case ------------------------------------------------------
    def scalar_columns(self) -> dict:
        """``FaradayClimatology.scalars`` of every case: {name: (B,)}, in its order."""
        s = self._statistics()
        out = {"mean_deg": np.degrees(s["mean"]), "sd_deg": np.degrees(s["sd"]),
               "omega_mean_deg": np.degrees(s["mean"]), "omega_sd_deg": np.degrees(s["sd"]),
               "omega_mean_abs_deg": np.degrees(s["mean_abs"]), "vtec_mean_tecu": s["vtec"] / 1e16,
               "stec_mean_tecu": s["stec"] / 1e16, "range_delay_mean_m": s["range_delay"],
               "b_dot_k_mean_ut": s["b_dot_k"] * 1e6, "f107_sfu": self.f107.astype(float),
               "frequency_mhz": self.frequency_hz / 1e6, "tec_variability": np.full(len(self), float(self.variability))}
        for k, p in enumerate(PERCENTILES):
            out[f"omega_p{p:g}_deg".replace(".", "_")] = np.degrees(s["percentiles"][:, k])
        return out

    def even_quadrature(self) -> tuple:
        """``FaradayDistribution.even_quadrature`` of every case: the nodes u_j = cos 2 Omega_j (5,) and the
        weights (B, 5), ``sum_j w_j u_j^k = E[u^k]``, k = 0..4."""
        return EVEN_NODES, self._even_weights()

    def _even_weights(self) -> np.ndarray:
        """The weights of ``even_quadrature`` from phi_2, phi_4, phi_6, phi_8."""
        phi = self._statistics()["phi"]
        moments = np.stack([np.ones(len(self)), phi[:, 0], (1 + phi[:, 1]) / 2, (3 * phi[:, 0] + phi[:, 2]) / 4,
                            (3 + 4 * phi[:, 1] + phi[:, 3]) / 8], axis=-1)
        return np.matmul(EVEN_WEIGHTS[None], moments[:, :, None])[:, :, 0]  # EVEN_WEIGHTS @ moments, case by case

    def trig_moments(self) -> dict:
        """``FaradayDistribution.trig_moments`` of every case, Men et al. (2021), eq. (9a-d): {name: (B,)}."""
        s = self._statistics()
        cos2, cos4, sin2 = s["phi2"].real, s["phi4"].real, s["phi2"].imag
        return {"c4": (3 + 4 * cos2 + cos4) / 8, "s4": (3 - 4 * cos2 + cos4) / 8, "c2s2": (1 - cos4) / 8,
                "cs": sin2 / 2}

    @property
    def mean_rad(self) -> np.ndarray:
        """The mean of Omega of every case (rad), (B,)."""
        return self._statistics()["mean"]

    @property
    def sd_rad(self) -> np.ndarray:
        """The SD of Omega of every case (rad), (B,)."""
        return self._statistics()["sd"]

    # The statistics, by sample count ---------------------------------------------------------------------
    def _statistics(self) -> dict:
        if "statistics" not in self._memo:
            self._memo["statistics"] = self._compute()
        return self._memo["statistics"]

    def _compute(self) -> dict:
        """Per case: mean, SD and mean |Omega| (rad), the acquisition means of vertical and slant TEC (el/m^2),
        range delay (m) and B.k (T), the ``PERCENTILES`` of Omega (rad), Re phi_k for k = 2, 4, 6, 8 evaluated
        together (``even_quadrature``) and phi_2, phi_4 each alone (``trig_moments``), with the operations of
        ``climatology_from_integrals`` and ``EmpiricalFaraday``."""
        n_cases = len(self)
        out = {name: np.full(n_cases, np.nan) for name in ("mean", "sd", "mean_abs", "vtec", "stec", "range_delay",
                                                           "b_dot_k")}
        out["percentiles"] = np.full((n_cases, len(PERCENTILES)), np.nan)
        out["phi"] = np.full((n_cases, _EVEN_HARMONICS.size), np.nan)
        out["phi2"], out["phi4"] = np.full(n_cases, np.nan, complex), np.full(n_cases, np.nan, complex)
        x = lognormal_nodes(self.variability, self.nodes)
        seen = np.isfinite(self.faraday)
        count = seen.sum(-1)
        for n in np.unique(count[count > 0]):
            rows = np.flatnonzero(count == n)
            mask = seen[rows]
            far, stec, vtec = (getattr(self, a)[rows][mask].reshape(rows.size, n) for a in ("faraday", "stec", "vtec"))
            f = self.frequency_hz[rows][:, None]
            w_acq = np.full(n, 1.0 / n)
            weights = np.repeat(w_acq / w_acq.sum(), x.size) / x.size
            w = weights / weights.sum()  # EmpiricalFaraday's normalised weights, equal for every case of the group
            samples = (faraday_rotation_integral(far, f)[:, :, None] * x[None, None, :]).reshape(rows.size, -1)
            mean = _row_dot(samples, w)
            out["mean"][rows] = mean
            out["sd"][rows] = np.sqrt(_row_dot((samples - mean[:, None]) ** 2, w))
            out["mean_abs"][rows] = _row_dot(np.abs(samples), w)
            acq = w_acq / w_acq.sum()
            with np.errstate(invalid="ignore", divide="ignore"):
                b_dot_k = np.where(stec > 0, far / stec, np.nan)
            out["vtec"][rows], out["stec"][rows] = _row_dot(vtec, acq), _row_dot(stec, acq)
            out["range_delay"][rows], out["b_dot_k"][rows] = _row_dot(range_delay(stec, f), acq), _row_dot(b_dot_k, acq)
            out["percentiles"][rows] = _percentiles(np.sort(samples, axis=-1), w)
            # circular moments as EmpiricalFaraday.circular_moment: k = 2, 4, 6, 8 together; k = 2 and 4 alone
            wc = w.astype(complex)
            out["phi"][rows] = (np.exp(1j * _EVEN_HARMONICS[:, None] * samples[:, None, :]) @ wc).real
            for k in (2, 4):
                out[f"phi{k}"][rows] = _row_dot(np.exp(1j * np.asarray(float(k))[..., None] * samples), wc)
        return out


def _row_dot(a: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``np.dot(w, row)`` of every row of ``a`` (G, m), bit for bit: a stack of (1, m) x (m, 1) products is
    reduced as the one-case dot is, where ``a @ w`` need not be."""
    return np.matmul(a[:, None, :], w[None, :, None])[:, 0, 0]


def _percentiles(sorted_samples: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``weighted_percentiles`` of every row of ``sorted_samples`` (G, m) with the same weights ``w`` (m,) for
    every row: the inverse of the weighted empirical CDF, linear between the mid-points of the probability
    masses, with ``numpy.interp``'s arithmetic (its ends, its exact nodes, its slope)."""
    w = w / w.sum()
    cdf = np.cumsum(w) - w / 2
    out = np.empty((len(sorted_samples), len(PERCENTILES)))
    for k, p in enumerate(PERCENTILES):
        q = p / 100.0
        j = int(np.searchsorted(cdf, q, side="right")) - 1
        if j < 0:
            out[:, k] = sorted_samples[:, 0]
        elif j >= cdf.size - 1:
            out[:, k] = sorted_samples[:, -1]
        elif cdf[j] == q:
            out[:, k] = sorted_samples[:, j]
        else:
            slope = (sorted_samples[:, j + 1] - sorted_samples[:, j]) / (cdf[j + 1] - cdf[j])
            out[:, k] = slope * (q - cdf[j]) + sorted_samples[:, j]
    return out


__all__ = ["FaradayClimatologyBlock", "cell_climatology"]
