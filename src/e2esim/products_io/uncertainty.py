"""``e2esim uncertainty PRODUCT``: the per-pixel error budget of a real product (issue 26), on the product's own
grid, block of rows by block of rows so that memory does not grow with the grid (docs/real-data.md)."""

from __future__ import annotations

import functools
from pathlib import Path

from e2esim.errors import UserError
from e2esim.products_io.assumptions import load_assumptions
from e2esim.products_io.biomass_l1 import open_biomass
from e2esim.products_io.block_pool import block_layers
from e2esim.products_io.nisar_products import open_nisar_product
from e2esim.products_io.pixel_model import LAYERS
from e2esim.products_io.pixels import ProductFileError, ProductPixels
from e2esim.products_io.uncertainty_files import UncertaintyWriter, netcdf_chunks

PIXELS_PER_BLOCK = 1 << 16
"""Pixels the model evaluates at once: a block of rows of about this many pixels (at least one row)."""
BAND_PIXELS = 256 * 5000
"""Pixels read, evaluated and written at once (about): a band of rows of about this many pixels, a whole number of
blocks (at least one), so that memory is bounded by this, not by the grid's width or height (256 rows of a
5,000-column grid). The outputs' chunks are one band high, so that each chunk is written once, whole
(docs/real-data.md, Speed)."""


def open_product(path) -> ProductPixels:
    """A BIOMASS L1 product (a folder with its annotation XML and LUT NetCDF) or a NISAR GCOV, RSLC or GSLC (an HDF5
    file)."""
    p = Path(path)
    if p.is_dir():
        return open_biomass(p)
    if not p.exists():
        raise ProductFileError(f"{path}: no such file or folder; expected a BIOMASS L1 product folder or a NISAR "
                               "GCOV, RSLC or GSLC HDF5 file")
    return open_nisar_product(p)


def block_rows(shape, pixels_per_block: int = PIXELS_PER_BLOCK) -> int:
    """Rows of a model block. The blocks start at row 0 every ``block_rows``: a pixel's numbers are computed in the
    same block whatever the band (the co-polarised model's path depends on the rotations a block holds)."""
    return max(1, pixels_per_block // max(shape[1], 1))


def row_bands(shape, pixels_per_block: int = PIXELS_PER_BLOCK, band_pixels: int = BAND_PIXELS):
    """Bands of rows of about ``band_pixels`` pixels, each a whole number of model blocks (``block_rows``)."""
    step = block_rows(shape, pixels_per_block)
    band = step * max(1, round(band_pixels / max(shape[1], 1) / step))
    for start in range(0, shape[0], band):
        yield slice(start, min(start + band, shape[0]))


def write_uncertainty(product, output, scenario=None, force: bool = False,
                      pixels_per_block: int = PIXELS_PER_BLOCK, workers: int = 1) -> dict:
    """Write ``uncertainty.nc`` and ``uncertainty.tif`` into the folder ``output``; return a summary: the paths,
    the grid, the pixels with data, the fraction that passes the bound and every assumption taken from the
    scenario. workers : processes that evaluate the blocks (1: this process)."""
    if workers < 1:
        raise UserError(f"--workers: {workers}; expected a positive integer (processes that evaluate the pixels)")
    pixels = open_product(product)
    assumptions = load_assumptions(scenario, pixels.mission)
    attributes = {"title": "e2esim per-pixel uncertainty product", "source_product": str(product),
                  "mission": pixels.mission, "faraday_rotation_corrected_by_processor": str(pixels.faraday_applied),
                  "crosstalk_corrected_by_processor": str(pixels.crosstalk_applied),
                  "model": "sigma_hv error: Men et al. (2021) eqs. 11-12 completed to second order "
                           "(e2esim.distortion.analytic); sigma_hh, sigma_vv errors: co-pol eqs. 3.2-4.2 "
                           "(e2esim.distortion.polarimetric_pixels); Faraday-rotation SD: Quegan et al. (2018) eq. 5; "
                           "AGB: power law (Men et al. 2021 eqs. 15-16)",
                  **pixels.facts, **assumptions.attributes()}
    bands = list(row_bands(pixels.shape, pixels_per_block))
    writer = UncertaintyWriter(output, pixels, attributes, force, band_rows=bands[0].stop - bands[0].start)
    valid = passed = 0
    try:
        step = block_rows(pixels.shape, pixels_per_block)
        # with workers, the NetCDF's chunks are compressed there (the writing process is the serial part)
        encode = functools.partial(netcdf_chunks, chunk=writer.chunk) if workers > 1 else None
        for rows, layers, *chunks in block_layers(open_product, product, scenario, pixels, assumptions, bands, step,
                                                  workers, encode):
            valid += int((layers["verdict"] != 255).sum())
            passed += int((layers["verdict"] == 1).sum())
            writer.write(rows, layers, *chunks)
        paths = writer.commit()
    except BaseException:
        writer.discard()
        raise
    return {"outputs": paths, "shape": list(pixels.shape), "pixels_with_data": valid,
            "fraction_passing": passed / valid if valid else None, "layers": list(LAYERS), **attributes}
