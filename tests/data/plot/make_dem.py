#!/usr/bin/python3
"""Writes the DEM fixtures of tests/data/plot/ (run from this folder; standard library only).

dem_plane.png: 64 × 56 pixels, 16-bit grey, value(column, row) = 1000 + 40·column + 25·row —
a plane whose heights the tests know exactly (tests/species/plot/layout_test.cpp).
dem_small.png: the same plane cropped to 20 × 20 pixels (too small for dem.toml's plot).
bad/dem_rgb.png: 64 × 56 pixels, 8-bit RGB (a DEM must be single-channel).
bad/dem_corrupt.png: a PNG signature followed by garbage.
"""
import struct
import zlib


def chunk(kind, data):
    return (struct.pack(">I", len(data)) + kind + data +
            struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))


def png(path, width, height, bit_depth, colour_type, rows):
    raw = b"".join(b"\x00" + row for row in rows)
    data = (b"\x89PNG\r\n\x1a\n" +
            chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, bit_depth, colour_type, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    with open(path, "wb") as f:
        f.write(data)


def plane(width, height):
    return [b"".join(struct.pack(">H", 1000 + 40 * c + 25 * r) for c in range(width))
            for r in range(height)]


png("dem_plane.png", 64, 56, 16, 0, plane(64, 56))
png("dem_small.png", 20, 20, 16, 0, plane(20, 20))
png("bad/dem_rgb.png", 64, 56, 8, 2,
    [b"".join(bytes([c, r, 7]) for c in range(64)) for r in range(56)])
with open("bad/dem_corrupt.png", "wb") as f:
    f.write(b"\x89PNG\r\n\x1a\n" + b"this is not a PNG's IHDR chunk, only garbage bytes")
