#!/usr/bin/env python3
"""Tiles 8-bit grey or RGB PNGs (previews, contact sheets) into one RGB sheet for a quick look
(no dependencies).

usage: scripts/montage.py OUT.png COLUMNS TILE_PX IN1.png IN2.png ...
Each input is shrunk to TILE_PX square by keeping, of every k×k block, its darkest pixel (so
thin dark twigs survive, in their label colours).
"""
import struct
import sys
import zlib


def read_png(path):
    """Width, height and rows of (r, g, b) tuples of an 8-bit grey or RGB PNG."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, w, h, nc = 8, b"", 0, 0, 1
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
            assert depth == 8 and ctype in (0, 2), "expects 8-bit grey or RGB"
            nc = 1 if ctype == 0 else 3
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride = w * nc
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for x in range(stride):
            a = line[x - nc] if x >= nc else 0
            b = prev[x]
            c = prev[x - nc] if x >= nc else 0
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + b) & 255
            elif f == 3: line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pr = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[x] = (line[x] + pr) & 255
        rows.append([tuple(line[x * nc:(x + 1) * nc]) * (3 // nc) for x in range(w)])
        prev = line
    return w, h, rows


def write_png(path, w, h, rows):
    raw = b"".join(b"\x00" + bytes(v for px in r for v in px) for r in rows)
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b"")
    open(path, "wb").write(png)


def main():
    out, cols, tile = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    files = sys.argv[4:]
    nrows = (len(files) + cols - 1) // cols
    W, H = cols * tile, nrows * tile
    white, border = (255, 255, 255), (200, 200, 200)
    sheet = [[white] * W for _ in range(H)]
    luminance = lambda p: 2126 * p[0] + 7152 * p[1] + 722 * p[2]
    for i, f in enumerate(files):
        w, h, rows = read_png(f)
        k = max(1, -(-max(w, h) // tile))
        ox, oy = (i % cols) * tile, (i // cols) * tile
        for ty in range(min(tile, h // k)):
            block = rows[ty * k:(ty + 1) * k]
            for tx in range(min(tile, w // k)):
                sheet[oy + ty][ox + tx] = min((p for r in block for p in r[tx * k:(tx + 1) * k]),
                                              key=luminance)
        for t in range(tile):  # tile border
            sheet[oy + t][ox] = sheet[oy][ox + t] = border
    write_png(out, W, H, sheet)


if __name__ == "__main__":
    main()
