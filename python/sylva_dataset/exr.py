"""A small reader of single-part scanline OpenEXR files: the depth maps sylva writes.

sylva's depth EXRs (pipeline/formats/image_codecs.cpp) are single-part scanline OpenEXR 2.0 files
with one FLOAT or HALF channel, RLE compression with one scanline per chunk or ZIP with 16. This
reader decodes those and the other lossless scanline layouts a re-saved file is likely to have:
compression NONE, RLE, ZIPS (1 line per chunk) and ZIP (16 lines), channels of type UINT, HALF
or FLOAT, any number of channels, any data window. The layout is the one in OpenEXR's
"OpenEXR File Layout" document: magic number, version, header attributes, line offset table,
then chunks of (y, data size, data), each scanline holding the channels in name order. For
anything else (tiled, multi-part, deep, PIZ/PXR24/B44/DWA compression, subsampled channels)
read_exr falls back on OpenImageIO's Python module when it is importable (Debian:
python3-openimageio). Every reader takes a path or the file's bytes (a tar shard's member).
"""

import os
import struct
import tempfile
import zlib

import numpy as np

from .source import read_source

__all__ = ["read_exr", "read_exr_first_channel"]

_MAGIC = 20000630
_PIXEL_TYPES = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}
_LINES_PER_CHUNK = {0: 1, 1: 1, 2: 1, 3: 16}  # NONE, RLE, ZIPS, ZIP
_COMPRESSION_NAMES = {0: "none", 1: "rle", 2: "zips", 3: "zip", 4: "piz", 5: "pxr24", 6: "b44",
                      7: "b44a", 8: "dwaa", 9: "dwab"}


class UnsupportedExr(ValueError):
    """An EXR layout this reader does not decode (read_exr then tries OpenImageIO)."""


def _cstring(data, pos):
    end = data.index(b"\0", pos)
    return data[pos:end].decode("latin-1"), end + 1


def _header(data, path):
    if len(data) < 8 or struct.unpack_from("<i", data, 0)[0] != _MAGIC:
        raise ValueError("%s: not an OpenEXR file" % path)
    version = struct.unpack_from("<I", data, 4)[0]
    if version & 0xFF != 2:
        raise UnsupportedExr("%s: OpenEXR version %d" % (path, version & 0xFF))
    if version & 0x1A00:  # tiled (0x200), deep (0x800), multi-part (0x1000)
        raise UnsupportedExr("%s: tiled, deep or multi-part OpenEXR" % path)
    pos, attrs = 8, {}
    while True:
        name, pos = _cstring(data, pos)
        if not name:
            return attrs, pos
        kind, pos = _cstring(data, pos)
        size = struct.unpack_from("<i", data, pos)[0]
        pos += 4
        attrs[name] = (kind, data[pos:pos + size])
        pos += size


def _channels(value):
    """chlist: (name, numpy dtype, x sampling, y sampling), in file (= name) order."""
    out, pos = [], 0
    while pos < len(value) and value[pos] != 0:
        name, pos = _cstring(value, pos)
        ptype, _linear, xs, ys = struct.unpack_from("<iB3xii", value, pos)
        pos += 16
        out.append((name, ptype, xs, ys))
    return out


def _rle_decode(src, size):
    """OpenEXR RLE: a signed count byte; c < 0: −c literal bytes follow; c ≥ 0: c + 1 copies of
    the next byte."""
    out = bytearray()
    i, n = 0, len(src)
    while i < n:
        c = src[i]
        if c >= 128:  # negative: a literal stretch
            count = 256 - c
            out += src[i + 1:i + 1 + count]
            i += 1 + count
        else:
            out += bytes((src[i + 1],)) * (c + 1)
            i += 2
    if len(out) != size:
        raise ValueError("RLE data decodes to %d bytes, expected %d" % (len(out), size))
    return bytes(out)


def _unpredict(raw):
    """Undo the RLE/ZIP predictor (deltas + 128) and the split of bytes into even/odd halves."""
    t = np.frombuffer(raw, np.uint8).astype(np.int64)
    t[1:] -= 128
    t = (np.cumsum(t) & 0xFF).astype(np.uint8)
    half = (len(t) + 1) // 2
    out = np.empty(len(t), np.uint8)
    out[0::2] = t[:half]
    out[1::2] = t[half:]
    return out.tobytes()


def _read_native(path, data):
    attrs, pos = _header(data, path)
    for key in ("channels", "compression", "dataWindow"):
        if key not in attrs:
            raise ValueError("%s: EXR header has no %s attribute" % (path, key))
    compression = attrs["compression"][1][0]
    if compression not in _LINES_PER_CHUNK:
        raise UnsupportedExr("%s: EXR compression %s" % (path, _COMPRESSION_NAMES.get(compression,
                                                                                        compression)))
    channels = _channels(attrs["channels"][1])
    for name, ptype, xs, ys in channels:
        if ptype not in _PIXEL_TYPES or xs != 1 or ys != 1:
            raise UnsupportedExr("%s: channel %r: pixel type %d, sampling %d×%d" % (path, name, ptype,
                                                                                      xs, ys))
    x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"][1])
    width, height = x1 - x0 + 1, y1 - y0 + 1
    per_chunk = _LINES_PER_CHUNK[compression]
    chunks = (height + per_chunk - 1) // per_chunk
    offsets = struct.unpack_from("<%dQ" % chunks, data, pos)
    dtypes = [_PIXEL_TYPES[c[1]] for c in channels]
    line_bytes = sum(width * dt.itemsize for dt in dtypes)
    planes = [np.empty((height, width), dt) for dt in dtypes]
    for offset in offsets:
        y, size = struct.unpack_from("<ii", data, offset)
        row = y - y0
        lines = min(per_chunk, height - row)
        if row < 0 or row >= height:
            raise ValueError("%s: chunk at byte %d has y = %d outside the data window" % (path, offset,
                                                                                          y))
        expected = lines * line_bytes
        body = data[offset + 8:offset + 8 + size]
        if len(body) != size:
            raise ValueError("%s: chunk at byte %d is truncated" % (path, offset))
        if size < expected:  # compressed (a chunk that would not shrink is stored raw)
            if compression == 1:
                body = _unpredict(_rle_decode(body, expected))
            elif compression in (2, 3):
                body = _unpredict(zlib.decompress(body))
            else:
                raise ValueError("%s: uncompressed chunk of %d bytes, expected %d" % (path, size,
                                                                                      expected))
        if len(body) != expected:
            raise ValueError("%s: chunk at y = %d holds %d bytes, expected %d" % (path, y, len(body),
                                                                                  expected))
        at = 0
        for k in range(lines):
            for plane, dt in zip(planes, dtypes):
                n = width * dt.itemsize
                plane[row + k] = np.frombuffer(body, dt, width, at)
                at += n
    return {name: plane.astype(plane.dtype.newbyteorder("="))
            for (name, _, _, _), plane in zip(channels, planes)}


def _read_oiio(source, path):
    import OpenImageIO as oiio  # noqa: N813 (the module's own name)

    if isinstance(source, (bytes, bytearray, memoryview)):
        # OpenImageIO's Python module opens files only: bytes (a tar member) go through a
        # temporary file, for the layouts the native decoder above does not read.
        fd, tmp = tempfile.mkstemp(suffix=".exr")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(source)
            return _read_oiio(tmp, path)
        finally:
            os.unlink(tmp)
    inp = oiio.ImageInput.open(source)
    if inp is None:
        raise ValueError("%s: OpenImageIO: %s" % (path, oiio.geterror()))
    try:
        spec = inp.spec()
        pixels = inp.read_image(0, 0, 0, spec.nchannels, "float")
    finally:
        inp.close()
    pixels = np.asarray(pixels, np.float32).reshape(spec.height, spec.width, spec.nchannels)
    return {name: np.ascontiguousarray(pixels[:, :, c])
            for c, name in enumerate(spec.channelnames)}


def read_exr(source, name=None):
    """Reads an OpenEXR image into {channel name: (H, W) array}, channels in the file's order
    (OpenEXR stores them sorted by name). FLOAT channels come back as float32, HALF as float16,
    UINT as uint32, all native byte order. Files this reader does not decode go through
    OpenImageIO (as float32) when its Python module is importable. source: a path or the file's
    bytes; name: what error messages call it."""
    data, path = read_source(source, name)
    try:
        return _read_native(path, data)
    except UnsupportedExr:
        try:
            return _read_oiio(source, path)
        except ImportError:
            raise UnsupportedExr("%s: not a layout sylva_dataset decodes, and OpenImageIO's Python "
                                 "module is not installed (Debian: python3-openimageio)" % path)


def read_exr_first_channel(source, name=None):
    """The first channel of an EXR file (a path or its bytes), whatever its name, as a float32
    (H, W) array. sylva's depth maps have exactly one channel."""
    channels = read_exr(source, name)
    if not channels:
        raise ValueError("%s: EXR file has no channels" % (name or source))
    return np.asarray(next(iter(channels.values())), np.float32)
