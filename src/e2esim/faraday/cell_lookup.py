"""Faraday rotation of one map cell, looked up in the global climatology table instead of integrated again.

The table (``e2esim.faraday.global_climatology``) holds, per pass, solar level, month, swath position and grid
cell, the path integrals F = int N_e B.k ds, the slant and the vertical TEC of the ray from the cell centre to
the satellite (the IRI monthly median on the 15th at the pass's local time; Quegan et al. 2018, eq. 3 for
Omega = A F / f^2). A map sweep needs one month of it at a time: ``month_table`` computes the table of one
month, both passes and one solar level once per process (the process's kernel memo, handed in through the
services) and through the array cache once per machine, and
every case of that month looks its cell up with ``cell_integrals``, vectorised over any number of cells, so
that the cases of a map sweep cost no ionospheric integration of their own.
"""

from __future__ import annotations

import json

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.faraday.global_climatology import GlobalClimatology, global_climatology
from e2esim.orbit.sunsync import PASSES

MAX_TABLES = 32
"""Tables kept in memory per process (a 1 deg global month, both passes, three swath positions: 4.7 MB)."""


def month_table(orbit, step_deg: float, month: int, f107: float, incidence_deg, settings, lat_range=(-90.0, 90.0),
                lon_range=(-180.0, 180.0), cache=None, executor=None, progress=None, memo=None) -> GlobalClimatology:
    """The global climatology table of one ``month`` (1-12), both passes (``PASSES``) and one solar level
    ``f107`` (sfu) at ``incidence_deg`` (swath positions): from ``memo`` (the process's ``KernelMemo``, which
    keeps the last ``MAX_TABLES``), else from ``cache``, else computed (``global_climatology``). Cases of a map
    sweep share it."""

    def compute():
        return global_climatology(orbit, step_deg, months=(int(month),), passes=PASSES, f107=(float(f107),),
                                  incidence_deg=tuple(float(i) for i in incidence_deg), settings=settings,
                                  executor=executor, cache=cache, progress=progress, lat_range=tuple(lat_range),
                                  lon_range=tuple(lon_range))

    if memo is None:
        return compute()
    key = json.dumps([repr(orbit), float(step_deg), int(month), float(f107), [float(i) for i in incidence_deg],
                      repr(settings), [float(x) for x in lat_range], [float(x) for x in lon_range]])
    return memo.recall(("month table", key), compute, keep=MAX_TABLES)


def cell_index(axis_deg: np.ndarray, value_deg, periodic: bool = False) -> tuple:
    """Index of the grid cell of the regular ``axis_deg`` (cell centres, ascending) that contains each value, and
    whether the value lies inside the grid (a periodic axis wraps longitudes round the globe)."""
    axis = np.asarray(axis_deg, float)
    value = np.asarray(value_deg, float)
    step = axis[1] - axis[0] if axis.size > 1 else 360.0
    start = axis[0] - step / 2
    if periodic:
        value = start + np.mod(value - start, 360.0)
    k = np.floor((value - start) / step + 1e-9).astype(int)
    inside = (k >= 0) & (k < axis.size)
    return np.clip(k, 0, axis.size - 1), inside


def cell_integrals(table: GlobalClimatology, pass_index, lat_deg, lon_deg, solar_index=0, month_index=0) -> dict:
    """F (T el/m^2), slant and vertical TEC (el/m^2) of the cells containing (lat, lon) (deg, broadcast over
    cases) for ``pass_index`` into ``PASSES``: arrays (..., n_swath), float64, NaN where the pass cannot see the
    cell. Raises ``PhysicsInputError`` (key ``lat_deg`` or ``lon_deg``) for a point outside the table's grid."""
    lon_global = table.lon_deg.size * (table.lon_deg[1] - table.lon_deg[0] if table.lon_deg.size > 1 else 360.0)
    i, lat_in = cell_index(table.lat_deg, lat_deg)
    j, lon_in = cell_index(table.lon_deg, lon_deg, periodic=abs(lon_global - 360.0) < 1e-6)
    if not np.all(lat_in):
        raise PhysicsInputError(f"latitude {_first(lat_deg, lat_in)} deg is outside the climatology table's grid "
                                f"({_edges(table.lat_deg)} deg)", key="lat_deg")
    if not np.all(lon_in):
        raise PhysicsInputError(f"longitude {_first(lon_deg, lon_in)} deg is outside the climatology table's grid "
                                f"({_edges(table.lon_deg)} deg)", key="lon_deg")
    p = np.asarray(pass_index)
    # (pass, swath, lat, lon) indexed by arrays round a slice: the case axes come first, then the swath
    return {name: getattr(table, name)[:, solar_index, month_index][p, :, i, j].astype(float)
            for name in ("faraday", "stec", "vtec")}


def _first(values, ok) -> str:
    v = np.broadcast_to(np.asarray(values, float), np.shape(ok))
    return f"{v[~ok].ravel()[0]:g}"


def _edges(axis) -> str:
    step = axis[1] - axis[0] if axis.size > 1 else 0.0
    return f"{axis[0] - step / 2:g} to {axis[-1] + step / 2:g}"
