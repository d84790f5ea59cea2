"""A user's latitude-longitude raster (an RFI-affected fraction, an acquisition mask): one 2-D variable over 1-D
latitude and longitude axes (degrees) in a NetCDF-4/HDF5 file, read with xarray (netCDF4 engine; nothing is
unpickled or executed), looked up at the pixel that contains a point.

Layout: a variable ``variable`` with two dimensions named like latitude (lat, latitude, y) and longitude (lon,
longitude, x), each with a coordinate of that name, ascending or not, longitudes in [-180, 360). Values outside
[``lower``, ``upper``] (infinities included) are refused, naming the file, the variable and the first bad pixel;
NaN (a fill value) is a pixel without data.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from e2esim.errors import PhysicsInputError
from e2esim.extras import optional_import
from e2esim.input_files import NotARegularFile, regular_file_stat
from e2esim.scene.agb_map import MAX_MAP_PIXELS

LAT_NAMES = ("lat", "latitude", "y")
LON_NAMES = ("lon", "longitude", "x")


@dataclass(frozen=True)
class LatLonRaster:
    """Values (n_lat, n_lon) on pixel centres ``lat_deg`` and ``lon_deg`` (both ascending, longitudes in
    [-180, 180)); ``source``: the file."""

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    values: np.ndarray
    source: str = ""

    def lookup(self, lat_deg, lon_deg, outside: float = np.nan) -> np.ndarray:
        """Value of the pixel nearest to each point (deg, broadcast); ``outside`` beyond half a pixel of the
        raster's extent (longitudes wrap round a global raster)."""
        lat, lon = np.broadcast_arrays(np.asarray(lat_deg, float), np.mod(np.asarray(lon_deg, float) + 180.0, 360.0)
                                       - 180.0)
        i, in_lat = _nearest(self.lat_deg, lat, periodic=False)
        j, in_lon = _nearest(self.lon_deg, lon, periodic=self._global_lon())
        return np.where(in_lat & in_lon, self.values[i, j], outside)

    def _global_lon(self) -> bool:
        step = float(np.median(np.diff(self.lon_deg)))
        return bool(abs(self.lon_deg.size * step - 360.0) <= 0.5 * step)


def _nearest(axis, x, periodic: bool):
    """Index of the nearest centre of ``axis`` (ascending, >= 2 points) and whether ``x`` is within half a pixel."""
    step = float(np.median(np.diff(axis)))
    if periodic:
        d = np.abs(np.mod(x[..., None] - axis + 180.0, 360.0) - 180.0)
        return np.argmin(d, axis=-1), np.ones(x.shape, bool)
    k = np.clip(np.rint((x - axis[0]) / step).astype(int), 0, axis.size - 1)
    return k, (x >= axis[0] - step / 2) & (x <= axis[-1] + step / 2)


def read_lat_lon_raster(path, variable: str, what: str, lower: float, upper: float, key: str = "file") -> LatLonRaster:
    """The raster ``variable`` of the NetCDF file ``path`` (module docstring); ``what`` names it in messages.
    Raises ``PhysicsInputError`` (at ``key``) for a file that is missing, not NetCDF, or of the wrong layout."""
    path = Path(path).expanduser()
    try:
        regular_file_stat(path)
    except NotARegularFile as exc:
        raise PhysicsInputError(f"the {what} {str(path)!r} is {exc.kind}, not a regular file", key=key) from exc
    except OSError as exc:
        raise PhysicsInputError(f"cannot read the {what} {str(path)!r}: {exc.strerror or exc}; give a NetCDF file "
                                f"with a variable {variable!r} over lat and lon", key=key) from exc
    xr = optional_import("xarray", "maps", f"reading the {what}")
    optional_import("netCDF4", "maps", f"reading the {what}")
    try:
        with xr.open_dataset(path, engine="netcdf4", decode_times=False, mask_and_scale=True) as ds:
            if variable not in ds.data_vars:
                raise PhysicsInputError(f"the {what} {str(path)!r} has no variable {variable!r}; its variables: "
                                        + (", ".join(map(str, ds.data_vars)) or "none"), key=key)
            da = ds[variable]
            dims = [next((d for d in da.dims if str(d).lower() in names), None) for names in (LAT_NAMES, LON_NAMES)]
            if da.ndim != 2 or None in dims:
                raise PhysicsInputError(f"the variable {variable!r} of the {what} {str(path)!r} has dimensions "
                                        f"{tuple(map(str, da.dims))}; expected two: latitude and longitude", key=key)
            if da.size > MAX_MAP_PIXELS:
                raise PhysicsInputError(f"the {what} {str(path)!r} has {da.size:,} pixels, above the limit of "
                                        f"{MAX_MAP_PIXELS:,}", key=key)
            da = da.transpose(*dims)
            lat = np.asarray(da[dims[0]].values, float)
            lon = np.asarray(da[dims[1]].values, float)
            values = np.asarray(da.values, float)
    except PhysicsInputError:
        raise
    except Exception as exc:  # the libraries' own errors on a file that is not NetCDF
        raise PhysicsInputError(f"cannot read the {what} {str(path)!r} as NetCDF: {type(exc).__name__}: {exc}",
                                key=key) from exc
    return _checked(str(path), what, variable, lat, lon, values, lower, upper, key)


def _checked(path, what, variable, lat, lon, values, lower, upper, key) -> LatLonRaster:
    if lat.size < 2 or lon.size < 2 or not (np.all(np.isfinite(lat)) and np.all(np.isfinite(lon))):
        raise PhysicsInputError(f"the {what} {path!r} needs finite latitude and longitude axes of two or more "
                                "pixels each", key=key)
    if np.any(np.abs(lat) > 90.0):
        raise PhysicsInputError(f"the {what} {path!r} has latitudes outside [-90, 90] deg", key=key)
    lon = np.mod(lon + 180.0, 360.0) - 180.0
    i, j = np.argsort(lat), np.argsort(lon)
    lat, lon, values = lat[i], lon[j], values[np.ix_(i, j)]
    if np.any(np.diff(lat) <= 0) or np.any(np.diff(lon) <= 0):
        raise PhysicsInputError(f"the {what} {path!r} repeats a latitude or longitude", key=key)
    with np.errstate(invalid="ignore"):
        bad = np.isinf(values) | (values < lower) | (values > upper)
    if bad.any():
        a, b = np.argwhere(bad)[0]
        raise PhysicsInputError(f"the {what} {path!r}: {variable} is {values[a, b]!r} at latitude {lat[a]:g}, "
                                f"longitude {lon[b]:g} deg ({int(bad.sum())} such pixels); expected values from "
                                f"{lower:g} to {upper:g}", key=key)
    values.setflags(write=False)
    return LatLonRaster(lat, lon, values, path)


__all__ = ["LatLonRaster", "read_lat_lon_raster"]
