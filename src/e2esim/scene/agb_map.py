"""User-supplied above-ground-biomass maps on a latitude-longitude grid, in NetCDF or GeoTIFF.

NetCDF files are read with xarray (netCDF4 engine): a 2-D variable (``agb`` by default) over latitude and
longitude coordinates (named ``lat``/``latitude``/``y`` and ``lon``/``longitude``/``x``). GeoTIFF files are read
with rioxarray (rasterio, GDAL): band 1, in a geographic coordinate reference system (longitude and latitude in
degrees, such as EPSG:4326); a projected map must be reprojected first (``gdalwarp -t_srs EPSG:4326``). The
values are AGB in t/ha (= Mg/ha); a ``units`` attribute, when present, must say so or be kg m-2 (converted,
1 kg/m^2 = 10 t/ha). NaN, the GeoTIFF's nodata value and values <= 0 mean no forest; a value above
``MAX_MAP_AGB_T_HA`` (or +inf) is refused, as is a map of fewer than two latitudes or longitudes (its pixel size
cannot be told) and a path that is not a regular file (a FIFO would block the reader for ever).

A point's AGB is the value of the map pixel that contains it (nearest pixel centre); a point more than half a
pixel beyond the map's edge is outside the map (NaN). Maps are read once per process and file version.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from e2esim.errors import MissingExtraError, PhysicsInputError
from e2esim.extras import optional_import
from e2esim.input_files import NotARegularFile, regular_file_stat

MAX_MAP_PIXELS = 100_000_000
"""Pixels of an AGB map read into memory: 1e8 (400 MB as float32; a global map at 0.036 deg, 4 km). Finer maps
are better aggregated to the map sweep's step first (cell means), which also gives each cell its mean AGB."""

MAX_MAP_AGB_T_HA = 5000.0
"""Largest AGB a map pixel may hold: 5 000 t/ha. The most carbon-dense forests measured, mountain ash in Victoria,
Australia, hold about 1 900 t C/ha in living biomass (Keith, Mackey & Lindenmayer 2009, PNAS 106, 11635), about
3 800 t/ha of dry biomass; a larger value is a fill value or a unit error, not a forest (issue 22: 1e30 t/ha
was accepted and passed the requirement)."""

LAT_NAMES = ("lat", "latitude", "y")
LON_NAMES = ("lon", "longitude", "x")
T_HA_UNITS = ("t/ha", "t ha-1", "t ha^-1", "mg/ha", "mg ha-1", "mg ha^-1", "t.ha-1", "mg.ha-1")
KG_M2_UNITS = ("kg/m2", "kg m-2", "kg m^-2", "kg/m^2", "kg.m-2")
SUFFIXES = {".nc": "netcdf", ".nc4": "netcdf", ".netcdf": "netcdf", ".cdf": "netcdf", ".tif": "geotiff",
            ".tiff": "geotiff"}


@dataclass(frozen=True)
class AGBMap:
    """AGB (t/ha, float32, NaN where no forest) on pixel centres ``lat_deg`` (ascending) x ``lon_deg``
    (ascending, in [-180, 180)); ``source`` names the file."""

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    agb_t_ha: np.ndarray
    source: str = ""

    def lookup(self, lat_deg, lon_deg) -> np.ndarray:
        """AGB (t/ha) of the pixels containing the points (deg, broadcast); NaN outside the map or where no
        forest."""
        lat, lon = np.broadcast_arrays(np.asarray(lat_deg, float), _wrap(np.asarray(lon_deg, float)))
        i, inside_i = _pixel(self.lat_deg, lat, periodic=False)
        j, inside_j = _pixel(self.lon_deg, lon, periodic=_is_global(self.lon_deg))
        return np.where(inside_i & inside_j, self.agb_t_ha[i, j].astype(float), np.nan)

    def covers(self, lat_deg, lon_deg) -> np.ndarray:
        """True where the points (deg) are inside the map's extent (forest or not)."""
        lat, lon = np.broadcast_arrays(np.asarray(lat_deg, float), _wrap(np.asarray(lon_deg, float)))
        return _pixel(self.lat_deg, lat, False)[1] & _pixel(self.lon_deg, lon, _is_global(self.lon_deg))[1]


def read_agb_map(path, variable: str = "agb", memo=None) -> AGBMap:
    """The AGB map in ``path`` (NetCDF or GeoTIFF, by suffix); NetCDF ``variable`` holds AGB. With ``memo`` (the
    process's ``KernelMemo``), read once per file version (path, size and modification time; the last
    ``MAPS_KEPT`` maps are kept, in memory only). Raises ``PhysicsInputError`` (key ``file`` or ``variable``) for a
    file that is missing or not such a map."""
    path = Path(path).expanduser()
    try:
        stat = regular_file_stat(path)
    except NotARegularFile as exc:
        raise PhysicsInputError(f"the AGB map {str(path)!r} is {exc.kind}, not a regular file; give a NetCDF or "
                                "GeoTIFF file", key="file") from exc
    except OSError as exc:
        raise PhysicsInputError(f"cannot read the AGB map {str(path)!r}: {exc.strerror or exc}", key="file") from exc
    where = str(path.resolve())
    if memo is None:
        return _read(where, variable)
    return memo.recall(("agb map", where, stat.st_size, stat.st_mtime_ns, variable), lambda: _read(where, variable),
                       keep=MAPS_KEPT)


MAPS_KEPT = 4


def _read(path: str, variable: str) -> AGBMap:
    kind = SUFFIXES.get(Path(path).suffix.lower())
    if kind is None:
        raise PhysicsInputError(f"{path!r} is neither NetCDF nor GeoTIFF by its name; expected a file ending in "
                                + ", ".join(SUFFIXES), key="file")
    try:
        lat, lon, values, units = _read_netcdf(path, variable) if kind == "netcdf" else _read_geotiff(path)
    except (PhysicsInputError, MissingExtraError):
        raise
    except Exception as exc:  # the libraries' own errors on a corrupt or foreign file
        raise PhysicsInputError(f"cannot read the AGB map {path!r} as {kind}: {type(exc).__name__}: {exc}",
                                key="file") from exc
    return _checked(path, lat, lon, values, units)


def _read_netcdf(path: str, variable: str):
    xr = optional_import("xarray", "products", "reading a NetCDF AGB map")
    optional_import("netCDF4", "products", "reading a NetCDF AGB map")

    with xr.open_dataset(path, engine="netcdf4", decode_times=False, mask_and_scale=True) as ds:
        if variable not in ds.data_vars:
            raise PhysicsInputError(f"the AGB map {path!r} has no variable {variable!r}; its variables: "
                                    + (", ".join(map(str, ds.data_vars)) or "none"), key="variable")
        da = ds[variable]
        lat_dim = _dim(da, LAT_NAMES, path, "latitude")
        lon_dim = _dim(da, LON_NAMES, path, "longitude")
        # drop other axes of length one (time, band), never latitude or longitude: a one-row map keeps its row
        da = da.squeeze([d for d in da.dims if da.sizes[d] == 1 and d not in (lat_dim, lon_dim)], drop=True)
        if da.ndim != 2:
            raise PhysicsInputError(f"the AGB variable {variable!r} of {path!r} has dimensions {da.dims}; expected "
                                    "two: latitude and longitude", key="variable")
        _check_size(path, da.size)
        da = da.transpose(lat_dim, lon_dim)
        return (np.asarray(da[lat_dim].values, float), np.asarray(da[lon_dim].values, float),
                np.asarray(da.values, np.float32), str(da.attrs.get("units", "")))


def _read_geotiff(path: str):
    rioxarray = optional_import("rioxarray", "products", "reading a GeoTIFF AGB map")

    with rioxarray.open_rasterio(path, masked=True) as da:
        crs = da.rio.crs
        if crs is None or not crs.is_geographic:
            raise PhysicsInputError(f"the GeoTIFF {path!r} is in {crs or 'no coordinate reference system'}, not in "
                                    "longitude and latitude; reproject it first (gdalwarp -t_srs EPSG:4326)",
                                    key="file")
        band = da.isel(band=0) if "band" in da.dims else da
        _check_size(path, band.size)
        return (np.asarray(band["y"].values, float), np.asarray(band["x"].values, float),
                np.asarray(band.values, np.float32), str(da.attrs.get("units", "")))


def _dim(da, names, path, what) -> str:
    for dim in da.dims:
        if str(dim).lower() in names:
            return dim
    raise PhysicsInputError(f"the AGB map {path!r} has no {what} dimension (dimensions {da.dims}; expected one of "
                            f"{', '.join(names)})", key="variable")


def _check_size(path, size) -> None:
    if size > MAX_MAP_PIXELS:
        raise PhysicsInputError(f"the AGB map {path!r} has {size:,} pixels, above the limit of {MAX_MAP_PIXELS:,}; "
                                "aggregate it to a coarser grid first (the map sweep's step)", key="file")


def _checked(path, lat, lon, values, units) -> AGBMap:
    u = units.strip().lower()
    if u in KG_M2_UNITS:
        values = values * np.float32(10.0)
    elif u and u not in T_HA_UNITS:
        raise PhysicsInputError(f"the AGB map {path!r} is in {units!r}; expected t/ha (Mg/ha) or kg m-2", key="file")
    if lat.ndim != 1 or lon.ndim != 1:
        raise PhysicsInputError(f"the AGB map {path!r} needs 1-D latitude and longitude axes", key="file")
    if lat.size < 2 or lon.size < 2:
        raise PhysicsInputError(f"the AGB map {path!r} has {lat.size} latitude(s) and {lon.size} longitude(s); "
                                "expected at least two of each, so that its pixel size is known", key="file")
    if not (np.all(np.isfinite(lat)) and np.all(np.isfinite(lon)) and np.all(np.abs(lat) <= 90.0)):
        raise PhysicsInputError(f"the AGB map {path!r} has latitudes outside [-90, 90] deg or non-finite axes",
                                key="file")
    lon = _wrap(lon)
    i, j = np.argsort(lat), np.argsort(lon)
    lat, lon = lat[i], lon[j]
    if np.any(np.diff(lat) <= 0) or np.any(np.diff(lon) <= 0):
        raise PhysicsInputError(f"the AGB map {path!r} repeats a latitude or longitude", key="file")
    values = np.array(values[np.ix_(i, j)], np.float32)
    values[~(values > 0)] = np.nan
    _check_range(path, values, lat, lon, u in KG_M2_UNITS)
    values.setflags(write=False)
    return AGBMap(lat, lon, values, path)


def _check_range(path, values, lat, lon, converted: bool) -> None:
    """Refuse a forest value above ``MAX_MAP_AGB_T_HA`` (+inf included), naming the largest and where it is."""
    with np.errstate(invalid="ignore"):
        high = values > MAX_MAP_AGB_T_HA
    if not high.any():
        return
    i, j = np.unravel_index(int(np.nanargmax(np.where(high, values, -np.inf))), values.shape)
    unit = " (after converting kg m-2 to t/ha)" if converted else ""
    raise PhysicsInputError(
        f"the AGB map {path!r} holds {int(high.sum()):,} value(s) above {MAX_MAP_AGB_T_HA:g} t/ha, the largest "
        f"{float(values[i, j]):.6g} t/ha{unit} at latitude {lat[i]:g}, longitude {lon[j]:g} deg; AGB is at most "
        f"{MAX_MAP_AGB_T_HA:g} t/ha: if such values mark missing data, declare them as the variable's _FillValue "
        "(NetCDF) or the nodata value (GeoTIFF)", key="file")


def _wrap(lon):
    return np.mod(np.asarray(lon, float) + 180.0, 360.0) - 180.0


def _is_global(lon_axis) -> bool:
    """True when the longitude axis goes round the globe (its pixels cover 360 deg)."""
    if lon_axis.size < 2:
        return False
    step = np.median(np.diff(lon_axis))
    return bool(abs(lon_axis.size * step - 360.0) <= 0.5 * step)


def _pixel(axis, x, periodic: bool):
    """Index of the pixel centre of ``axis`` (ascending) nearest to ``x``, and whether ``x`` lies within half a
    pixel of the axis (always, round a periodic longitude axis)."""
    n = axis.size
    if n == 1:
        return np.zeros(x.shape, int), np.abs(x - axis[0]) <= 0.5
    half = 0.5 * np.median(np.diff(axis))
    k = np.searchsorted(axis, x)  # axis[k - 1] < x <= axis[k]
    left, right = np.mod(k - 1, n), np.mod(k, n)
    if periodic:
        d_left = np.abs(np.mod(x - axis[left] + 180.0, 360.0) - 180.0)
        d_right = np.abs(np.mod(axis[right] - x + 180.0, 360.0) - 180.0)
        return np.where(d_left <= d_right, left, right), np.ones(x.shape, bool)
    left, right = np.clip(k - 1, 0, n - 1), np.clip(k, 0, n - 1)
    idx = np.where(np.abs(x - axis[left]) <= np.abs(axis[right] - x), left, right)
    return idx, (x >= axis[0] - half) & (x <= axis[-1] + half)
