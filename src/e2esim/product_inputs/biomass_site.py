"""One pixel of a BIOMASS L1 product: the LUT layers and annotation figures a product-driven scenario reads.

The names, units and axes are those of ``e2esim.products_io.biomass_layout`` (BioPAL BPS v4.3.0,
``l1_lut_writer.write_lut_file`` and the L1 annotation XSDs), so a file the uncertainty product reads is read the
same way here. A pixel is picked on the LUT's geometry grid (RGC axes: ``geometry/latitude``, ``longitude``): the
pixel nearest to a site, or the scene centre. A layer on the SLC axes is interpolated bilinearly onto the RGC grid
in (azimuth time, slant-range time), as ``e2esim.products_io.biomass_l1`` does; values equal to the LUT's
``noDataValueFloat`` are no data.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from e2esim.extras import optional_import
from e2esim.input_files import check_regular
from e2esim.products_io import biomass_layout as layout
from e2esim.products_io.pixels import ProductFileError, check_units

EARTH_RADIUS_M = 6371008.8
"""Mean Earth radius (IUGG), for the distance from a site to a pixel: the test is against the grid's own spacing."""
OUTSIDE_SPACINGS = 1.5
"""A site farther than this many pixel spacings from its nearest pixel lies outside the product."""


@dataclass(frozen=True)
class LUTLayers:
    """Layers of one BIOMASS L1 LUT on its geometry grid. latitude, longitude : (rows, columns) in degrees.
    layers : {"group/variable": (rows, columns) float64, NaN where no data}. slant_range_time : (columns,) the
    two-way slant-range time of each column (s, ``slantRangeTimeRGC``). path : the LUT file."""

    path: str
    latitude: np.ndarray
    longitude: np.ndarray
    layers: dict
    slant_range_time: np.ndarray

    def centre(self) -> tuple:
        """(row, column) of the scene centre."""
        rows, cols = self.latitude.shape
        return rows // 2, cols // 2

    def pixel_of(self, lat_deg: float, lon_deg: float) -> tuple:
        """(row, column) of the pixel nearest to (lat_deg, lon_deg); ``ProductFileError`` if the site lies outside
        the product (farther than ``OUTSIDE_SPACINGS`` pixel spacings from every pixel)."""
        distance = _distance_m(lat_deg, lon_deg, self.latitude, self.longitude)
        row, col = np.unravel_index(int(np.nanargmin(distance)), distance.shape)
        if not distance[row, col] <= OUTSIDE_SPACINGS * self._spacing_m(row, col):
            raise ProductFileError(
                f"{self.path}: the site at latitude {lat_deg:g}, longitude {lon_deg:g} deg lies outside the product "
                f"(nearest pixel {distance[row, col] / 1e3:.3g} km away; the product covers latitude "
                f"{np.nanmin(self.latitude):.4g} to {np.nanmax(self.latitude):.4g}, longitude "
                f"{np.nanmin(self.longitude):.4g} to {np.nanmax(self.longitude):.4g} deg)")
        return int(row), int(col)

    def _spacing_m(self, row: int, col: int) -> float:
        rows, cols = self.latitude.shape
        steps = [(row + dr, col + dc) for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1))
                 if 0 <= row + dr < rows and 0 <= col + dc < cols]
        return max(float(_distance_m(self.latitude[row, col], self.longitude[row, col], self.latitude[p],
                                     self.longitude[p])) for p in steps) if steps else 0.0


def _distance_m(lat_deg, lon_deg, lat, lon):
    """Great-circle distance (haversine) on the mean sphere, metres."""
    p1, p2 = np.radians(lat_deg), np.radians(lat)
    dl = np.radians(np.asarray(lon) - lon_deg)
    h = np.sin((p2 - p1) / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_M * np.arcsin(np.sqrt(np.clip(h, 0.0, 1.0)))


def read_lut_layers(path, names) -> LUTLayers:
    """The layers ``names`` ("group/variable" of ``biomass_layout.LUT_VARIABLES`` or ``SCENARIO_LUT_VARIABLES``) of
    the LUT at ``path``, each checked against the layout (present, units, axes) and put on the geometry grid."""
    path = Path(path)
    with open_lut(path) as ds:
        if layout.LUT_NO_DATA_ATTRIBUTE not in ds.ncattrs():
            raise ProductFileError(f"{path}: global attribute {layout.LUT_NO_DATA_ATTRIBUTE!r} is missing; the BPS "
                                   "LUT writer sets it")
        no_data = ds.getncattr(layout.LUT_NO_DATA_ATTRIBUTE)
        axes = {name: lut_axis(path, ds, name) for name in (*layout.RGC_AXES, *layout.SLC_AXES)}
        latitude = _layer(path, ds, "geometry/latitude", no_data)
        longitude = _layer(path, ds, "geometry/longitude", no_data)
        layers = {}
        for name in names:
            values = _layer(path, ds, name, no_data)
            if ds[name].dimensions == layout.SLC_AXES:
                values = _onto_rgc(values, axes)
            layers[name] = values
    return LUTLayers(str(path), latitude, longitude, layers, axes[layout.RGC_AXES[1]])


def open_lut(path):
    """The LUT NetCDF at ``path`` opened for reading (a ``netCDF4.Dataset``), checked to be a regular file;
    ``ProductFileError`` if it is not NetCDF-4 (``e2esim.products_io.biomass_l1`` opens it the same way)."""
    check_regular(path, "BIOMASS LUT", ProductFileError)
    netcdf4 = optional_import("netCDF4", "products", "reading a BIOMASS L1 LUT (NetCDF)")
    try:
        return netcdf4.Dataset(str(path), "r")
    except OSError as exc:
        raise ProductFileError(f"{path}: cannot be read as NetCDF-4 ({exc}); the file is truncated or not a "
                               "BIOMASS L1 LUT") from None


def _layer(path, ds, name: str, no_data) -> np.ndarray:
    group, variable = name.split("/")
    units, axes = {**layout.LUT_VARIABLES.get(group, {}), **layout.SCENARIO_LUT_VARIABLES.get(group, {})}[variable]
    if group not in ds.groups:
        raise ProductFileError(f"{path}: group {group!r} is missing, so the product holds no {name}; the BPS LUT "
                               f"writer adds it only when the processor computed it; take {variable} from elsewhere")
    if variable not in ds.groups[group].variables:
        raise ProductFileError(f"{path}: variable {name} is missing; the BPS LUT writer writes it with axes "
                               f"{' x '.join(axes)}")
    var = ds.groups[group].variables[variable]
    check_units(path, name, getattr(var, "units", None), units)
    if tuple(var.dimensions) != axes:
        raise ProductFileError(f"{path}: {name}: dimensions {var.dimensions}; expected {axes}")
    raw = var[:, :]
    raw = raw.filled(np.nan) if np.ma.isMaskedArray(raw) else np.asarray(raw)
    values = np.asarray(raw, dtype=np.float64)
    return np.where(values == no_data, np.nan, values)


def lut_axis(path, ds, name) -> np.ndarray:
    """The 1-D time axis ``name`` of the LUT (s), checked: present, in seconds, increasing."""
    if name not in ds.variables:
        raise ProductFileError(f"{path}: axis variable {name!r} is missing; the BPS LUT writer writes it")
    check_units(path, name, getattr(ds.variables[name], "units", None), layout.AXIS_UNITS)
    values = np.asarray(ds.variables[name][:], dtype=np.float64)
    if values.size < 2 or np.any(np.diff(values) <= 0):
        raise ProductFileError(f"{path}: {name}: not increasing; an axis of at least two increasing times is expected")
    return values


def _onto_rgc(values, axes) -> np.ndarray:
    """Bilinear interpolation of an SLC-axes layer onto the RGC grid (the layer itself where the axes agree); NaN
    outside the SLC axes and where a neighbour holds no data."""
    az_slc, rg_slc = axes[layout.SLC_AXES[0]], axes[layout.SLC_AXES[1]]
    az_rgc, rg_rgc = axes[layout.RGC_AXES[0]], axes[layout.RGC_AXES[1]]
    if np.array_equal(az_slc, az_rgc) and np.array_equal(rg_slc, rg_rgc):
        return values
    (i, wi), (j, wj) = _bracket(az_slc, az_rgc), _bracket(rg_slc, rg_rgc)
    wi, wj = wi[:, None], wj[None, :]
    return ((1 - wi) * ((1 - wj) * values[np.ix_(i, j)] + wj * values[np.ix_(i, j + 1)])
            + wi * ((1 - wj) * values[np.ix_(i + 1, j)] + wj * values[np.ix_(i + 1, j + 1)]))


def _bracket(axis, wanted):
    """(lower index, weight of the upper neighbour) of each ``wanted`` on the increasing ``axis``; NaN weight
    outside it."""
    i = np.clip(np.searchsorted(axis, wanted, "right") - 1, 0, axis.size - 2)
    w = (wanted - axis[i]) / (axis[i + 1] - axis[i])
    return i, np.where((wanted >= axis[0]) & (wanted <= axis[-1]), w, np.nan)


__all__ = ["LUTLayers", "lut_axis", "open_lut", "read_lut_layers"]
