"""Writing the uncertainty product: a CF NetCDF (``uncertainty.nc``) and a Cloud-Optimised GeoTIFF
(``uncertainty.tif``, one band per layer) on the product's own grid, band of rows by band of rows, into temporary
files that are renamed into place only when both are complete (no partial output).

Settings (docs/real-data.md, Speed): the NetCDF's chunks are one band high and at most 1,024 columns wide, so that
each band fills its chunks whole (no chunk is read back, decompressed and compressed again), deflated at level 1
(zlib, no shuffle: as before); the GeoTIFF is first written uncompressed in strips one band high, band-interleaved
(each band of each layer written once), then copied to the COG: ZSTD level 1, 512 x 512 tiles, its overviews
resampled by nearest neighbour (an overview pixel is a pixel of the layer: the verdict stays 0 or 1, NaN stays no
data), compressed on all cores (``NUM_THREADS``)."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

from e2esim.errors import OutputExistsError
from e2esim.extras import optional_import
from e2esim.products_io.pixel_model import LAYERS, NO_DATA_VERDICT

NETCDF_NAME, GEOTIFF_NAME = "uncertainty.nc", "uncertainty.tif"
COG_COMPRESSION = "ZSTD"
"""The COG's compression, at level 1: lossless, about half the CPU time of DEFLATE level 1 for a file of about the
same size (docs/real-data.md, Speed). Readers need libtiff with ZSTD (GDAL 2.3 or later, as rasterio's wheels)."""


class UncertaintyWriter:
    """Open both outputs as temporaries in ``folder``; ``write(rows, layers)``; ``commit()`` renames them into
    place; ``discard()`` removes them (called on any failure)."""

    def __init__(self, folder, pixels, attributes: dict, force: bool = False, band_rows: int = 256):
        self.folder = Path(folder)
        self.targets = [self.folder / NETCDF_NAME, self.folder / GEOTIFF_NAME]
        existing = [str(t) for t in self.targets if t.exists()]
        if existing and not force:
            raise OutputExistsError(f"{existing[0]} exists; give --force to replace it")
        self.folder.mkdir(parents=True, exist_ok=True)
        self.temps = [t.with_name(f".{t.name}.{os.getpid()}.partial") for t in self.targets]
        self.tiff_temp = self.temps[1].with_name(self.temps[1].name + ".tiled")
        self.pixels = pixels
        self.band_rows = max(1, min(band_rows, pixels.shape[0]))
        self.nc = self.tiff = None
        try:
            self._open(attributes)
        except BaseException:
            self.discard()
            raise

    def _open(self, attributes: dict) -> None:
        pixels = self.pixels
        netcdf4 = optional_import("netCDF4", "products", "writing the uncertainty product (NetCDF)")
        rasterio = optional_import("rasterio", "products", "writing the uncertainty product (GeoTIFF)")
        self._rasterio = rasterio
        self.nc = netcdf4.Dataset(str(self.temps[0]), "w", format="NETCDF4")
        self.dims = self._coordinates()
        self.nc.setncatts({"Conventions": "CF-1.8", **{k: _attribute(v) for k, v in attributes.items()}})
        rows, cols = pixels.shape
        chunk = (self.band_rows, min(cols, 1024))
        for name, (units, what) in LAYERS.items():
            dtype, fill = ("u1", NO_DATA_VERDICT) if name == "verdict" else ("f4", np.float32(np.nan))
            var = self.nc.createVariable(name, dtype, self.dims, fill_value=fill, chunksizes=chunk,
                                         compression="zlib", complevel=1)
            var.setncatts({"units": units, "long_name": what})
            if pixels.crs is not None:
                var.grid_mapping = "crs"
        profile = {"driver": "GTiff", "width": cols, "height": rows, "count": len(LAYERS), "dtype": "float32",
                   "tiled": False, "blockysize": self.band_rows, "interleave": "band", "nodata": np.nan,
                   "BIGTIFF": "IF_SAFER"}
        if pixels.geotransform is not None:
            from affine import Affine  # lazy: start-up time (rasterio's dependency)

            x0, dx, y0, dy = pixels.geotransform
            profile.update(transform=Affine(dx, 0.0, x0, 0.0, dy, y0), crs=f"EPSG:{pixels.crs}")
        with warnings.catch_warnings():  # a radar grid (BIOMASS L1) has no map transform: said in docs/real-data.md
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            self.tiff = rasterio.open(self.tiff_temp, "w", **profile)
        for band, name in enumerate(LAYERS, start=1):
            self.tiff.set_band_description(band, name)
        self.tiff.update_tags(**{k: str(v) for k, v in attributes.items()})

    def _coordinates(self) -> tuple:
        dims = None
        for name, (cdims, values, attrs) in self.pixels.coordinates.items():
            for d, size in zip(cdims, np.shape(values)):
                if d not in self.nc.dimensions:
                    self.nc.createDimension(d, size)
            var = self.nc.createVariable(name, "f8", cdims)
            var.setncatts(attrs)
            var[:] = values
            if len(cdims) == 1:
                dims = (cdims[0],) if dims is None else (*dims, cdims[0])
        if self.pixels.crs is not None:
            crs = self.nc.createVariable("crs", "i4")
            crs.setncatts({"epsg_code": f"EPSG:{self.pixels.crs}", "crs_wkt": _wkt(self._rasterio, self.pixels.crs)})
        return dims

    def write(self, rows: slice, layers: dict) -> None:
        from rasterio.windows import Window  # lazy: start-up time

        window = Window(0, rows.start, self.pixels.shape[1], rows.stop - rows.start)
        for band, name in enumerate(LAYERS, start=1):
            self.nc.variables[name][rows, :] = layers[name]
            values = layers[name].astype(np.float32)
            if name == "verdict":
                values[layers[name] == NO_DATA_VERDICT] = np.nan
            self.tiff.write(values, band, window=window)

    def commit(self) -> list:
        self.nc.close()
        self.tiff.close()
        from rasterio.shutil import copy  # lazy: start-up time

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", self._rasterio.errors.NotGeoreferencedWarning)
            copy(str(self.tiff_temp), str(self.temps[1]), driver="COG", COMPRESS=COG_COMPRESSION, LEVEL=1,
                 BIGTIFF="IF_SAFER", RESAMPLING="NEAREST", NUM_THREADS="ALL_CPUS")
        self.tiff_temp.unlink()
        for temp, target in zip(self.temps, self.targets):
            os.replace(temp, target)
        return [str(t) for t in self.targets]

    def discard(self) -> None:
        for handle in (self.nc, self.tiff):
            try:
                if handle is not None:
                    handle.close()
            except Exception:  # already closed, or broken by the failure being reported
                pass
        for temp in (*self.temps, self.tiff_temp):
            temp.unlink(missing_ok=True)


def _attribute(value):
    return value if isinstance(value, (int, float, np.floating, np.integer)) else str(value)


def _wkt(rasterio, epsg: int) -> str:
    return rasterio.crs.CRS.from_epsg(epsg).to_wkt()
