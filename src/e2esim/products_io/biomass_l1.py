"""Reading a BIOMASS L1 product for the uncertainty product: its annotation XML and its LUT NetCDF
(``e2esim.products_io.biomass_layout`` gives every name and its source in the BIOMASS Processing Suite).

The output grid is the LUT's geometry grid (RGC axes: latitude, longitude, incidence per pixel); the ionosphere and
denoising layers (SLC axes) are interpolated onto it bilinearly in (azimuth time, slant-range time). Values equal to
the file's ``noDataValueFloat`` are no data: a ``faradayRotationStd`` that is all fill (as the BPS writes it) is an
empty layer, which the uncertainty product fills. The L1 product holds no polarimetric covariance per pixel in its
LUT, so the scene is the scenario's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from e2esim.product_inputs.biomass_site import lut_axis, open_lut
from e2esim.products_io import biomass_layout as layout
from e2esim.products_io.biomass_annotation import read_annotation
from e2esim.products_io.pixels import PixelBlock, ProductFileError, ProductPixels, check_shape, check_units

BIOMASS_FREQUENCY_HZ = 435e6


def product_files(path) -> tuple:
    """(annotation, LUT) of a product folder: ``annotation.xml`` and ``lut.nc``, or its only ``*.xml`` and ``*.nc``
    (the BPS names both after the product)."""
    folder = Path(path)
    named = folder / layout.ANNOTATION_FILE, folder / layout.LUT_FILE
    if all(p.exists() for p in named):
        return named
    xml, nc = sorted(folder.glob("*.xml")), sorted(folder.glob("*.nc"))
    if len(xml) != 1 or len(nc) != 1:
        raise ProductFileError(f"{folder}: a BIOMASS L1 product folder holds one annotation (*.xml) and one LUT "
                               f"(*.nc); found {len(xml)} and {len(nc)}")
    return xml[0], nc[0]


def open_biomass(path) -> ProductPixels:
    annotation_path, lut_path = product_files(path)
    annotation = read_annotation(annotation_path)
    ds = open_lut(lut_path)
    try:
        return _pixels(str(path), lut_path, ds, annotation)
    except ProductFileError:
        ds.close()
        raise


def _pixels(path, lut_path, ds, annotation) -> ProductPixels:
    no_data = ds.getncattr(layout.LUT_NO_DATA_ATTRIBUTE) if layout.LUT_NO_DATA_ATTRIBUTE in ds.ncattrs() else None
    if no_data is None:
        raise ProductFileError(f"{lut_path}: global attribute {layout.LUT_NO_DATA_ATTRIBUTE!r} is missing; the BPS "
                               "LUT writer sets it")
    for group in layout.REQUIRED_GROUPS:
        if group not in ds.groups:
            raise ProductFileError(f"{lut_path}: group {group!r} is missing; a BIOMASS L1 LUT has groups "
                                   f"{', '.join(layout.KNOWN_LUT_VARIABLES)}")
    for group, known in layout.KNOWN_LUT_VARIABLES.items():
        if group in ds.groups:
            extra = sorted(set(ds.groups[group].variables) - set(known))
            if extra:
                raise ProductFileError(f"{lut_path}: {group}/{extra[0]}: unexpected variable; the BPS v4.3 layout "
                                       f"has {', '.join(known)} there")
    for group, variables in layout.LUT_VARIABLES.items():
        if group not in ds.groups:
            continue
        for name, (units, axes) in variables.items():
            if name not in ds.groups[group].variables:
                if group == "ionosphereCorrection" and name == "faradayRotationStd":
                    continue
                raise ProductFileError(f"{lut_path}: variable {group}/{name} is missing; the BPS LUT writer writes "
                                       f"it with {variables and 'axes ' + ' x '.join(axes)}")
            var = ds.groups[group].variables[name]
            check_units(lut_path, f"{group}/{name}", getattr(var, "units", None), units)
            if tuple(var.dimensions) != axes:
                raise ProductFileError(f"{lut_path}: {group}/{name}: dimensions {var.dimensions}; expected {axes}")
    axes = {name: lut_axis(lut_path, ds, name) for name in (*layout.RGC_AXES, *layout.SLC_AXES)}
    shape = (axes[layout.RGC_AXES[0]].size, axes[layout.RGC_AXES[1]].size)
    geometry = ds.groups["geometry"].variables
    ionosphere = ds.groups["ionosphereCorrection"].variables if "ionosphereCorrection" in ds.groups else {}
    denoising = ds.groups["denoising"].variables
    interpolate = _slc_to_rgc(axes)

    def layer(var, rows):
        if var.dimensions == layout.SLC_AXES:
            return interpolate(lambda lo, hi: _values(var, slice(lo, hi), no_data), rows)
        return _values(var, rows, no_data)

    def read(rows: slice) -> PixelBlock:
        noise = np.mean([layer(denoising[f"denoising{p}"], rows) for p in ("HH", "HV", "VV")], axis=0)
        valid = np.isfinite(noise) & np.isfinite(layer(geometry["incidenceAngle"], rows)) & (noise > 0)
        fr = layer(ionosphere["faradayRotation"], rows) if "faradayRotation" in ionosphere else None
        sd = layer(ionosphere["faradayRotationStd"], rows) if "faradayRotationStd" in ionosphere else None
        if fr is not None:
            valid &= np.isfinite(fr)
        return PixelBlock(rows, valid, noise, faraday_mean=fr,
                          faraday_sd=None if sd is None else np.where(valid, sd, np.nan))

    latitude = np.asarray(geometry["latitude"][:], dtype=np.float64)
    check_shape(lut_path, "geometry/latitude", latitude.shape, shape)
    coords = {
        "azimuth_time": (("azimuth_time",), axes[layout.RGC_AXES[0]], {"units": "s", "long_name":
                         "azimuth time relative to the LUT's referenceAzimuthTime"}),
        "slant_range_time": (("slant_range_time",), axes[layout.RGC_AXES[1]], {"units": "s"}),
        "latitude": (("azimuth_time", "slant_range_time"), latitude, {"units": "degrees_north"}),
        "longitude": (("azimuth_time", "slant_range_time"), np.asarray(geometry["longitude"][:], dtype=np.float64),
                      {"units": "degrees_east"}),
    }
    crosstalk_applied = bool(np.any(annotation["crosstalk"] != 0))
    facts = {
        "product_annotation_faradayRotationCorrectionApplied": str(annotation["faraday_applied"]).lower(),
        "product_annotation_crosstalk_max_abs": float(np.max(np.abs(annotation["crosstalk"]))),
        "product_annotation_channel_imbalance_max_abs": float(np.max(np.abs(annotation["imbalance"]))),
        "product_lut_faradayRotation": "present" if "faradayRotation" in ionosphere else "absent",
        "product_lut_faradayRotationStd": _fill_state(ionosphere.get("faradayRotationStd"), no_data),
        **{f"product_rfi_percentage_affected_lines_{p}": v for p, v in annotation["rfi_percent"].items()},
        "frequency_hz": BIOMASS_FREQUENCY_HZ,
    }
    blanked = max(annotation["rfi_percent"].values(), default=0.0) / 100.0
    if not 0.0 <= blanked < 1.0:
        raise ProductFileError(f"{path}: {layout.RFI_REPORT_PATH}/{layout.RFI_FRACTION_ELEMENT}: {100 * blanked!r} %; "
                               "0 to below 100 % is allowed")
    facts["rfi_blanked_fraction_counted"] = blanked
    return ProductPixels(path, "biomass", shape, coords, read, annotation["faraday_applied"], crosstalk_applied,
                         facts, rfi_blanked_fraction=blanked)


def _values(var, rows: slice, no_data) -> np.ndarray:
    """Rows of a 2-D layer as float64, NaN where masked or equal to the no-data value."""
    raw = var[rows, :]
    raw = raw.filled(np.nan) if np.ma.isMaskedArray(raw) else np.asarray(raw)
    values = np.asarray(raw, dtype=np.float64)
    return np.where(values == no_data, np.nan, values)


def _slc_to_rgc(axes):
    """Bilinear interpolation of an SLC-axes layer onto rows of the RGC grid (the identity where the axes agree);
    only the SLC rows around the requested RGC rows are read."""
    az_slc, rg_slc = axes[layout.SLC_AXES[0]], axes[layout.SLC_AXES[1]]
    az_rgc, rg_rgc = axes[layout.RGC_AXES[0]], axes[layout.RGC_AXES[1]]
    same = np.array_equal(az_slc, az_rgc) and np.array_equal(rg_slc, rg_rgc)

    def interpolate(read_rows, rows):
        if same:
            return read_rows(rows.start, rows.stop)
        from scipy.interpolate import RegularGridInterpolator  # lazy: start-up time

        wanted = az_rgc[rows]
        lo = max(int(np.searchsorted(az_slc, wanted[0], "right")) - 1, 0)
        hi = min(int(np.searchsorted(az_slc, wanted[-1], "left")) + 1, az_slc.size)
        hi = max(hi, lo + 2) if az_slc.size >= lo + 2 else hi
        f = RegularGridInterpolator((az_slc[lo:hi], rg_slc), read_rows(lo, hi), bounds_error=False,
                                    fill_value=np.nan)
        az, rg = np.meshgrid(wanted, rg_rgc, indexing="ij")
        return f((az, rg))

    return interpolate


def _fill_state(var, no_data) -> str:
    if var is None:
        return "absent"
    rows = var.shape[0]
    for lo in range(0, rows, 256):  # by blocks of rows: memory does not grow with the grid
        if not np.all(np.isnan(_values(var, slice(lo, min(lo + 256, rows)), no_data))):
            return "present"
    return "empty (every value is the no-data fill)"
