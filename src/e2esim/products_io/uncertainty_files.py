"""Writing the uncertainty product: a CF NetCDF (``uncertainty.nc``) and a Cloud-Optimised GeoTIFF
(``uncertainty.tif``, one band per layer) on the product's own grid, band of rows by band of rows, into temporary
files that are renamed into place only when both are complete (no partial output).

Settings (docs/real-data.md, Speed): the NetCDF's chunks are one band high and at most 1,024 columns wide, so that
each band fills its chunks whole (no chunk is read back, decompressed and compressed again), byte-shuffled and
deflated at level 1 (netCDF4's zlib filter order). The file is laid out by netCDF4 (dimensions, coordinates,
variables, attributes), then its chunks are written whole, already compressed, through HDF5's direct chunk write
(h5py), so that the compression can run in the processes that evaluate the bands (``netcdf_chunks``); the chunks'
bytes are what HDF5's own shuffle and deflate filters give. The COG is written while the bands come
(``e2esim.products_io.cog_tiles``): ZSTD level 1, 512 x 512 tiles, its overviews resampled by nearest neighbour (an
overview pixel is a pixel of the layer: the verdict stays 0 or 1, NaN stays no data), compressed on GDAL's threads,
its tiles laid out as a COG at the end without being compressed again."""

from __future__ import annotations

import os
import zlib
from pathlib import Path

import numpy as np

from e2esim.errors import OutputExistsError
from e2esim.extras import optional_import
from e2esim.products_io.cog_tiles import CogWriter
from e2esim.products_io.pixel_model import LAYERS, NO_DATA_VERDICT

NETCDF_NAME, GEOTIFF_NAME = "uncertainty.nc", "uncertainty.tif"


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
        self.pixels = pixels
        self.band_rows = max(1, min(band_rows, pixels.shape[0]))
        self.chunk = (self.band_rows, min(pixels.shape[1], NETCDF_CHUNK_COLUMNS))
        self.nc = self.tiff = None
        try:
            self._open(attributes)
            self.nc.close()  # laid out: the chunks are written by HDF5 directly
            self.nc = optional_import("h5py", "products", "writing the uncertainty product").File(self.temps[0], "r+")
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
        for name, (units, what) in LAYERS.items():
            dtype, fill = LAYER_STORAGE[name == "verdict"]
            var = self.nc.createVariable(name, dtype, self.dims, fill_value=fill, chunksizes=self.chunk,
                                         compression="zlib", complevel=NETCDF_LEVEL, shuffle=True)
            var.setncatts({"units": units, "long_name": what})
            if pixels.crs is not None:
                var.grid_mapping = "crs"
        profile = {}
        if pixels.geotransform is not None:
            from affine import Affine  # lazy: start-up time (rasterio's dependency)

            x0, dx, y0, dy = pixels.geotransform
            profile.update(transform=Affine(dx, 0.0, x0, 0.0, dy, y0), crs=f"EPSG:{pixels.crs}")
        self.tiff = CogWriter(self.temps[1], pixels.shape, len(LAYERS), profile, list(LAYERS),
                              {k: str(v) for k, v in attributes.items()})

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

    def write(self, rows: slice, layers: dict, chunks: dict | None = None) -> None:
        """Write the band ``rows`` of every layer; ``chunks``: its NetCDF chunks as ``netcdf_chunks`` gives them
        (compressed elsewhere), else they are compressed here."""
        if chunks is None:
            chunks = netcdf_chunks(layers, self.chunk)
        for name, parts in chunks.items():
            dataset = self.nc[name].id
            for column, data in parts:
                dataset.write_direct_chunk((rows.start, column), data)
        values = np.empty((len(LAYERS), rows.stop - rows.start, self.pixels.shape[1]), dtype=np.float32)
        for band, name in enumerate(LAYERS):
            values[band] = layers[name]
            if name == "verdict":
                values[band][layers[name] == NO_DATA_VERDICT] = np.nan
        self.tiff.add(rows.start, values)

    def commit(self) -> list:
        self.nc.close()
        self.tiff.finish(self.temps[1])
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
        for temp in self.temps:
            temp.unlink(missing_ok=True)


NETCDF_CHUNK_COLUMNS, NETCDF_LEVEL = 1024, 1
LAYER_STORAGE = {False: ("f4", np.float32(np.nan)), True: ("u1", NO_DATA_VERDICT)}
"""(dtype, fill value) of the layers in the NetCDF, by whether the layer is the verdict."""


def netcdf_chunks(layers: dict, chunk: tuple) -> dict:
    """{layer: [(first column, bytes), ...]}: the NetCDF chunks of a band of the layers (a band is at most ``chunk``
    rows high and starts at a chunk's first row), as HDF5 stores them: each chunk whole (an edge chunk padded with
    the fill value, as HDF5 pads it), byte-shuffled (the shuffle filter: the first byte of every element, then the
    second, ...) and zlib-compressed at ``NETCDF_LEVEL`` (the deflate filter)."""
    out = {}
    for name, values in layers.items():
        dtype, fill = LAYER_STORAGE[name == "verdict"]
        values = np.asarray(values).astype(dtype, copy=False)
        size = np.dtype(dtype).itemsize
        parts = []
        for column in range(0, values.shape[1], chunk[1]):
            block = values[:, column:column + chunk[1]]
            if block.shape != chunk:
                padded = np.full(chunk, fill, dtype=dtype)
                padded[:block.shape[0], :block.shape[1]] = block
                block = padded
            raw = np.ascontiguousarray(block).view(np.uint8).reshape(-1, size).T.tobytes()
            parts.append((column, zlib.compress(raw, NETCDF_LEVEL)))
        out[name] = parts
    return out


def _attribute(value):
    return value if isinstance(value, (int, float, np.floating, np.integer)) else str(value)


def _wkt(rasterio, epsg: int) -> str:
    return rasterio.crs.CRS.from_epsg(epsg).to_wkt()
