"""Reading a NISAR RSLC or GSLC product (HDF5) for the uncertainty product (``e2esim.products_io.nisar_slc_layout``
gives every path and its source in isce3).

The output grid is the image's own: the RSLC's radar grid (zero-Doppler time x slant range; no map transform) or
the GSLC's map grid (``xCoordinates`` x ``yCoordinates`` in the EPSG of ``projection``). What is assumed for an SLC
(docs/real-data.md): a single-look complex image holds no estimate of the polarimetric covariance, so the scene is
the scenario's and no looks are counted (the budget is that of the system errors, the Faraday rotation and the noise
in a backscatter estimated from the SLC, as for a BIOMASS L1 product; speckle is not in it). Per pixel: the noise
power sigma_n, the mean of the ``nes0`` tables of HH, HV and VV interpolated bilinearly onto the grid from their
own coarser grid; validity: the GSLC's ``mask`` (0 and 255 no data), the RSLC's valid samples of each line
(``validSamplesSubSwath<i>``), and a finite positive noise. Once: the crosstalk tables (all zero: crosstalk not
corrected; an RSLC's tables apply per pixel at its column's slant range, ``nisar_budget_terms``),
``faradayRotation`` (0.0: no correction; the product holds no rotation layer, so the rotation is the scenario's less
what was removed), ``rfiLikelihood`` (counted as the RFI term's blanked time, ``nisar_budget_terms``) and
``scaleFactor`` (reported), and the orbit group (read
through ``e2esim.orbit.real.nisar``; the RSLC's acquisition must lie inside it).
"""

from __future__ import annotations

import numpy as np

from e2esim.errors import UserError
from e2esim.orbit.real.nisar import read_nisar_orbit
from e2esim.products_io.lut_grid import bilinear_rows
from e2esim.products_io.nisar_budget_terms import crosstalk_corrected_at, rfi_blanked_fraction
from e2esim.products_io.nisar_slc_layout import CHANNELS, MASK_FILL, MASK_INVALID, TIME_UNITS_PREFIX, slc_layout
from e2esim.products_io.pixels import PixelBlock, ProductFileError, ProductPixels, check_shape, check_units

NISAR_L_BAND_HZ = 1257.5e6


def slc_pixels(path, f, product: str) -> ProductPixels:
    """The pixels of the open HDF5 file ``f`` (``product`` "RSLC" or "GSLC")."""
    layout = slc_layout(product)
    name = f"NISAR {product} product"
    image = f.get(layout.image)
    if image is None:
        raise ProductFileError(f"{path}: group {layout.image} is missing; a {name} has it")
    unexpected = sorted(m for m in image if m not in layout.members and not m.startswith("validSamplesSubSwath"))
    if unexpected:
        raise ProductFileError(f"{path}: {layout.image}/{unexpected[0]}: unexpected variable; the {product} layout "
                               f"has {', '.join(sorted(layout.members))} there")
    rows = _vector(path, f, layout, layout.rows, name)
    cols = _vector(path, f, layout, layout.columns, name)
    shape = (rows.size, cols.size)
    for c in CHANNELS:
        check_shape(path, f"{layout.image}/{c}", _dataset(path, f, layout, f"{layout.image}/{c}", name).shape,
                    shape)
    noise_grid = np.mean([np.asarray(_dataset(path, f, layout, layout.nes0(c), name)[()], dtype=np.float64)
                          for c in CHANNELS], axis=0)
    nes0_rows = _vector(path, f, layout, layout.nes0_rows, name)
    nes0_cols = _vector(path, f, layout, layout.nes0_columns, name)
    check_shape(path, layout.nes0(CHANNELS[0]), noise_grid.shape, (nes0_rows.size, nes0_cols.size))
    crosstalk_facts, crosstalk_tables = _crosstalk(path, f, layout, name)
    facts = {**crosstalk_facts, **_scalars(path, f, layout, name), "frequency_hz": NISAR_L_BAND_HZ,
             "product_type": product}
    blanked, rfi_facts = rfi_blanked_fraction({c: facts[f"product_rfiLikelihood_{c}"] for c in CHANNELS})
    facts.update(rfi_facts)
    # an RSLC's columns are slant ranges: its crosstalk tables apply pixel by pixel (nisar_budget_terms)
    corrected_columns = None
    if product == "RSLC" and facts["crosstalk_applied"]:
        corrected_columns = crosstalk_corrected_at(*crosstalk_tables, cols)
        facts["crosstalk_corrected_per_slant_range"] = "the tables interpolated at each column's slant range"
    if product == "RSLC":
        epoch = _time_epoch(path, f, layout.rows)
        if _time_epoch(path, f, layout.nes0_rows) != epoch:
            raise ProductFileError(f"{path}: {layout.nes0_rows}: reference epoch differs from {layout.rows}'s; "
                                   "the RSLC writer gives both the same")
    facts.update(_orbit(path, layout, rows, _time_epoch(path, f, layout.rows) if product == "RSLC" else None))
    noise_at = bilinear_rows(nes0_cols, nes0_rows, noise_grid, cols)
    mask = f[layout.mask] if layout.mask is not None and layout.mask in f else None
    if layout.mask is not None:
        if mask is None:
            raise ProductFileError(f"{path}: variable {layout.mask} is missing; a {name} has it")
        check_shape(path, layout.mask, mask.shape, shape)
    valid_columns = _valid_samples(path, f, layout, shape) if product == "RSLC" else None

    def read(block_rows: slice) -> PixelBlock:
        noise = noise_at(rows[block_rows])
        valid = np.isfinite(noise) & (noise > 0)
        if mask is not None:
            m = np.asarray(mask[block_rows, :])
            valid &= (m != MASK_FILL) & (m != MASK_INVALID)
        if valid_columns is not None:
            j = np.arange(shape[1])
            first, stop = valid_columns[block_rows, :, 0], valid_columns[block_rows, :, 1]
            valid &= np.any((j >= first[..., None]) & (j < stop[..., None]), axis=1)
        corrected = None if corrected_columns is None else np.broadcast_to(corrected_columns, valid.shape)
        return PixelBlock(block_rows, valid, noise, crosstalk_corrected=corrected)

    if product == "RSLC":
        coords = {"zero_doppler_time": (("zero_doppler_time",), rows, {
                      "units": f"s since {epoch}", "long_name": "zero-Doppler azimuth time (UTC)"}),
                  "slant_range": (("slant_range",), cols, {"units": "m", "long_name": "slant range"})}
        return ProductPixels(str(path), "nisar", shape, coords, read, facts["product_faradayRotation_rad"] != 0.0,
                             facts.pop("crosstalk_applied"), facts, rfi_blanked_fraction=blanked)
    epsg = int(f[layout.projection].attrs.get("epsg_code", f[layout.projection][()])) if layout.projection in f \
        else None
    if epsg is None:
        raise ProductFileError(f"{path}: variable {layout.projection} is missing; a {name} has it")
    coords = {"y": (("y",), rows, {"units": "m", "standard_name": "projection_y_coordinate"}),
              "x": (("x",), cols, {"units": "m", "standard_name": "projection_x_coordinate"})}
    dx, dy = (cols[1] - cols[0], rows[1] - rows[0]) if cols.size > 1 and rows.size > 1 else (1.0, 1.0)
    return ProductPixels(str(path), "nisar", shape, coords, read, facts["product_faradayRotation_rad"] != 0.0,
                         facts.pop("crosstalk_applied"), facts,
                         geotransform=(cols[0] - dx / 2, dx, rows[0] - dy / 2, dy), crs=epsg,
                         rfi_blanked_fraction=blanked)


def _dataset(path, f, layout, name, what):
    group = name.rsplit("/", 1)[0]
    if group not in f:
        raise ProductFileError(f"{path}: group {group} is missing; a {what} has it")
    if name not in f:
        raise ProductFileError(f"{path}: variable {name} is missing; a {what} has it")
    ds = f[name]
    units = ds.attrs.get("units")
    if isinstance(units, bytes):
        units = units.decode("utf-8", "replace")
    expected = layout.units[name]
    if expected is None:
        if not (isinstance(units, str) and units.startswith(TIME_UNITS_PREFIX)):
            raise ProductFileError(f"{path}: {name}: units {units!r}; the layout has units "
                                   f"'{TIME_UNITS_PREFIX}YYYY-mm-ddTHH:MM:SS'")
    else:
        check_units(path, name, units, expected)
    return ds


def _vector(path, f, layout, name, what) -> np.ndarray:
    values = np.asarray(_dataset(path, f, layout, name, what)[()], dtype=np.float64)
    if values.ndim != 1 or values.size == 0 or not np.all(np.isfinite(values)):
        raise ProductFileError(f"{path}: {name}: shape {values.shape}; a non-empty axis of finite values is expected")
    return values


def _time_epoch(path, f, name) -> np.datetime64:
    units = f[name].attrs["units"]
    text = (units.decode() if isinstance(units, bytes) else units)[len(TIME_UNITS_PREFIX):].strip()
    try:
        return np.datetime64(text.replace(" ", "T").rstrip("Z"), "ns")
    except ValueError:
        raise ProductFileError(f"{path}: {name}: units {units!r}; the epoch after 'seconds since' is not a "
                               "date and time (YYYY-mm-ddTHH:MM:SS)") from None


def _crosstalk(path, f, layout, what) -> tuple:
    """(facts, (slant-range axis or None, the four tables))."""
    tables = [np.asarray(_dataset(path, f, layout, t, what)[()]).reshape(-1) for t in layout.crosstalk_tables]
    facts, axis = {}, None
    if layout.crosstalk_axis_required or layout.crosstalk_slant_range in f:
        axis = _vector(path, f, layout, layout.crosstalk_slant_range, what)
        for name, table in zip(layout.crosstalk_tables, tables):
            check_shape(path, name, table.shape, axis.shape)
        facts["product_crosstalk_slant_range_m"] = f"{axis.min():.6g} to {axis.max():.6g}"
    largest = [float(np.max(np.abs(t))) if t.size else 0.0 for t in tables]
    for name, value in zip(layout.crosstalk_tables, largest):
        if not np.isfinite(value):
            raise ProductFileError(f"{path}: {name}: holds a value that is not a finite number")
    facts["product_crosstalk_max_abs"] = max(largest)
    facts["crosstalk_applied"] = bool(max(largest) > 0)
    return facts, (axis, tables)


def _scalars(path, f, layout, what) -> dict:
    faraday = float(_dataset(path, f, layout, layout.faraday_rotation, what)[()])
    if not np.isfinite(faraday) or abs(faraday) > np.pi / 2:
        raise ProductFileError(f"{path}: {layout.faraday_rotation}: {faraday!r} rad; a finite angle in "
                               "[-pi/2, pi/2] is expected")
    facts = {"product_faradayRotation_rad": faraday, "faraday_rotation_applied_rad": faraday}
    for c in CHANNELS:
        rfi = float(_dataset(path, f, layout, layout.rfi_likelihood(c), what)[()])
        if not (np.isnan(rfi) or 0.0 <= rfi <= 1.0):
            raise ProductFileError(f"{path}: {layout.rfi_likelihood(c)}: {rfi!r}; a likelihood in [0, 1] (or NaN: "
                                   "detection skipped) is expected")
        facts[f"product_rfiLikelihood_{c}"] = rfi
        facts[f"product_scaleFactor_{c}"] = float(_dataset(path, f, layout, layout.scale_factor(c), what)[()])
    return facts


def _orbit(path, layout, rows, epoch) -> dict:
    """The orbit group's facts; for an RSLC, its zero-Doppler times must lie within the state vectors."""
    try:
        orbit = read_nisar_orbit(path, layout.orbit)
    except UserError as exc:
        raise ProductFileError(f"{exc} (the orbit group {layout.orbit})") from None
    facts = {"product_orbit": orbit.kind, "product_orbit_span": orbit.span_text()}
    if epoch is not None:
        first, last = orbit.seconds(epoch + (np.array([rows.min(), rows.max()]) * 1e9).astype("timedelta64[ns]"))
        if first < orbit.start_s or last > orbit.end_s:
            raise ProductFileError(f"{path}: {layout.orbit}: the state vectors span {orbit.span_text()}; they do not "
                                   f"cover the acquisition ({layout.rows}: {rows.min():g} to {rows.max():g} s since "
                                   f"{epoch})")
    return facts


def _valid_samples(path, f, layout, shape) -> np.ndarray:
    """(lines, sub-swaths, 2): the [first, stop) valid samples of each line (all samples without the table)."""
    found = sorted((int(m[len("validSamplesSubSwath"):]), m) for m in f[layout.image]
                   if m.startswith("validSamplesSubSwath") and m[len("validSamplesSubSwath"):].isdigit())
    if not found:
        return np.broadcast_to(np.array([0, shape[1]]), (shape[0], 1, 2))
    tables = []
    for _, m in found:
        table = np.asarray(f[f"{layout.image}/{m}"][()])
        check_shape(path, f"{layout.image}/{m}", table.shape, (shape[0], 2))
        tables.append(table.astype(np.int64))
    return np.stack(tables, axis=1)
