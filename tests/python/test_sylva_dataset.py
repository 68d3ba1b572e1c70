#!/usr/bin/python3
"""Test of python/sylva_dataset.py: builds tests/data/tiny_dataset.toml with the given sylva
executable and checks that the loader reads back exactly what was written (counts against the
manifest's stats, mask coverage against silhouette_coverage, cameras against the views), plus
the PNG decoder on every row filter and the PLY reader's general (mixed list length) path.

Usage: test_sylva_dataset.py SYLVA_EXE [SOURCE_DIR]
Exit 77 (ctest SKIP) when numpy is missing.
"""

import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

try:
    import numpy as np
except ImportError:
    print("numpy missing (apt-get install -y python3-numpy): skipped")
    sys.exit(77)

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "python"))
import sylva_dataset as sd  # noqa: E402

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)


def png_bytes(rows, channels, filters):
    """Encodes uint8 rows (H, W*channels) with the given per-row filter types."""
    h, stride = rows.shape
    bpp = channels
    out = bytearray()
    prev = np.zeros(stride, np.int64)
    for y in range(h):
        cur = rows[y].astype(np.int64)
        ft = filters[y % len(filters)]
        enc = np.zeros(stride, np.int64)
        for i in range(stride):
            a = cur[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if ft == 0:
                pred = 0
            elif ft == 1:
                pred = a
            elif ft == 2:
                pred = b
            elif ft == 3:
                pred = (a + b) // 2
            else:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            enc[i] = (cur[i] - pred) % 256
        out.append(ft)
        out += bytes(enc.astype(np.uint8))
        prev = cur
    ctype = {1: 0, 2: 4, 3: 2, 4: 6}[channels]

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", stride // channels, h, 8, ctype, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(bytes(out))) + chunk(b"IEND", b""))


def test_png_filters(tmp):
    rng = np.random.RandomState(3)
    for channels in (1, 2, 3, 4):
        img = rng.randint(0, 256, size=(7, 5 * channels)).astype(np.uint8)
        p = os.path.join(tmp, "f%d.png" % channels)
        with open(p, "wb") as f:
            f.write(png_bytes(img, channels, [0, 1, 2, 3, 4]))
        got = sd.read_png(p)
        want = img if channels == 1 else img.reshape(7, 5, channels)
        check(got.shape == want.shape and (got == want).all(), "PNG filters 0-4, %d channel(s)" % channels)


def test_ply_mixed_lists(tmp):
    p = os.path.join(tmp, "mixed.ply")
    header = ("ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
              "element face 2\nproperty list uchar int vertex_indices\nproperty uchar tag\nend_header\n")
    body = struct.pack("<ff", 1.5, -2.0) + struct.pack("<B3iB", 3, 0, 1, 1, 7) + struct.pack("<B4iB", 4, 1, 0, 1, 0, 9)
    with open(p, "wb") as f:
        f.write(header.encode() + body)
    ply = sd.read_ply(p)
    check(list(ply["vertex"]["x"]) == [1.5, -2.0], "PLY vertex x")
    faces = ply["face"]
    check(list(faces[0]["vertex_indices"]) == [0, 1, 1] and list(faces[1]["vertex_indices"]) == [1, 0, 1, 0]
          and list(faces["tag"]) == [7, 9], "PLY mixed list lengths")


def test_dataset(exe, src, tmp):
    out = os.path.join(tmp, "ds")
    subprocess.run([exe, "build", os.path.join(src, "tests/data/tiny_dataset.toml"), "--out", out, "--threads", "2"],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    ds = sd.Dataset(out)
    check(len(ds) == ds.info["counts"]["instances_in_dataset"] == 24, "instance count %d" % len(ds))
    check(ds.species == ["tiny", "tiny-var"], "species %r" % ds.species)
    check([i.species for i in ds] == ["tiny"] * 12 + ["tiny-var"] * 12, "instance order")
    check(len({i.id for i in ds}) == 24, "unique ids")
    check(len(ds.by_species("tiny")) == 12, "by_species")
    first = ds[0]
    check(ds[first.id].id == first.id, "lookup by id")
    views = ds.info["spec"]["views"]
    w, h = views["resolution"]
    for inst in ds:
        st = inst.stats
        sk = inst.skeleton()
        check(len(sk.nodes) == st["nodes"], "%s skeleton nodes %d vs %d" % (inst.id, len(sk.nodes), st["nodes"]))
        check(len(sk.edges) == st["segments"], "%s skeleton edges" % inst.id)
        check(sk.edges.min() >= 0 and sk.edges.max() < len(sk.nodes), "%s edge indices" % inst.id)
        m = inst.mesh()
        check(len(m.vertices) == st["mesh_vertices"], "%s mesh vertices" % inst.id)
        check(m.faces.shape == (st["mesh_triangles"], 3), "%s mesh faces %r" % (inst.id, m.faces.shape))
        check(m.faces.max() < len(m.vertices), "%s face indices" % inst.id)
        wt = inst.mesh("watertight")
        check(len(wt.vertices) == st["watertight_vertices"] and len(wt.faces) == st["watertight_triangles"],
              "%s watertight counts" % inst.id)
        cams = inst.cameras()
        check(len(cams["frames"]) == views["count"], "%s camera count" % inst.id)
        masks = inst.masks()
        check(len(masks) == views["count"] == len(st["silhouette_coverage"]), "%s mask count" % inst.id)
        for k, mask in enumerate(masks):
            check(mask.shape == (h, w), "%s mask %d shape %r" % (inst.id, k, mask.shape))
            check(set(np.unique(mask)) <= {0, 255}, "%s mask %d values" % (inst.id, k))
            cov = float((mask == 255).sum()) / (w * h)
            check(abs(cov - st["silhouette_coverage"][k]) < 1e-12,
                  "%s mask %d coverage %g vs %g" % (inst.id, k, cov, st["silhouette_coverage"][k]))
        labels = inst.labels()
        check(len(labels) == len(masks) and all(((l > 0) == (s > 0)).all() for l, s in zip(labels, masks)),
              "%s labels cover exactly the silhouette" % inst.id)


def main():
    if len(sys.argv) < 2:
        print(__doc__)
        return 2
    exe = os.path.abspath(sys.argv[1])
    src = sys.argv[2] if len(sys.argv) > 2 else os.path.dirname(HERE)
    tmp = tempfile.mkdtemp(prefix="sylva_pytest_")
    try:
        test_png_filters(tmp)
        test_ply_mixed_lists(tmp)
        test_dataset(exe, src, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if failures:
        print("%d failure(s)" % len(failures))
        return 1
    print("sylva_dataset: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
