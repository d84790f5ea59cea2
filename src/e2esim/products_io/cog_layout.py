"""The Cloud-Optimised GeoTIFF's layout, written from tiles GDAL already compressed: the full-resolution image and
each overview are written during the run as tiled GeoTIFFs (GDAL's GTiff driver: its tags, its compression), and
``write_cog`` lays their compressed tiles out as GDAL's COG driver does, without decompressing or compressing them
again (GDAL's COG driver has no such copy: it compresses every tile again, serially after the run).

The layout is the one GDAL's COG driver writes and documents (GDAL, "COG -- Cloud Optimized GeoTIFF generator",
section "File format details"; TIFF 6.0 and BigTIFF for the structures):

- the header, then the "ghost" structural metadata (``GDAL_STRUCTURAL_METADATA_SIZE=...``: IFDs before the data,
  blocks in row-major order, each block led by its size as a uint32 and trailed by its last 4 bytes repeated);
- the image file directories (IFDs), each followed by its tags' out-of-line values: the full-resolution image
  first, then the overviews from the largest to the smallest (``NewSubfileType`` 1);
- the tiles: the smallest overview's first, the full-resolution image's last, each in row-major order.

Classic TIFF where the file stays under 4 GiB, BigTIFF beyond. Only little-endian files are read (GDAL writes the
machine's order, little-endian on the platforms e2esim supports); anything else is refused by name."""

from __future__ import annotations

import contextlib
import os
import struct
from dataclasses import dataclass
from pathlib import Path

TYPE_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 8, 6: 1, 7: 1, 8: 2, 9: 4, 10: 8, 11: 4, 12: 8, 16: 8, 17: 8, 18: 8}
"""Bytes of one value of each TIFF field type (TIFF 6.0 sec. 2; LONG8, SLONG8, IFD8: BigTIFF)."""
NEW_SUBFILE_TYPE, TILE_OFFSETS, TILE_BYTE_COUNTS = 254, 324, 325
SHORT, LONG, LONG8 = 3, 4, 16
GHOST = ("LAYOUT=IFDS_BEFORE_DATA\nBLOCK_ORDER=ROW_MAJOR\nBLOCK_LEADER=SIZE_AS_UINT4\n"
         "BLOCK_TRAILER=LAST_4_BYTES_REPEATED\nKNOWN_INCOMPATIBLE_EDITION=NO\n ")
"""GDAL's structural metadata of a COG (the text after its first line), as GDAL's COG driver writes it."""


@dataclass
class TiledImage:
    """The first IFD of a tiled TIFF: its tags other than the tiles' offsets and byte counts ({tag: (type, count,
    value bytes)}), and where its compressed tiles lie in ``path``."""

    path: Path
    tags: dict
    offsets: list
    byte_counts: list


def read_tiled(path) -> TiledImage:
    """The first IFD of the little-endian tiled TIFF or BigTIFF ``path`` (as GDAL's GTiff driver writes it)."""
    path = Path(path)
    with open(path, "rb") as f:
        head = f.read(16)
        if head[:4] == b"II*\x00":
            big, (ifd,) = False, struct.unpack_from("<I", head, 4)
        elif head[:4] == b"II+\x00":
            big, (ifd,) = True, struct.unpack_from("<Q", head, 8)
        else:
            raise ValueError(f"{path}: not a little-endian TIFF or BigTIFF (starts {head[:4]!r})")
        count_format, entry_format, inline = ("<Q", "<HHQ", 8) if big else ("<H", "<HHI", 4)
        f.seek(ifd)
        (n,) = struct.unpack(count_format, f.read(struct.calcsize(count_format)))
        entry = struct.calcsize(entry_format) + inline
        raw = f.read(n * entry)
        tags = {}
        for i in range(n):
            tag, kind, count = struct.unpack_from(entry_format, raw, i * entry)
            size = TYPE_SIZES[kind] * count
            at = i * entry + struct.calcsize(entry_format)
            if size <= inline:
                value = raw[at:at + size]
            else:
                (offset,) = struct.unpack_from("<Q" if big else "<I", raw, at)
                f.seek(offset)
                value = f.read(size)
            tags[tag] = (kind, count, value)
    missing = {TILE_OFFSETS, TILE_BYTE_COUNTS} - tags.keys()
    if missing:
        raise ValueError(f"{path}: not a tiled TIFF (no tags {sorted(missing)})")
    offsets, counts = (_numbers(*tags.pop(t)) for t in (TILE_OFFSETS, TILE_BYTE_COUNTS))
    return TiledImage(path, tags, offsets, counts)


def _numbers(kind: int, count: int, value: bytes) -> list:
    return list(struct.unpack(f"<{count}{ {3: 'H', 4: 'I', 16: 'Q'}[kind] }", value))


def write_cog(target, images: list, bigtiff: bool | None = None) -> None:
    """Write the COG ``target`` from ``images`` (``TiledImage``: the full-resolution image, then the overviews from
    the largest to the smallest), copying their compressed tiles as they are. bigtiff : None: BigTIFF only where
    a classic TIFF cannot hold the file (4 GiB) or a tag's 64-bit values."""
    data_bytes = sum(sum(c) + 8 * len(c) for c in (im.byte_counts for im in images))
    wide_tags = any(kind in (16, 17, 18) for im in images for kind, _, _ in im.tags.values())
    big = wide_tags or _layout_ifds(images, False)[1] + data_bytes >= 2**32 if bigtiff is None else bigtiff
    ifds_end = _layout_ifds(images, big)[1]
    # tile data: smallest overview first, each tile led by its size and trailed by its last 4 bytes
    offsets, at = [None] * len(images), ifds_end
    for index in reversed(range(len(images))):
        offsets[index] = []
        for count in images[index].byte_counts:
            offsets[index].append(at + 4)
            at += count + 8
    blob, _ = _layout_ifds(images, big, offsets)
    with open(target, "wb") as out:
        out.write(blob)
        for index in reversed(range(len(images))):
            image = images[index]
            with open(image.path, "rb") as src:
                for offset, count in zip(image.offsets, image.byte_counts):
                    out.write(struct.pack("<I", count))
                    out.flush()
                    _copy(src, out, offset, count)
                    src.seek(offset + count - min(count, 4))
                    out.write(src.read(min(count, 4)).rjust(4, b"\0"))


def _copy(src, out, offset: int, count: int) -> None:
    """Copy ``count`` bytes at ``offset`` of ``src`` to the end of ``out`` (flushed): in the kernel where it can
    (``os.copy_file_range``, Linux), else through memory."""
    done = 0
    if hasattr(os, "copy_file_range"):
        with contextlib.suppress(OSError):  # not supported between these files: the rest copied through memory below
            while done < count:
                n = os.copy_file_range(src.fileno(), out.fileno(), count - done, offset + done)
                if n == 0:
                    break
                done += n
        out.seek(0, os.SEEK_END)
    if done < count:
        src.seek(offset + done)
        out.write(src.read(count - done))


def _layout_ifds(images: list, big: bool, tile_offsets: list | None = None) -> tuple:
    """The header, ghost area and IFDs (with their out-of-line values) as bytes, and their length."""
    ghost = f"GDAL_STRUCTURAL_METADATA_SIZE={len(GHOST):06d} bytes\n{GHOST}".encode()
    ghost += b"\0" * (len(ghost) % 2)  # an IFD starts on a word boundary (TIFF 6.0 sec. 2)
    first_ifd = (16 if big else 8) + len(ghost)
    header = (b"II+\x00" + struct.pack("<HHQ", 8, 0, first_ifd)) if big else (b"II*\x00" + struct.pack("<I",
                                                                                                        first_ifd))
    parts, at = [header, ghost], first_ifd
    offset_kind = LONG8 if big else LONG
    for index, image in enumerate(images):
        tags = dict(image.tags)
        if index > 0:
            tags[NEW_SUBFILE_TYPE] = (LONG, 1, struct.pack("<I", 1))  # a reduced-resolution image
        n = len(image.byte_counts)
        offsets = tile_offsets[index] if tile_offsets else [0] * n
        fmt = "Q" if big else "I"
        tags[TILE_OFFSETS] = (offset_kind, n, struct.pack(f"<{n}{fmt}", *offsets))
        tags[TILE_BYTE_COUNTS] = (offset_kind, n, struct.pack(f"<{n}{fmt}", *image.byte_counts))
        last = index == len(images) - 1
        block = _ifd(tags, big, at, last)
        parts.append(block)
        at += len(block)
    blob = b"".join(parts)
    return blob, len(blob)


def _ifd(tags: dict, big: bool, at: int, last: bool) -> bytes:
    """One IFD at file offset ``at`` followed by its tags' out-of-line values (each at an even offset); its next-IFD
    pointer is the byte after them (0 for the last)."""
    count_format, entry_format, inline = ("<Q", "<HHQ", 8) if big else ("<H", "<HHI", 4)
    next_format = "<Q" if big else "<I"
    entry = struct.calcsize(entry_format) + inline
    size = struct.calcsize(count_format) + len(tags) * entry + struct.calcsize(next_format)
    extra, entries = bytearray(), bytearray()
    for tag in sorted(tags):
        kind, count, value = tags[tag]
        entries += struct.pack(entry_format, tag, kind, count)
        if len(value) <= inline:
            entries += value.ljust(inline, b"\0")
        else:
            entries += struct.pack(next_format, at + size + len(extra))
            extra += value + b"\0" * (len(value) % 2)
    end = at + size + len(extra)
    return (struct.pack(count_format, len(tags)) + bytes(entries) + struct.pack(next_format, 0 if last else end)
            + bytes(extra))
