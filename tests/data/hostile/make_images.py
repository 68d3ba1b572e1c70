#!/usr/bin/env python3
"""Writes the broken images and SVG sketches the hostile-input fixtures name (standard library
only): python3 tests/data/hostile/make_images.py. Each file is small; the point of each is in
its name and in the comment of the fixture that names it."""
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))


def chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png(width, height, raw=None, iend=True, depth=8, colour=0):
    """A PNG whose IHDR declares width × height; `raw` is the filtered scanline data (default:
    a white disc on black, grey 8-bit)."""
    if raw is None:
        raw = b"".join(
            b"\0" + bytes(255 if (x - width // 2) ** 2 + (y - height // 2) ** 2 < (height // 3) ** 2
                          else 0 for x in range(width))
            for y in range(height))
    ihdr = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw))
    return data + (chunk(b"IEND", b"") if iend else b"")


def write(name, data):
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(data)


good = png(40, 40)
images = {
    "empty.png": b"",                                          # 0 bytes
    "text.png": b"this is a text file named .png\n",           # no PNG signature
    "signature_only.png": good[:8],                            # ends inside the header
    "truncated.png": good[: len(good) // 2],                   # ends inside IDAT
    "no_iend.png": png(40, 40, iend=False),                    # image data whole, no IEND chunk
    # the last byte of the IDAT chunk's data flipped: zlib's check (or the CRC) fails
    "bad_crc.png": good[:-13] + bytes([good[-13] ^ 0xFF]) + good[-12:],
    "huge_dims.png": png(100000, 100000, raw=b"\0" * 1000),    # declares 10¹⁰ pixels
    "wide.png": png(20000, 10, raw=b"\0" * 1000),              # 20000 px: over 16384 a side
    "zero_width.png": png(0, 10, raw=b""),
    "garbage_idat.png": b"\x89PNG\r\n\x1a\n"
    + chunk(b"IHDR", struct.pack(">IIBBBBB", 40, 40, 8, 0, 0, 0, 0))
    + chunk(b"IDAT", b"\x78\x9c" + b"not deflate data" * 8)
    + chunk(b"IEND", b""),
    "short_idat.png": png(40, 40, raw=b"\0" * 100),            # 100 of 1640 bytes of pixels
    "bad_depth.png": b"\x89PNG\r\n\x1a\n"
    + chunk(b"IHDR", struct.pack(">IIBBBBB", 40, 40, 7, 0, 0, 0, 0))   # bit depth 7
    + chunk(b"IEND", b""),
}
for name, data in images.items():
    write(os.path.join("images", name), data)

# Valid PNGs of every colour type and bit depth libpng expands, read by image_file_test.cpp
# against OpenImageIO's read of the same file.


def png_full(width, height, depth, colour, raw, extra=b"", interlace=0):
    ihdr = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, interlace)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + extra + chunk(b"IDAT", zlib.compress(raw))
            + chunk(b"IEND", b""))


def rows(width, height, samples_of):
    return b"".join(b"\0" + bytes(v for x in range(width) for v in samples_of(x, y))
                    for y in range(height))


W, H = 13, 7
valid = {
    "ok_grey8.png": png_full(W, H, 8, 0, rows(W, H, lambda x, y: [(x * 19 + y * 7) % 256])),
    "ok_grey16.png": png_full(W, H, 16, 0, b"".join(
        b"\0" + b"".join(struct.pack(">H", (x * 5003 + y * 977) % 65536) for x in range(W))
        for y in range(H))),
    "ok_grey1.png": png_full(16, H, 1, 0, b"".join(bytes([0, 0b10110010 ^ y, 0b01101100])
                                                   for y in range(H))),
    "ok_grey_alpha8.png": png_full(W, H, 8, 4, rows(W, H, lambda x, y: [x * 17 % 256, y * 36])),
    "ok_rgb8.png": png_full(W, H, 8, 2, rows(W, H, lambda x, y: [x * 19, y * 36, (x + y) * 11])),
    "ok_rgba8.png": png_full(W, H, 8, 6, rows(W, H, lambda x, y: [x * 19, y * 36, 200, x * y * 3])),
    "ok_palette.png": png_full(
        W, H, 8, 3, rows(W, H, lambda x, y: [(x + y) % 4]),
        extra=chunk(b"PLTE", bytes([0, 0, 0, 255, 0, 0, 0, 255, 0, 250, 250, 250]))),
    "ok_palette_trns.png": png_full(
        W, H, 8, 3, rows(W, H, lambda x, y: [(x * y) % 4]),
        extra=chunk(b"PLTE", bytes([0, 0, 0, 255, 0, 0, 0, 255, 0, 250, 250, 250]))
        + chunk(b"tRNS", bytes([0, 128, 255]))),
    # Adam7-interlaced: the passes' scanlines one after the other.
    "ok_interlaced.png": None,
    "ok_side_16384.png": png_full(16384, 1, 8, 0, b"\0" + bytes(i % 251 for i in range(16384))),
}


def adam7(width, height, sample):
    passes = [(0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2),
              (0, 1, 1, 2)]
    out = b""
    for x0, y0, dx, dy in passes:
        xs = list(range(x0, width, dx))
        if not xs:
            continue
        for y in range(y0, height, dy):
            out += b"\0" + bytes(sample(x, y) for x in xs)
    return out


valid["ok_interlaced.png"] = png_full(W, H, 8, 0, adam7(W, H, lambda x, y: (x * 19 + y * 7) % 256),
                                      interlace=1)
for name, data in valid.items():
    write(os.path.join("images", name), data)

sketches = {
    "empty.svg": b"",
    "no_path.svg": b'<svg xmlns="http://www.w3.org/2000/svg"><rect width="4" height="6"/></svg>',
    "bad_command.svg": b'<svg><path d="M 0 0 Q 1 2 X 3 4"/></svg>',
    "nan.svg": b'<svg><path d="M 0 0 L nan 1 L 0 5"/></svg>',
    "huge_coordinate.svg": b'<svg><path d="M 0 0 L 1e308 1 L 0 5"/></svg>',
    "incomplete.svg": b'<svg><path d="M 0 0 L 2"/></svg>',
    "arc.svg": b'<svg><path d="M 0 0 A 5 5 0 1 1 0 10"/></svg>',
    "binary.svg": bytes(range(256)) * 4,
    "unterminated.svg": b'<svg><path d="M 0 0 L 2 3 L 0 6',
}
for name, data in sketches.items():
    write(os.path.join("sketches", name), data)
