"""The screens and mixture quantiles of many sites at once: ``acquisitions`` vectorised over the cases of a block.

A block of a map sweep holds hundreds of cases, each with a few acquisitions (``cell``). Per case, the screens
(``acquisitions.acquisition_screens``) and the three bisections of ``acquisitions.mixture_quantiles`` cost a few
milliseconds of small numpy calls; here the cases that share their screen settings, orbit and number of acquisitions
are stacked into arrays (cases, acquisitions) and go through the same equations once (docs/theory/scintillation.md,
eqs. S11-S17). Every operation is elementwise, a reduction over the acquisitions axis alone, or a matrix product per
acquisition, and the bisection takes the same 60 halvings per row as the scalar one, so each case's numbers are, bit
for bit, those it gets alone (tests/test_scintillation_stacked.py).
"""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np
from scipy.special import erf, gammainc

from e2esim.scintillation.acquisitions import AcquisitionScreens, acquisition_screens, quantile_scalars
from e2esim.scintillation.cell import CellAcquisitions


def stack_acquisitions(geometries: list) -> CellAcquisitions:
    """``geometries`` (``AcquisitionGeometry`` or ``CellAcquisitions``, same orbit radius and number of acquisitions)
    as one ``CellAcquisitions`` whose arrays are (cases, n): what ``acquisition_screens`` reads of them."""
    names = ("pierce_lat", "pierce_lon", "incidence", "local_time_h", "time_utc", "weight")
    return CellAcquisitions(geometries[0].orbit, *(np.stack([np.asarray(getattr(g, n)) for g in geometries])
                                                      for n in names))


def row(screens: AcquisitionScreens, i: int) -> AcquisitionScreens:
    """Site ``i`` of stacked screens."""
    return rows(screens, [i])[0]


def rows(screens: AcquisitionScreens, positions) -> list:
    """Sites ``positions`` of stacked screens (``row`` of each; the fields looked up once)."""
    values = {f.name: getattr(screens, f.name) for f in fields(screens)}
    arrays = [name for name, value in values.items() if isinstance(value, np.ndarray)]
    return [AcquisitionScreens(**{**values, **{name: values[name][i] for name in arrays}}) for i in positions]


def stacked_screens(geometries: list, settings: list, site_lat=None, site_lon=None) -> list:
    """``[acquisition_screens(g, s, site_lat, site_lon) for g, s in zip(geometries, settings)]``, the cases with the
    same settings, orbit radius and number of acquisitions computed together (module docstring)."""
    groups: dict = {}
    for i, (g, s) in enumerate(zip(geometries, settings)):
        groups.setdefault((s, float(g.orbit.radius_m), np.shape(g.incidence)), []).append(i)
    out = [None] * len(geometries)
    for (s, _, _), members in groups.items():
        stacked = acquisition_screens(stack_acquisitions([geometries[i] for i in members]), s, site_lat, site_lon)
        for i, screens in zip(members, rows(stacked, range(len(members)))):
            out[i] = screens
    return out


def stacked_halo_shares(screens: list, cell_cells: float) -> list:
    """``[s.halo_share(cell_cells) for s in screens]`` (eq. S19), the screens with the same number of acquisitions,
    spectral index and outer scale computed together."""
    groups: dict = {}
    for i, s in enumerate(screens):
        groups.setdefault((np.shape(s.scan_length_m), s.spectral_index, s.outer_scale_m), []).append(i)
    out = [None] * len(screens)
    for members in groups.values():
        first = screens[members[0]]
        stacked = replace(first, scan_length_m=np.stack([screens[i].scan_length_m for i in members]))
        for i, q in zip(members, stacked.halo_share(cell_cells)):
            out[i] = q
    return out


def stacked_weighted_sums(screens: list, names: tuple) -> list:
    """``[{name: np.sum(s.weight * getattr(s, name)) for name in names} for s in screens]``, the screens with the same
    number of acquisitions summed together: a row's sum along the contiguous last axis of a C-contiguous (sites, n)
    array is that of the row alone (tests/test_scintillation_stacked.py)."""
    groups: dict = {}
    for i, s in enumerate(screens):
        groups.setdefault(np.shape(s.weight), []).append(i)
    out = [{} for _ in screens]
    for members in groups.values():
        weight = np.stack([screens[i].weight for i in members])
        for name in names:
            sums = np.sum(weight * np.stack([getattr(screens[i], name) for i in members]), axis=-1)
            for i, value in zip(members, sums):
                out[i][name] = value
    return out


def bisect_rows(cdf, prob: float, high: np.ndarray, steps: int = 60) -> np.ndarray:
    """``acquisitions._bisect`` on every row at once: the same halvings, so the same numbers."""
    lo, hi = np.zeros_like(high), np.array(high, dtype=float)
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        below = cdf(mid) < prob
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


def stacked_mixture_quantiles(screens: list, prob: float) -> list:
    """``[mixture_quantiles(s, prob) for s in screens]`` (eq. S17), the screens with the same number of acquisitions
    inverted together (``bisect_rows``)."""
    groups: dict = {}
    for i, s in enumerate(screens):
        groups.setdefault(np.shape(s.weight), []).append(i)
    out = [None] * len(screens)
    for members in groups.values():
        for i, q in zip(members, _quantile_rows([screens[i] for i in members], prob)):
            out[i] = q
    return out


def _quantile_rows(screens: list, prob: float) -> list:
    w, k, theta, shift_sd, quad_sd = (np.stack([getattr(s, n) for s in screens]) for n in (
        "weight", "shape", "scale", "shift_sd_cells", "quadratic_sd_rad"))
    safe_theta = np.where(theta > 0.0, theta, 1.0)

    def cdf_y(y):
        return np.sum(w * np.where(theta > 0.0, gammainc(k, y[:, None] / safe_theta), 1.0), axis=-1)

    def half_normal(sd):
        safe = math.sqrt(2.0) * np.where(sd > 0, sd, 1)
        return lambda x: np.sum(w * np.where(sd > 0.0, erf(x[:, None] / safe), 1), axis=-1)

    y = bisect_rows(cdf_y, prob, np.max(k * theta + 12.0 * np.sqrt(k) * theta, axis=-1, initial=0.0) + 1e-12)
    shift = bisect_rows(half_normal(shift_sd), prob, 8.0 * np.max(shift_sd, axis=-1) + 1e-12)
    quad_q = bisect_rows(half_normal(quad_sd), prob, 8.0 * np.max(quad_sd, axis=-1) + 1e-12)
    return [quantile_scalars(float(a), float(b), float(c)) for a, b, c in zip(y, shift, quad_q)]


__all__ = ["bisect_rows", "stack_acquisitions", "stacked_halo_shares",
           "stacked_mixture_quantiles", "stacked_screens", "stacked_weighted_sums"]
