"""A PNG decoder for 8- and 16-bit non-interlaced grey / grey+alpha / RGB / RGBA images: sylva's
views (8-bit grey) and 16-bit depth PNGs."""

import struct
import zlib

import numpy as np

from .source import read_source

__all__ = ["read_png"]


_PNG_CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}


def read_png(source, name=None):
    """Decodes a non-interlaced PNG (grey, grey+alpha, RGB, RGBA; 8 or 16 bits per sample) to a
    uint8 or uint16 array: (H, W) for grey, (H, W, C) otherwise. source: a path or the file's
    bytes; name: what error messages call it."""
    data, path = read_source(source, name)
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("%s: not a PNG file" % path)
    pos, idat, hdr = 8, [], None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        chunk = data[pos + 8:pos + 8 + length]
        if zlib.crc32(kind + chunk) & 0xFFFFFFFF != struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])[0]:
            raise ValueError("%s: bad CRC in %s chunk" % (path, kind.decode("latin-1")))
        if kind == b"IHDR":
            hdr = struct.unpack(">IIBBBBB", chunk)
        elif kind == b"IDAT":
            idat.append(chunk)
        elif kind == b"IEND":
            break
        pos += 12 + length
    if hdr is None:
        raise ValueError("%s: no IHDR" % path)
    w, h, depth, ctype, _, _, interlace = hdr
    if depth not in (8, 16) or ctype not in _PNG_CHANNELS or interlace:
        raise ValueError("%s: only 8- or 16-bit non-interlaced grey/RGB(A) PNGs are supported "
                         "(depth %d, colour type %d, interlace %d)" % (path, depth, ctype, interlace))
    channels = _PNG_CHANNELS[ctype]
    bpp = channels * depth // 8  # bytes per pixel: the filters' unit
    stride = w * bpp
    raw = np.frombuffer(zlib.decompress(b"".join(idat)), np.uint8)
    if raw.size != h * (stride + 1):
        raise ValueError("%s: image data has %d bytes, expected %d" % (path, raw.size, h * (stride + 1)))
    raw = raw.reshape(h, stride + 1)
    img = np.zeros((h, stride), np.uint8)
    prev = np.zeros(stride, np.uint8)
    for y in range(h):
        ft, line = raw[y, 0], raw[y, 1:]
        if ft == 0:  # None
            cur = line.copy()
        elif ft == 1:  # Sub: a running sum per channel
            cur = (np.cumsum(line.reshape(w, bpp).astype(np.int64), axis=0) % 256).astype(np.uint8).reshape(stride)
        elif ft == 2:  # Up
            cur = (line.astype(np.uint16) + prev) % 256
            cur = cur.astype(np.uint8)
        elif ft in (3, 4):  # Average, Paeth: sequential
            cur = bytearray(stride)
            lb, pb = line.tobytes(), prev.tobytes()
            for i in range(stride):
                a = cur[i - bpp] if i >= bpp else 0
                b = pb[i]
                if ft == 3:
                    cur[i] = (lb[i] + ((a + b) >> 1)) & 0xFF
                else:
                    c = pb[i - bpp] if i >= bpp else 0
                    p = a + b - c
                    pa, pbb, pc = abs(p - a), abs(p - b), abs(p - c)
                    pred = a if pa <= pbb and pa <= pc else (b if pbb <= pc else c)
                    cur[i] = (lb[i] + pred) & 0xFF
            cur = np.frombuffer(bytes(cur), np.uint8)
        else:
            raise ValueError("%s: bad PNG filter type %d in row %d" % (path, ft, y))
        img[y] = cur
        prev = img[y]
    if depth == 16:  # samples are big-endian
        img = img.view(">u2").astype(np.uint16)
    return img.reshape(h, w) if channels == 1 else img.reshape(h, w, channels)
