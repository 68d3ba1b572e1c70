"""The one PNG writer of the sketch generators (standard library only, deterministic)."""

import struct
import zlib


def write_png(path, width, height, pixels, channels=1):
    """8-bit PNG, grey (1 channel) or RGB (3): signature, IHDR, one IDAT (filter 0 on every
    row, zlib level 9), IEND. `pixels` holds width·height·channels bytes, rows top first."""
    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    colour_type = {1: 0, 3: 2}[channels]
    stride = width * channels
    raw = b"".join(b"\x00" + bytes(pixels[y * stride:(y + 1) * stride]) for y in range(height))
    png = (b"\x89PNG\r\n\x1a\n" +
           chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0)) +
           chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    with open(path, "wb") as f:
        f.write(png)
