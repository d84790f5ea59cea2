"""``e2esim uncertainty PRODUCT``: the per-pixel error budget of a real product (issue 26), on the product's own
grid, block of rows by block of rows so that memory does not grow with the grid (docs/real-data.md)."""

from __future__ import annotations

from pathlib import Path

from e2esim.errors import UserError
from e2esim.products_io.assumptions import load_assumptions
from e2esim.products_io.biomass_l1 import open_biomass
from e2esim.products_io.block_pool import block_layers
from e2esim.products_io.nisar_products import open_nisar_product
from e2esim.products_io.pixel_model import LAYERS
from e2esim.products_io.pixels import ProductFileError, ProductPixels
from e2esim.products_io.uncertainty_files import UncertaintyWriter

PIXELS_PER_BLOCK = 1 << 16
"""Pixels evaluated at once: a block of rows of about this many pixels (at least one row)."""


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


def row_blocks(shape, pixels_per_block: int = PIXELS_PER_BLOCK):
    rows, cols = shape
    step = max(1, pixels_per_block // max(cols, 1))
    for start in range(0, rows, step):
        yield slice(start, min(start + step, rows))


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
    writer = UncertaintyWriter(output, pixels, attributes, force)
    valid = passed = 0
    try:
        blocks = row_blocks(pixels.shape, pixels_per_block)
        for rows, layers in block_layers(open_product, product, scenario, pixels, assumptions, blocks, workers):
            valid += int((layers["verdict"] != 255).sum())
            passed += int((layers["verdict"] == 1).sum())
            writer.write(rows, layers)
        paths = writer.commit()
    except BaseException:
        writer.discard()
        raise
    return {"outputs": paths, "shape": list(pixels.shape), "pixels_with_data": valid,
            "fraction_passing": passed / valid if valid else None, "layers": list(LAYERS), **attributes}
