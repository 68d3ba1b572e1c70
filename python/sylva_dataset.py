"""Read a sylva dataset directory from Python (standard library + numpy only).

A dataset directory (written by ``sylva build``) holds ``dataset.json``, ``manifest.jsonl`` (one
JSON record per instance; shards write ``manifest.shard-I-of-N.jsonl``) and
``trees/<species>/<id>/`` with the files the record's ``files`` map names. This module reads them
back::

    import sylva_dataset as sd

    ds = sd.Dataset("out/demo")          # dataset.json + every complete manifest record
    ds.info["seed"], len(ds), ds.species  # facts, instance count, species names (first-seen order)
    for inst in ds:                       # Instance objects, in manifest (= instance) order
        inst.id, inst.species, inst.index, inst.seed   # index: within its species and sweep point
        inst.record                       # the manifest record (dict): params, sweep, stats, ...
        inst.stats["height_m"]
        sk = inst.skeleton()              # Skeleton(nodes, positions, radius, edges)
        sk.nodes["order"]                 #   structured array: x y z radius order part
        sk.edges                          #   (E, 2) int array of node indices (vertex1, vertex2)
        m = inst.mesh()                   # Mesh(vertices, positions, faces); inst.mesh("watertight")
        m.vertices["nx"], m.faces         #   structured vertex array, (F, 3) int array (triangles)
        cams = inst.cameras()             # transforms.json (dict: intrinsics + "frames")
        masks = inst.masks()              # list of (H, W) uint8 silhouettes: 0 background, 255 tree
        labels = inst.labels()            # list of (H, W) uint8: 0 background, 1 + order wood, 254 root, 255 leaf
    inst = ds["tiny-p000-00003"]          # by id (or ds[3] by position)
    ds.by_species("tiny")                 # the instances of one species

Low-level readers usable on their own: ``read_ply(path) -> {element name: numpy array}`` (binary
little/big-endian PLY; a list property becomes a fixed-width field when every row has the same
count, else an object array of index arrays) and ``read_png(path) -> numpy uint8 array`` (8-bit
grey, grey+alpha, RGB, RGBA; non-interlaced; all five row filters; (H, W) for grey, (H, W, C)
otherwise). Depth views (OpenEXR) are not decoded here; use OpenImageIO or OpenEXR for those.

Torn last manifest lines (a killed build) are skipped, as ``sylva`` itself does on resume.
"""

import json
import os
import re
import struct
import zlib
from collections import namedtuple

import numpy as np

__all__ = ["Dataset", "Instance", "Skeleton", "Mesh", "read_ply", "read_png"]

Skeleton = namedtuple("Skeleton", "nodes positions radius edges")
Mesh = namedtuple("Mesh", "vertices positions faces")

# --- PLY ------------------------------------------------------------------------------------------

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def _ply_header(data):
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise ValueError("not a PLY file")
    body = data.index(b"\n", end) + 1
    fmt, elements = None, []
    for line in data[:end].decode("ascii").splitlines():
        w = line.split()
        if not w or w[0] in ("ply", "comment", "obj_info"):
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property":
            if w[1] == "list":
                elements[-1][2].append((w[4], ("list", _PLY_TYPES[w[2]], _PLY_TYPES[w[3]])))
            else:
                elements[-1][2].append((w[2], _PLY_TYPES[w[1]]))
    if fmt not in ("binary_little_endian", "binary_big_endian"):
        raise ValueError("PLY format %r: only binary PLY is supported" % fmt)
    return ("<" if fmt == "binary_little_endian" else ">"), elements, body


def read_ply(path):
    """Reads a binary PLY file into {element name: numpy structured array}."""
    with open(path, "rb") as f:
        data = f.read()
    bo, elements, pos = _ply_header(data)
    out = {}
    for name, count, props in elements:
        lists = [p for p in props if isinstance(p[1], tuple)]
        if not lists:
            dt = np.dtype([(p, bo + t) for p, t in props])
            out[name] = np.frombuffer(data, dt, count, pos).copy()
            pos += dt.itemsize * count
            continue
        # Fast path: every row's lists have the count of the first row.
        first = {}
        off = pos
        fields = []
        for p, t in props:
            if isinstance(t, tuple):
                ct = np.dtype(bo + t[1])
                n = int(np.frombuffer(data, ct, 1, off)[0]) if count else 0
                first[p] = n
                fields += [(p + "__count", bo + t[1]), (p, bo + t[2], (n,))]
                off += ct.itemsize + n * np.dtype(t[2]).itemsize
            else:
                fields.append((p, bo + t))
                off += np.dtype(t).itemsize
        dt = np.dtype(fields)
        if count == 0 or pos + dt.itemsize * count <= len(data):
            arr = np.frombuffer(data, dt, count, pos) if count else np.zeros(0, dt)
            if all((arr[p + "__count"] == n).all() for p, n in first.items()):
                out[name] = arr.copy()
                pos += dt.itemsize * count
                continue
        # General path: row by row, lists as object arrays.
        rows = []
        for _ in range(count):
            row = []
            for p, t in props:
                if isinstance(t, tuple):
                    ct, it = np.dtype(bo + t[1]), np.dtype(bo + t[2])
                    n = int(np.frombuffer(data, ct, 1, pos)[0])
                    pos += ct.itemsize
                    row.append(np.frombuffer(data, it, n, pos).copy())
                    pos += n * it.itemsize
                else:
                    d = np.dtype(bo + t)
                    row.append(np.frombuffer(data, d, 1, pos)[0])
                    pos += d.itemsize
            rows.append(tuple(row))
        dt = np.dtype([(p, object if isinstance(t, tuple) else bo + t) for p, t in props])
        arr = np.empty(count, dt)
        for i, r in enumerate(rows):
            arr[i] = r
        out[name] = arr
    return out


# --- PNG ------------------------------------------------------------------------------------------

_PNG_CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}


def read_png(path):
    """Decodes an 8-bit non-interlaced PNG (grey, grey+alpha, RGB, RGBA) to a uint8 array."""
    with open(path, "rb") as f:
        data = f.read()
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
    if depth != 8 or ctype not in _PNG_CHANNELS or interlace:
        raise ValueError("%s: only 8-bit non-interlaced grey/RGB(A) PNGs are supported "
                         "(depth %d, colour type %d, interlace %d)" % (path, depth, ctype, interlace))
    bpp = _PNG_CHANNELS[ctype]
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
    return img.reshape(h, w) if bpp == 1 else img.reshape(h, w, bpp)


# --- dataset --------------------------------------------------------------------------------------


class Instance:
    """One tree of a dataset: its manifest record and readers for its files."""

    def __init__(self, dataset_dir, record):
        self.root = dataset_dir
        self.record = record
        self.id = record.get("id")
        self.species = record.get("species")
        self.index = record.get("index")
        self.seed = record.get("seed")
        self.stats = record.get("stats", {})
        self.params = record.get("params", {})
        self.sweep = record.get("sweep", {})
        self.files = record.get("files", {})

    def __repr__(self):
        return "Instance(%r, species=%r)" % (self.id, self.species)

    def path(self, key):
        """Absolute path of the file named by the record's files[key] (KeyError if absent)."""
        return os.path.join(self.root, self.files[key])

    @property
    def dir(self):
        """The instance directory, trees/<species>/<id>."""
        return os.path.join(self.root, "trees", self.species, self.id)

    def skeleton(self):
        """Skeleton(nodes, positions (N,3), radius (N,), edges (E,2)) from skeleton.ply."""
        ply = read_ply(self.path("skeleton_ply"))
        v = ply["vertex"]
        e = ply.get("edge")
        edges = (np.stack([e["vertex1"], e["vertex2"]], axis=1).astype(np.int64)
                 if e is not None else np.zeros((0, 2), np.int64))
        return Skeleton(v, np.stack([v["x"], v["y"], v["z"]], axis=1), v["radius"], edges)

    def mesh(self, kind="mesh"):
        """Mesh(vertices, positions (N,3), faces) from <kind>.ply ("mesh" or "watertight")."""
        ply = read_ply(self.path(kind + "_ply"))
        v = ply["vertex"]
        f = ply["face"]["vertex_indices"]
        if f.dtype != object:
            f = f.astype(np.int64)
        return Mesh(v, np.stack([v["x"], v["y"], v["z"]], axis=1), f)

    def points(self):
        """The labelled point cloud (points.ply) as a structured array."""
        return read_ply(self.path("points_ply"))["vertex"]

    def cameras(self):
        """transforms.json: intrinsics and one frame (camera-to-world matrix, files) per view."""
        with open(self.path("transforms")) as f:
            return json.load(f)

    def _frame_images(self, key):
        cams = self.cameras()
        base = os.path.dirname(self.path("transforms"))
        return [read_png(os.path.join(base, fr[key])) for fr in cams.get("frames", []) if key in fr]

    def masks(self):
        """The view silhouettes, in frame order: (H, W) uint8, 0 background, 255 tree."""
        return self._frame_images("file_path")

    def labels(self):
        """The label views: (H, W) uint8, 0 background, 1 + branch order for the shoot's wood
        (at most 253), 254 root wood, 255 leaves."""
        return self._frame_images("label_file_path")


def _manifest_paths(root):
    whole = os.path.join(root, "manifest.jsonl")
    if os.path.exists(whole):
        return [whole]
    shards = []
    for name in os.listdir(root):
        m = re.fullmatch(r"manifest\.shard-(\d+)-of-(\d+)\.jsonl", name)
        if m:
            shards.append((int(m.group(1)), os.path.join(root, name)))
    return [p for _, p in sorted(shards)]


class Dataset:
    """A dataset directory: info (dataset.json), records (manifest), Instance iteration."""

    def __init__(self, root):
        self.root = os.path.abspath(root)
        info = os.path.join(self.root, "dataset.json")
        self.info = {}
        if os.path.exists(info):
            with open(info) as f:
                self.info = json.load(f)
        self.records = []
        self.skipped_lines = 0
        for p in _manifest_paths(self.root):
            with open(p) as f:
                for line in f:
                    if not line.endswith("\n"):
                        self.skipped_lines += 1  # torn last line of a killed build
                        continue
                    if not line.strip():
                        continue
                    try:
                        self.records.append(json.loads(line))
                    except ValueError:
                        self.skipped_lines += 1
        self._by_id = {r.get("id"): i for i, r in enumerate(self.records)}

    def __len__(self):
        return len(self.records)

    def __iter__(self):
        for r in self.records:
            yield Instance(self.root, r)

    def __getitem__(self, key):
        if isinstance(key, str):
            return Instance(self.root, self.records[self._by_id[key]])
        return Instance(self.root, self.records[key])

    @property
    def species(self):
        """Species names in first-seen manifest order."""
        seen = []
        for r in self.records:
            if r.get("species") not in seen:
                seen.append(r.get("species"))
        return seen

    def by_species(self, name):
        return [Instance(self.root, r) for r in self.records if r.get("species") == name]
