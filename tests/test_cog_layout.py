"""The uncertainty product's COG, written from tiles compressed while the bands come (issue 26, Speed): it equals,
pixel for pixel and tag for tag, what GDAL's COG driver makes of the same layers (the overviews included, at sizes
whose ratios are not whole numbers), and it has the COG layout (IFDs before the data, the smallest overview's tiles
first, each tile led by its size and trailed by its last 4 bytes)."""

from __future__ import annotations

import struct
import warnings

import numpy as np
import pytest
import rasterio
from rasterio.shutil import copy

from e2esim.products_io.cog_layout import TILE_BYTE_COUNTS, TILE_OFFSETS, TYPE_SIZES, read_tiled, write_cog
from e2esim.products_io.cog_tiles import CogWriter, overview_sizes

pytestmark = pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")  # arrays, no map grid
SHAPE = (1037, 45)  # overviews 518 x 22 and 259 x 11: ratios that are not whole numbers


def layers(seed, shape=SHAPE) -> np.ndarray:
    values = np.random.default_rng(seed).normal(size=(3, *shape)).astype(np.float32)
    values[1, 5:40, 7:30] = np.nan  # no data
    values[2] = np.round(values[2]) > 0  # a verdict of 0 and 1
    return values


def cog_driver(values, path):
    """The reference: GDAL's COG driver, as the uncertainty product used it before."""
    plain = path.with_suffix(".plain.tif")
    with rasterio.open(plain, "w", driver="GTiff", width=values.shape[2], height=values.shape[1], count=3,
                       dtype="float32",
                       nodata=np.nan) as d:
        d.write(values)
        d.update_tags(title="t")
        for band in range(1, 4):
            d.set_band_description(band, f"layer{band}")
    copy(str(plain), str(path), driver="COG", COMPRESS="ZSTD", LEVEL=1, RESAMPLING="NEAREST")


def read_all(path) -> tuple:
    with rasterio.open(path) as d:
        about = (d.profile, d.tags(), d.tags(ns="IMAGE_STRUCTURE"), d.descriptions, d.overviews(1), d.block_shapes)
        levels = [d.read()]
    for k in range(len(about[4])):
        with rasterio.open(path, overview_level=k) as d:
            levels.append(d.read())
    return about, levels


def ifds(path) -> list:
    """[(offset, {tag: values})] of every IFD of a little-endian TIFF or BigTIFF (the tiles' offsets and counts)."""
    data = path.read_bytes()
    big = data[2] == 43
    word, entry = ("Q", 20) if big else ("I", 12)
    offset, out = struct.unpack_from(f"<{word}", data, 8 if big else 4)[0], []
    while offset:
        n = struct.unpack_from("<Q" if big else "<H", data, offset)[0]
        start, tags = offset + (8 if big else 2), {}
        for i in range(n):
            tag, kind = struct.unpack_from("<HH", data, start + i * entry)
            count = struct.unpack_from(f"<{word}", data, start + i * entry + 4)[0]
            at = start + i * entry + (12 if big else 8)
            if TYPE_SIZES[kind] * count > (8 if big else 4):
                at = struct.unpack_from(f"<{word}", data, at)[0]
            if tag in (TILE_OFFSETS, TILE_BYTE_COUNTS):
                tags[tag] = struct.unpack_from(f"<{count}{ {4: 'I', 16: 'Q'}[kind] }", data, at)
        out.append((offset, tags))
        offset = struct.unpack_from(f"<{word}", data, start + n * entry)[0]
    return data, out


def assert_cog_layout(path) -> None:
    data, directories = ifds(path)
    assert b"LAYOUT=IFDS_BEFORE_DATA" in data[:200] and all(offset % 2 == 0 for offset, _ in directories)
    first_tile = min(min(tags[TILE_OFFSETS]) for _, tags in directories)
    assert max(offset for offset, _ in directories) < first_tile  # every IFD before the data
    starts = [min(tags[TILE_OFFSETS]) for _, tags in directories]
    assert starts == sorted(starts, reverse=True)  # the smallest overview's tiles first, the image's last
    for _, tags in directories:
        offsets, counts = tags[TILE_OFFSETS], tags[TILE_BYTE_COUNTS]
        assert list(offsets) == sorted(offsets)  # row-major
        for at, n in zip(offsets, counts):
            assert struct.unpack_from("<I", data, at - 4)[0] == n and data[at + n:at + n + 4] == data[at + n - 4:at + n]


@pytest.mark.parametrize(("shape", "band_rows", "sizes"), [
    (SHAPE, 260, [(518, 22), (259, 11)]), (SHAPE, 1037, [(518, 22), (259, 11)]),
    ((3, 1100), 2, [(1, 550), (1, 275)])])  # a side halved to 0 is 1 pixel, as the COG driver makes it
def test_the_cog_equals_the_cog_drivers(tmp_path, shape, band_rows, sizes):
    """Written band by band (bands of 260 rows straddle the 512-row tiles), the COG holds the COG driver's values
    at every level, its tags, band names, tiles and overviews; the layout is a COG's."""
    values = layers(1, shape)
    cog_driver(values, tmp_path / "reference.tif")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        writer = CogWriter(tmp_path / "new", shape, 3, {}, ["layer1", "layer2", "layer3"], {"title": "t"})
        for first in range(0, shape[0], band_rows):
            writer.add(first, values[:, first:first + band_rows])
        writer.finish(tmp_path / "new.tif")
        (about, levels), (ref_about, ref_levels) = read_all(tmp_path / "new.tif"), read_all(tmp_path / "reference.tif")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new.tif", "reference.plain.tif", "reference.tif"]
    assert repr(about) == repr(ref_about)  # repr: the no-data value is NaN
    assert about[4] == [2, 4] and about[2]["LAYOUT"] == "COG"
    assert [v.shape[1:] for v in levels[1:]] == overview_sizes(*shape) == sizes
    for got, want in zip(levels, ref_levels, strict=True):
        np.testing.assert_array_equal(got.view(np.uint32), want.view(np.uint32))  # bit for bit, NaN included
    assert_cog_layout(tmp_path / "new.tif")


def test_bigtiff_sources_and_outputs(tmp_path):
    """A BigTIFF source (GDAL writes one for a large grid) is read, and a COG beyond 4 GiB is a BigTIFF: the layout
    forced to BigTIFF gives the same values."""
    values = layers(2)[:, :300]
    with rasterio.open(tmp_path / "big.tif", "w", driver="GTiff", width=45, height=300, count=3, dtype="float32",
                       tiled=True, blockxsize=512, blockysize=512, compress="ZSTD", interleave="pixel",
                       BIGTIFF="YES") as d:
        d.write(values)
    write_cog(tmp_path / "out.tif", [read_tiled(tmp_path / "big.tif")], bigtiff=True)
    assert (tmp_path / "out.tif").read_bytes()[:4] == b"II+\x00"
    with rasterio.open(tmp_path / "out.tif") as d:
        np.testing.assert_array_equal(d.read().view(np.uint32), values.view(np.uint32))
    assert_cog_layout(tmp_path / "out.tif")


def test_a_file_that_is_not_a_tiled_little_endian_tiff_is_refused(tmp_path):
    (tmp_path / "x.tif").write_bytes(b"MM\x00*" + bytes(12))
    with pytest.raises(ValueError, match="not a little-endian TIFF"):
        read_tiled(tmp_path / "x.tif")
    with rasterio.open(tmp_path / "strips.tif", "w", driver="GTiff", width=4, height=4, count=1,
                       dtype="float32") as d:
        d.write(np.zeros((1, 4, 4), np.float32))
    with pytest.raises(ValueError, match=r"not a tiled TIFF \(no tags \[324, 325\]\)"):
        read_tiled(tmp_path / "strips.tif")
