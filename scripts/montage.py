#!/usr/bin/env python3
"""Tiles 8-bit grey preview PNGs into one sheet for a quick look (no dependencies).

usage: scripts/montage.py OUT.png COLUMNS TILE_PX IN1.png IN2.png ...
Each input is shrunk by min-pooling (so thin dark twigs survive) to TILE_PX square.
"""
import struct
import sys
import zlib


def read_png(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, w, h = 8, b"", 0, 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
            assert depth == 8 and ctype == 0, "expects 8-bit grey"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    rows, prev = [], bytearray(w)
    for y in range(h):
        f = raw[y * (w + 1)]
        line = bytearray(raw[y * (w + 1) + 1:(y + 1) * (w + 1)])
        for x in range(w):
            a = line[x - 1] if x else 0
            b = prev[x]
            c = prev[x - 1] if x else 0
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + b) & 255
            elif f == 3: line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pr = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[x] = (line[x] + pr) & 255
        rows.append(line)
        prev = line
    return w, h, rows


def write_png(path, w, h, rows):
    raw = b"".join(b"\x00" + bytes(r) for r in rows)
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b"")
    open(path, "wb").write(png)


def main():
    out, cols, tile = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    files = sys.argv[4:]
    nrows = (len(files) + cols - 1) // cols
    W, H = cols * tile, nrows * tile
    sheet = [bytearray([255]) * W for _ in range(H)]
    for i, f in enumerate(files):
        w, h, rows = read_png(f)
        k = max(1, -(-w // tile))
        ox, oy = (i % cols) * tile, (i // cols) * tile
        for ty in range(min(tile, h // k)):
            block = rows[ty * k:(ty + 1) * k]
            for tx in range(min(tile, w // k)):
                sheet[oy + ty][ox + tx] = min(min(r[tx * k:(tx + 1) * k]) for r in block)
        for t in range(tile):  # tile border
            sheet[oy + t][ox] = sheet[oy][ox + t] = 200
    write_png(out, W, H, sheet)


if __name__ == "__main__":
    main()
