"""Small products in the exact layouts the readers of e2esim.products_io take (a few hundred pixels), written from
the public schemas and writer code, not from the readers: the BIOMASS L1 annotation (BPS XSDs, tests/data/bps_xsd)
and LUT NetCDF (BPS ``l1_lut_writer.write_lut_file``), and the NISAR GCOV HDF5 (isce3 ``nisar_L2_GCOV.xml``). The
names come from the layout modules, which the tests also check the files against."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import netCDF4
import numpy as np

from e2esim.products_io import biomass_layout as bl
from e2esim.products_io import nisar_layout as nl

NO_DATA = -9999.0  # the BPS LUT parameter no_pixel_value


def biomass_annotation(crosstalk=(0.0, 0.0, 0.0, 0.0), imbalance=(0.0, 0.0), faraday_applied=True,
                       rfi_percent=None) -> ET.Element:
    """The root ``mainAnnotation`` with the three sections e2esim reads, in the order and types of the XSD."""
    root = ET.Element(bl.ANNOTATION_ROOT)
    pd = ET.SubElement(root, "polarimetricDistortion")
    for list_name, names, values in (("crossTalkList", bl.CROSSTALK_ELEMENTS, crosstalk),
                                     ("channelImbalanceList", bl.IMBALANCE_ELEMENTS, imbalance)):
        lst = ET.SubElement(pd, list_name)
        for name, value in zip(names, values):
            node = ET.SubElement(lst, name)
            ET.SubElement(node, "re").text = repr(float(np.real(value)))
            ET.SubElement(node, "im").text = repr(float(np.imag(value)))
    iono = ET.SubElement(root, "ionosphereCorrection")
    for name, text, units in (("ionosphereHeightUsed", "350000.0", "m"), ("ionosphereHeightEstimated", "-1", "m"),
                              ("ionosphereHeightEstimationMethodSelected", "NA", None),
                              ("ionosphereHeightEstimationLatitudeValue", "60.0", "deg"),
                              ("ionosphereHeightEstimationFlag", "false", None),
                              ("ionosphereHeightEstimationMethodUsed", "Model", None),
                              ("gaussianFilterComputationFlag", "true", None),
                              ("faradayRotationCorrectionApplied", "true" if faraday_applied else "false", None),
                              ("autofocusShiftsApplied", "false", None)):
        node = ET.SubElement(iono, name)
        node.text = text
        if units:
            node.set("units", units)
    rfi = ET.SubElement(root, "rfiMitigation")
    if rfi_percent:
        lst = ET.SubElement(rfi, "rfiTMReportList", count=str(len(rfi_percent)))
        for pol, pct in rfi_percent.items():
            rep = ET.SubElement(lst, "rfiTMReport", polarisation=pol)
            ET.SubElement(rep, "percentageAffectedLines").text = repr(float(pct))
            ET.SubElement(rep, "avgPercentageAffectedSamples").text = "1.0"
            ET.SubElement(rep, "maxPercentageAffectedSamples").text = "2.0"
    return root


def write_biomass(folder, shape=(12, 20), faraday=None, faraday_std=None, noise=0.002, faraday_applied=True,
                  crosstalk=(0.0, 0.0, 0.0, 0.0), rfi_percent=None, slc_shape=None, units=None, drop=None,
                  extra=None, imbalance=(0.0, 0.0), tec=10.0, height=0.0, terrain_slope=0.0) -> Path:
    """A BIOMASS L1 product folder (annotation.xml, lut.nc). faraday, faraday_std : arrays on the SLC grid (rad)
    or None (no ionosphereCorrection group; a faraday_std of None with a faraday writes the all-fill layer, as the
    BPS does). units : {(group, variable): units} to override; drop : (group, variable) or group to leave out;
    extra : (group, variable) to add. imbalance : the annotation's (f1, f2); tec : ionosphereCorrection/tec (TECU,
    SLC grid; with faraday); height, terrain_slope : geometry/height (m), geometry/terrainSlope (deg), RGC grid."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    ET.ElementTree(biomass_annotation(crosstalk, imbalance, faraday_applied, rfi_percent)).write(
        folder / bl.ANNOTATION_FILE, xml_declaration=True, encoding="utf-8")
    slc_shape = slc_shape or shape
    units = units or {}
    with netCDF4.Dataset(folder / bl.LUT_FILE, "w", format="NETCDF4") as ds:
        ds.setncattr(bl.LUT_NO_DATA_ATTRIBUTE, NO_DATA)
        ds.mission = "BIOMASS"
        for (az, rg), (n_az, n_rg) in ((bl.RGC_AXES, shape), (bl.SLC_AXES, slc_shape)):
            for name, n, step in ((az, n_az, 0.05), (rg, n_rg, 1e-7)):
                ds.createDimension(name, n)
                v = ds.createVariable(name, "f8", (name,))
                v.units = bl.AXIS_UNITS
                v[:] = 4.5e-3 * (name.startswith("slant")) + step * np.linspace(0, n - 1, n) * (
                    (shape[0] - 1) / max(n_az - 1, 1) if name == az else (shape[1] - 1) / max(n_rg - 1, 1))
        lat = 60.0 + 0.01 * np.arange(shape[0])[:, None] + 0 * np.arange(shape[1])
        lon = 92.0 + 0.01 * np.arange(shape[1])[None, :] + 0 * lat
        inc = np.broadcast_to(np.linspace(23.0, 33.75, shape[1]), shape)
        layers = {("geometry", "latitude"): lat, ("geometry", "longitude"): lon,
                  ("geometry", "height"): np.broadcast_to(height, shape), ("geometry", "incidenceAngle"): inc,
                  ("geometry", "elevationAngle"): inc - 3.0,
                  ("geometry", "terrainSlope"): np.broadcast_to(terrain_slope, shape),
                  ("radiometry", "sigmaNought"): np.sin(np.radians(inc)),
                  ("radiometry", "gammaNought"): np.tan(np.radians(inc))}
        for pol in bl.POLARISATIONS:
            layers[("denoising", f"denoising{pol}")] = np.full(slc_shape, noise)
        if faraday is not None:
            layers[("ionosphereCorrection", "faradayRotation")] = faraday
            layers[("ionosphereCorrection", "faradayRotationStd")] = (
                np.full(slc_shape, NO_DATA) if faraday_std is None else faraday_std)
            layers[("ionosphereCorrection", "tec")] = np.broadcast_to(tec, slc_shape)
        if extra is not None:
            layers[extra] = np.zeros(shape)
        for (group, name), values in layers.items():
            if drop in (group, (group, name)):
                continue
            g = ds.groups.get(group) or ds.createGroup(group)
            axes = bl.SLC_AXES if group in ("ionosphereCorrection", "denoising") else bl.RGC_AXES
            dtype = "f8" if name in ("latitude", "longitude", "height") else "f4"
            v = g.createVariable(name, dtype, axes, fill_value=NO_DATA, compression="zlib", complevel=2)
            other = {"tec": "TECU", "elevationAngle": "deg"}.get(name)  # variables the reader does not need
            default = bl.LUT_VARIABLES.get(group, {}).get(name, (other,))[0]
            given = units.get((group, name), default)
            if given is not None:
                v.units = given
            v[:, :] = values
    return folder


def write_gcov(path, shape=(15, 20), seed=0, faraday=0.0, crosstalk=0.0, looks=25.0, nes0=0.003,
               units=None, drop=None, extra=None, truncate=None, rfi=0.1) -> Path:
    """A NISAR GCOV HDF5 with a forest-like covariance (HV 0.02-0.08, HH = 4 HV, VV = 2.5 HV, |rho_hhvv| 0.3)."""
    rng = np.random.default_rng(seed)
    rows, cols = shape
    hv = rng.uniform(0.02, 0.08, shape).astype(np.float32)
    hh, vv = 4 * hv, 2.5 * hv
    hhvv = (0.3 * np.sqrt(hh * vv) * np.exp(0.3j)).astype(np.complex64)
    mask = np.ones(shape, np.uint8)
    mask[0, 0] = nl.MASK_FILL
    units = units or {}
    values = {
        f"{nl.GRIDS}/HHHH": hh, f"{nl.GRIDS}/HVHV": hv, f"{nl.GRIDS}/VVVV": vv, f"{nl.GRIDS}/HHVV": hhvv,
        f"{nl.GRIDS}/numberOfLooks": np.full(shape, looks, np.float32),
        f"{nl.GRIDS}/xCoordinates": 500000.0 + 20.0 * np.arange(cols),
        f"{nl.GRIDS}/yCoordinates": 6650000.0 - 20.0 * np.arange(rows),
        **{t: np.full(5, crosstalk, np.complex64) for t in nl.CROSSTALK_TABLES},
        nl.CROSSTALK_SLANT_RANGE: np.linspace(8e5, 9e5, 5), nl.FARADAY_ROTATION: np.float64(faraday),
        **{nl.NES0[c]: np.full((3, 4), nes0, np.float32) for c in nl.CHANNELS},
        nl.NES0_X: np.linspace(499000.0, 501000.0, 4), nl.NES0_Y: np.linspace(6651000.0, 6649000.0, 3),
        **{nl.RFI_LIKELIHOOD[c]: np.float64(rfi[c] if isinstance(rfi, dict) else rfi) for c in nl.CHANNELS},
        **{nl.SCALE_FACTOR[c]: np.float64(1.0) for c in nl.CHANNELS},
    }
    if extra is not None:
        values[extra] = np.zeros(shape, np.float32)
    with h5py.File(path, "w") as f:
        for name, value in values.items():
            if drop is not None and name.startswith(drop):
                continue
            ds = f.create_dataset(name, data=value)
            u = units.get(name, nl.UNITS.get(name, "1"))
            if u is not None:
                ds.attrs["units"] = u
        f.create_dataset(nl.MASK, data=mask)
        proj = f.create_dataset(nl.PROJECTION, data=np.uint32(32646))
        proj.attrs["epsg_code"] = np.int32(32646)
    if truncate is not None:
        data = Path(path).read_bytes()
        Path(path).write_bytes(data[: int(len(data) * truncate)])
    return Path(path)


def write_slc(path, product="RSLC", shape=(15, 20), faraday=0.0, crosstalk=0.0, nes0=None, rfi=0.1,
              units=None, drop=None, extra=None, orbit_shift_s=0.0, crosstalk_axis=None) -> Path:
    """A NISAR RSLC or GSLC HDF5 in the layout of e2esim.products_io.nisar_slc_layout (isce3 SLC.py and
    nisar_L2_GSLC.xml): a small image, the calibration tables, the orbit group. nes0 : (3, 4) linear NESZ of its
    own grid (default rising across the swath, 0.001 to 0.01); the RSLC's second sub-swath leaves the first three
    samples of every line invalid; crosstalk : the four tables' value, or their values along ``crosstalk_axis``
    (slant range, m; default 5 values from 840 to 860 km); orbit_shift_s moves the state vectors' times (an orbit
    that misses the scene)."""
    from e2esim.products_io.nisar_slc_layout import CHANNELS, slc_layout

    layout = slc_layout(product)
    rows, cols = shape
    rng = np.random.default_rng(1)
    nes0 = np.array(np.broadcast_to(np.linspace(0.001, 0.01, 4), (3, 4))) if nes0 is None else nes0
    epoch = "seconds since 2025-11-01T00:00:00"
    axis = np.linspace(8.4e5, 8.6e5, 5) if crosstalk_axis is None else np.asarray(crosstalk_axis, np.float64)
    if product == "RSLC":
        axes = {layout.rows: 600.0 + 0.1 * np.arange(rows), layout.columns: 8.5e5 + 10.0 * np.arange(cols),
                layout.nes0_rows: np.array([599.0, 600.8, 602.0]), layout.nes0_columns: np.linspace(8.5e5, 8.52e5, 4)}
    else:
        axes = {layout.rows: 6650000.0 - 20.0 * np.arange(rows), layout.columns: 500000.0 + 20.0 * np.arange(cols),
                layout.nes0_rows: np.linspace(6650000.0, 6649700.0, 3),
                layout.nes0_columns: np.linspace(500000.0, 500380.0, 4)}
    values = {
        **{f"{layout.image}/{c}": (rng.normal(size=shape) + 1j * rng.normal(size=shape)).astype(np.complex64)
           for c in CHANNELS},
        **axes,
        **{t: np.broadcast_to(np.asarray(crosstalk, np.complex64), axis.shape).copy()
           for t in layout.crosstalk_tables},
        layout.crosstalk_slant_range: axis,
        layout.faraday_rotation: np.float64(faraday),
        **{layout.nes0(c): nes0.astype(np.float32) for c in CHANNELS},
        **{layout.rfi_likelihood(c): np.float64(rfi) for c in CHANNELS},
        **{layout.scale_factor(c): np.float64(1.0) for c in CHANNELS},
    }
    if product == "GSLC":
        del values[layout.crosstalk_slant_range]  # the L2 writer copies the tables, not their axis
    if extra is not None:
        values[extra] = np.zeros(shape, np.float32)
    units = units or {}
    t = np.arange(0.0, 1300.0, 10.0) + orbit_shift_s  # state vectors every 10 s around the scene
    w = 7.5e3 / 7.1e6
    orbit = {"time": t, "position": 7.1e6 * np.stack([np.cos(w * t), np.sin(w * t), 0 * t], axis=-1),
             "velocity": 7.5e3 * np.stack([-np.sin(w * t), np.cos(w * t), 0 * t], axis=-1)}
    with h5py.File(path, "w") as f:
        for name, value in values.items():
            if drop is not None and name.startswith(drop):
                continue
            ds = f.create_dataset(name, data=value)
            u = units.get(name, layout.units.get(name, "1"))
            ds.attrs["units"] = epoch if u is None else u
        image = f.require_group(layout.image)
        image.create_dataset("listOfPolarizations", data=np.bytes_(list(CHANNELS)))
        if product == "RSLC":
            image.create_dataset("numberOfSubSwaths", data=np.uint8(2))
            image.create_dataset("validSamplesSubSwath1", data=np.tile(np.array([0, 0], np.uint32), (rows, 1)))
            image.create_dataset("validSamplesSubSwath2", data=np.tile(np.array([3, cols], np.uint32), (rows, 1)))
        else:
            mask = np.ones(shape, np.uint8)
            mask[0, 0] = 255
            mask[1, 0] = 0
            if drop != layout.mask:
                image.create_dataset("mask", data=mask)
            proj = image.create_dataset("projection", data=np.uint32(32646))
            proj.attrs["epsg_code"] = np.int32(32646)
        if drop != layout.orbit:
            for name, value in orbit.items():
                ds = f.create_dataset(f"{layout.orbit}/{name}", data=value)
                ds.attrs["units"] = {"time": epoch, "position": "meters", "velocity": "meters / second"}[name]
            f.create_dataset(f"{layout.orbit}/orbitType", data=np.bytes_("POE"))
            f.create_dataset(f"{layout.orbit}/interpMethod", data=np.bytes_("Hermite"))
    return Path(path)
