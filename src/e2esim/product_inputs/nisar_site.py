"""One pixel of a NISAR product (GCOV, GSLC or RSLC): the calibration figures a product-driven scenario reads
(issue 26, item 5; docs/real-data.md, "A scenario driven by a product").

The file is opened and checked by the uncertainty product's readers (``e2esim.products_io.nisar_products``: the
same layout, units and refusals), so a file ``e2esim uncertainty`` reads is read the same way here. At a pixel:

* the noise power sigma_n: the mean of the ``nes0`` tables of HH, HV and VV interpolated bilinearly onto the pixel
  (as the uncertainty product takes it);
* the crosstalk variance V_delta = mean over the four tables ``crosstalk/{tx,rx}{Horizontal,Vertical}Crosspol`` of
  |delta_k|^2: an RSLC's tables interpolated at the pixel's slant range (its column,
  ``e2esim.products_io.nisar_budget_terms``); a GCOV's or GSLC's (no slant range per pixel) averaged over their
  samples. The tables are the crosstalk ratios the processor measured (isce3's RSLC writer: "txHV/txHH", ...), taken
  as the level of the crosstalk in the data before calibration. All zero: None (not measured, not applied);
* once per product: ``faradayRotation`` (rad, the rotation the processor removed; 0.0 = none applied) and the RFI
  term's blanked time f_t, the largest finite ``rfiLikelihood`` (``nisar_budget_terms``; None where every
  polarisation's detection was skipped).

The pixel: a site's (``lat_deg``, ``lon_deg``, WGS 84) on a GCOV's or GSLC's map grid, through the grid's EPSG
(``rasterio.warp.transform``); a site farther than 1.5 pixel spacings outside the grid is refused. An RSLC's radar
grid has no geolocation e2esim reads: only its scene centre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from e2esim.extras import optional_import
from e2esim.products_io import nisar_layout
from e2esim.products_io.nisar_budget_terms import rfi_blanked_fraction
from e2esim.products_io.nisar_products import open_nisar_product
from e2esim.products_io.nisar_slc import NISAR_L_BAND_HZ
from e2esim.products_io.nisar_slc_layout import CHANNELS, slc_layout
from e2esim.products_io.pixels import ProductFileError

OUTSIDE_SPACINGS = 1.5
"""A site farther than this many pixel spacings beyond the grid's edge lies outside the product."""


@dataclass(frozen=True)
class NisarPixel:
    """What a NISAR product gives a scenario at one pixel (module docstring). noise_power : sigma_n (linear).
    crosstalk_variance : V_delta, or None where the tables are all zero. faraday_rad : the rotation the processor
    removed. rfi_fraction : f_t, or None where detection was skipped everywhere. frequency_hz : NISAR's L-band
    centre. pixel : (row, column)."""

    path: str
    product: str
    pixel: tuple
    noise_power: float
    crosstalk_variance: float | None
    faraday_rad: float
    rfi_fraction: float | None
    frequency_hz: float = NISAR_L_BAND_HZ


def read_nisar_pixel(path, lat_deg=None, lon_deg=None) -> NisarPixel:
    """The figures of the NISAR product at ``path`` at the site (both None: the scene centre)."""
    pixels = open_nisar_product(path)
    product = pixels.facts.get("product_type", "GCOV")
    if lat_deg is None:
        row, col = pixels.shape[0] // 2, pixels.shape[1] // 2
    elif product == "RSLC":
        raise ProductFileError(f"{path}: an RSLC's radar grid has no geolocation e2esim reads, so a site (latitude "
                               f"{lat_deg:g}, longitude {lon_deg:g} deg) cannot be placed in it; leave lat_deg and "
                               "lon_deg out for its scene centre, or give a GCOV or GSLC")
    else:
        row, col = _map_pixel(pixels, lat_deg, lon_deg)
    block = pixels.read(slice(row, row + 1))
    noise = float(block.noise_power[0, col])
    if not (np.isfinite(noise) and noise > 0):
        raise ProductFileError(f"{path}: nes0 holds no data at pixel (row {row}, column {col})")
    likelihoods = {c: pixels.facts[f"product_rfiLikelihood_{c}"] for c in CHANNELS}
    fraction = rfi_blanked_fraction(likelihoods)[0] if any(np.isfinite(v) for v in likelihoods.values()) else None
    return NisarPixel(str(path), product, (row, col), noise, _crosstalk_variance(path, product, pixels, col),
                      float(pixels.facts["product_faradayRotation_rad"]), fraction)


def _crosstalk_variance(path, product, pixels, col) -> float | None:
    import h5py  # lazy: start-up time

    names = nisar_layout.CROSSTALK_TABLES if product == "GCOV" else slc_layout(product).crosstalk_tables
    with h5py.File(path, "r") as f:
        tables = [np.asarray(f[name][()], dtype=np.complex128).reshape(-1) for name in names]
        if product == "RSLC":
            axis = np.asarray(f[slc_layout(product).crosstalk_slant_range][()], dtype=np.float64)
            at = float(pixels.coordinates["slant_range"][1][col])
            order = np.argsort(axis)
            tables = [np.interp(at, axis[order], t[order].real) + 1j * np.interp(at, axis[order], t[order].imag)
                      for t in tables]
    power = float(np.mean([np.mean(np.abs(t) ** 2) for t in tables]))
    return power if power > 0 else None


def _map_pixel(pixels, lat_deg, lon_deg) -> tuple:
    """(row, column) of the map-grid pixel nearest to the site; refused outside the grid."""
    warp = optional_import("rasterio.warp", "products", "placing a site on a NISAR product's map grid")
    (x,), (y,) = warp.transform("EPSG:4326", f"EPSG:{pixels.crs}", [float(lon_deg)], [float(lat_deg)])
    xs, ys = pixels.coordinates["x"][1], pixels.coordinates["y"][1]
    dx = abs(xs[1] - xs[0]) if xs.size > 1 else 0.0
    dy = abs(ys[1] - ys[0]) if ys.size > 1 else 0.0
    col, row = int(np.argmin(np.abs(xs - x))), int(np.argmin(np.abs(ys - y)))
    if abs(xs[col] - x) > OUTSIDE_SPACINGS * dx or abs(ys[row] - y) > OUTSIDE_SPACINGS * dy:
        raise ProductFileError(
            f"{pixels.path}: the site at latitude {lat_deg:g}, longitude {lon_deg:g} deg (x {x:.1f}, y {y:.1f} m in "
            f"EPSG:{pixels.crs}) lies outside the product (x {xs.min():.1f} to {xs.max():.1f}, y {ys.min():.1f} to "
            f"{ys.max():.1f} m)")
    return row, col


__all__ = ["NisarPixel", "read_nisar_pixel"]
