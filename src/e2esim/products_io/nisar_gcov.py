"""Reading a NISAR GCOV product (HDF5) for the uncertainty product (``e2esim.products_io.nisar_layout`` gives every
path and its source, the NISAR L2 GCOV specification shipped with isce3).

The output grid is the product's own map grid (``xCoordinates`` x ``yCoordinates`` in the EPSG of ``projection``).
Per pixel: the covariance terms HHHH, HVHV, VVVV and HHVV (the scene), ``numberOfLooks`` and ``mask`` (0 and 255
are no data); the noise-equivalent sigma0 ``nes0`` of HH, HV and VV interpolated bilinearly from its coarser grid
(their mean is the noise power sigma_n per channel). Once: the crosstalk tables (all zero = crosstalk not
corrected), ``faradayRotation`` (0.0 = no correction; the product holds no Faraday-rotation layer, so the rotation
is the scenario's), ``rfiLikelihood`` (counted as the RFI term's blanked time, ``nisar_budget_terms``) and
``scaleFactor`` (reported in the outputs' attributes). A GCOV pixel's slant range is not in the product, so its
crosstalk tables count as one: any non-zero value = corrected.
"""

from __future__ import annotations

import numpy as np

from e2esim.products_io import nisar_layout as layout
from e2esim.products_io.lut_grid import bilinear_rows
from e2esim.products_io.nisar_budget_terms import rfi_blanked_fraction
from e2esim.products_io.pixels import PixelBlock, ProductFileError, ProductPixels, check_shape, check_units

NISAR_L_BAND_HZ = 1257.5e6


def _dataset(path, f, name):
    group = name.rsplit("/", 1)[0]
    if group not in f:
        raise ProductFileError(f"{path}: group {group} is missing; a NISAR GCOV product (isce3 nisar_L2_GCOV.xml) "
                               f"has it")
    if name not in f:
        raise ProductFileError(f"{path}: variable {name} is missing; a NISAR GCOV product has it")
    ds = f[name]
    check_units(path, name, ds.attrs.get("units"), layout.UNITS[name])
    return ds


def gcov_pixels(path, f) -> ProductPixels:
    """The pixels of the open HDF5 file ``f`` (``e2esim.products_io.nisar_products`` opens it)."""
    grids = {name: _dataset(path, f, name) for name in layout.GRID_VARIABLES}
    expected = set(layout.COVARIANCE_TERMS) | {"numberOfLooks", "mask", "xCoordinates", "yCoordinates",
                                               "projection", "listOfPolarizations", "listOfCovarianceTerms",
                                               "xCoordinateSpacing", "yCoordinateSpacing", "rtcGammaToSigmaFactor",
                                               "HHHV", "HHVH", "HVVH", "HVVV", "VHVH", "VHVV"}
    unexpected = sorted(set(f[layout.GRIDS]) - expected)
    if unexpected:
        raise ProductFileError(f"{path}: {layout.GRIDS}/{unexpected[0]}: unexpected variable; the GCOV layout "
                               f"has {', '.join(sorted(expected))} there")
    if layout.MASK not in f:
        raise ProductFileError(f"{path}: variable {layout.MASK} is missing; a NISAR GCOV product has it")
    x = np.asarray(grids[f"{layout.GRIDS}/xCoordinates"][()], dtype=np.float64)
    y = np.asarray(grids[f"{layout.GRIDS}/yCoordinates"][()], dtype=np.float64)
    shape = (y.size, x.size)
    for name in (*(f"{layout.GRIDS}/{t}" for t in layout.COVARIANCE_TERMS), f"{layout.GRIDS}/numberOfLooks",
                 layout.MASK):
        check_shape(path, name, f[name].shape, shape)
    terms = {t: f[f"{layout.GRIDS}/{t}"] for t in layout.COVARIANCE_TERMS}
    looks, mask = f[f"{layout.GRIDS}/numberOfLooks"], f[layout.MASK]
    nes0 = {c: _dataset(path, f, layout.NES0[c]) for c in layout.CHANNELS}
    nes0_x = np.asarray(_dataset(path, f, layout.NES0_X)[()], dtype=np.float64)
    nes0_y = np.asarray(_dataset(path, f, layout.NES0_Y)[()], dtype=np.float64)
    for c in layout.CHANNELS:
        check_shape(path, layout.NES0[c], nes0[c].shape, (nes0_y.size, nes0_x.size))
    noise_grid = np.mean([np.asarray(nes0[c][()], dtype=np.float64) for c in layout.CHANNELS], axis=0)
    crosstalk = [np.asarray(_dataset(path, f, name)[()]) for name in layout.CROSSTALK_TABLES]
    if layout.CROSSTALK_SLANT_RANGE in f:  # the L2 writer copies the tables, not their axis (nisar_layout)
        _dataset(path, f, layout.CROSSTALK_SLANT_RANGE)
    faraday = float(_dataset(path, f, layout.FARADAY_ROTATION)[()])
    if not np.isfinite(faraday) or abs(faraday) > np.pi / 2:
        raise ProductFileError(f"{path}: {layout.FARADAY_ROTATION}: {faraday!r} rad; a finite angle in "
                               "[-pi/2, pi/2] is expected")
    rfi = {c: float(_dataset(path, f, layout.RFI_LIKELIHOOD[c])[()]) for c in layout.CHANNELS}
    scale = {c: float(_dataset(path, f, layout.SCALE_FACTOR[c])[()]) for c in layout.CHANNELS}
    noise_at = bilinear_rows(nes0_x, nes0_y, noise_grid, x)

    def read(rows: slice) -> PixelBlock:
        sigma = tuple(np.asarray(terms[t][rows, :], dtype=np.float64) for t in ("HHHH", "HVHV", "VVVV"))
        hhvv = np.asarray(terms["HHVV"][rows, :], dtype=np.complex128)
        n = np.asarray(looks[rows, :], dtype=np.float64)
        m = np.asarray(mask[rows, :])
        noise = noise_at(y[rows])
        valid = ((m != layout.MASK_FILL) & (m != layout.MASK_INVALID) & np.all([np.isfinite(s) & (s > 0)
                 for s in sigma], axis=0) & np.isfinite(hhvv) & np.isfinite(n) & (n >= 1) & np.isfinite(noise)
                 & (noise > 0))
        # |<S_hh S_vv*>| cannot exceed sqrt(sigma_hh sigma_vv) in a covariance; a pixel where it does is no data
        valid &= np.abs(hhvv) ** 2 <= sigma[0] * sigma[2]
        return PixelBlock(rows, valid, noise, sigma, hhvv, n)

    projection = f[layout.PROJECTION]
    epsg = int(projection.attrs.get("epsg_code", projection[()]))
    coords = {"y": (("y",), y, {"units": "m", "standard_name": "projection_y_coordinate"}),
              "x": (("x",), x, {"units": "m", "standard_name": "projection_x_coordinate"})}
    crosstalk_applied = bool(any(np.any(t != 0) for t in crosstalk))
    facts = {
        "product_faradayRotation_rad": faraday,
        "faraday_rotation_applied_rad": faraday,
        "product_crosstalk_max_abs": float(max(np.max(np.abs(t)) if t.size else 0.0 for t in crosstalk)),
        **{f"product_rfiLikelihood_{c}": v for c, v in rfi.items()},
        **{f"product_scaleFactor_{c}": v for c, v in scale.items()},
        "frequency_hz": NISAR_L_BAND_HZ,
    }
    blanked, rfi_facts = rfi_blanked_fraction(rfi)
    facts.update(rfi_facts)
    dx, dy = (x[1] - x[0], y[1] - y[0]) if x.size > 1 and y.size > 1 else (1.0, 1.0)
    return ProductPixels(path, "nisar", shape, coords, read, faraday != 0.0, crosstalk_applied, facts,
                         geotransform=(x[0] - dx / 2, dx, y[0] - dy / 2, dy), crs=epsg,
                         rfi_blanked_fraction=blanked)

