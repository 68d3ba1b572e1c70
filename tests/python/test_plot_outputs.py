#!/usr/bin/python3
"""A plot's scene.ply, per-tree meshes and instance-id images as numpy and OpenCV read them.

Reads the plot that the GoogleTest PlotOutputs.WritesPresetPlotForReaders wrote into DIR
(ctest runs it first as the fixture plot_outputs) and checks:

- scene.ply (numpy, from its header): the vertex element is float x y z nx ny nz, int tree_id,
  uchar part; the tree_id values are exactly {0} and the plot's ids from trees.csv; part values
  are within 0-5; terrain (part 0) and ground cover (5) have tree_id 0, stems/branches/leaves/
  roots (1-4) a tree's id; per tree, its wood vertices (parts 1, 2, 4) equal the vertex count
  of trees/<tree>/mesh.ply's wood (part 0 there) and its leaf vertices (part 3) the leaf
  vertices (part 1 there); the faces' indices are all in range;
- views/<view>_id.png read with cv2.IMREAD_UNCHANGED is a uint16 single-channel image equal to
  the renderer's ids (views/<view>_id.u16, written beside it by the test), non-zero exactly where
  the silhouette views/<view>.png is 255, with ids from the plot; the part label PNG is 1-4 on
  tree pixels, 0 / 5 / 255 elsewhere;
- the depth EXR (cv2.IMREAD_ANYDEPTH) is > 0 wherever the label is not background (terrain
  included), 0 on the background.

Usage: test_plot_outputs.py DIR   (a missing module is a failure, not a skip)
"""

import csv
import glob
import os
import sys

os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")
import cv2  # noqa: E402
import numpy as np  # noqa: E402

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)


TYPES = {"float": "<f4", "double": "<f8", "int": "<i4", "uint": "<u4", "uchar": "u1",
         "char": "i1", "short": "<i2", "ushort": "<u2"}


def read_ply(path):
    """(vertex structured array, faces (F, 3) int array) of a binary little-endian PLY with a
    scalar vertex element and a face element of 'list uchar uint' (sylva's mesh PLYs)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    nv = nf = 0
    props = []
    element = None
    for line in data[:end].decode("ascii").splitlines():
        w = line.split()
        if w[:1] == ["format"]:
            assert w[1] == "binary_little_endian", path
        if w[:1] == ["element"]:
            element = w[1]
            if element == "vertex":
                nv = int(w[2])
            elif element == "face":
                nf = int(w[2])
        if w[:1] == ["property"] and element == "vertex":
            props.append((w[2], TYPES[w[1]]))
    vdt = np.dtype(props)
    vertices = np.frombuffer(data, vdt, nv, end)
    fdt = np.dtype([("n", "u1"), ("i", "<u4", (3,))])
    faces = np.frombuffer(data, fdt, nf, end + nv * vdt.itemsize)
    check(np.all(faces["n"] == 3), f"{path}: every face a triangle")
    check(end + nv * vdt.itemsize + nf * fdt.itemsize == len(data), f"{path}: size matches header")
    return vertices, faces["i"]


def main(root):
    plots = glob.glob(os.path.join(root, "plots", "*", "*", "plot.json"))
    check(len(plots) == 1, f"one plot under {root}, found {len(plots)}")
    if not plots:
        return
    plot = os.path.dirname(plots[0])
    with open(os.path.join(plot, "trees.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    ids = {int(r["id"]) for r in rows}
    names = {int(r["id"]): r["name"] for r in rows}
    check(len(ids) >= 2, "at least two trees")

    v, faces = read_ply(os.path.join(plot, "scene.ply"))
    check(v.dtype.names == ("x", "y", "z", "nx", "ny", "nz", "tree_id", "part"),
          f"scene.ply vertex properties {v.dtype.names}")
    check(set(np.unique(v["tree_id"]).tolist()) == ids | {0},
          f"scene.ply tree_id values {sorted(np.unique(v['tree_id']).tolist())} == {{0}} ∪ {sorted(ids)}")
    check(set(np.unique(v["part"]).tolist()) <= {0, 1, 2, 3, 4, 5}, "parts within 0-5")
    ground = np.isin(v["part"], [0, 5])
    check(np.all(v["tree_id"][ground] == 0), "terrain and ground cover have tree_id 0")
    check(np.all(v["tree_id"][~ground] > 0), "tree parts have a tree id")
    check(np.count_nonzero(v["part"] == 0) > 0 and np.count_nonzero(v["part"] == 5) > 0,
          "terrain and ground cover present")
    check(faces.size > 0 and int(faces.max()) < len(v), "face indices in range")
    for tid in sorted(ids):
        tree = v[v["tree_id"] == tid]
        wood = np.count_nonzero(np.isin(tree["part"], [1, 2, 4]))
        leaves = np.count_nonzero(tree["part"] == 3)
        mv, _ = read_ply(os.path.join(plot, "trees", names[tid], "mesh.ply"))
        check(wood == np.count_nonzero(mv["part"] == 0),
              f"{names[tid]}: scene wood vertices {wood} == mesh.ply's")
        check(leaves == np.count_nonzero(mv["part"] == 1),
              f"{names[tid]}: scene leaf vertices {leaves} == mesh.ply's")
        check(np.count_nonzero(tree["part"] == 1) > 0, f"{names[tid]}: has stem vertices")

    for view in ("overview", "oblique", "top"):
        base = os.path.join(plot, "views", view)
        img = cv2.imread(base + "_id.png", cv2.IMREAD_UNCHANGED)
        check(img is not None and img.dtype == np.uint16 and img.ndim == 2,
              f"{view}_id.png reads as single-channel uint16")
        if img is None:
            continue
        h, w = img.shape
        raw = np.fromfile(base + "_id.u16", dtype="<u2").reshape(h, w)
        check(np.array_equal(img, raw), f"{view}_id.png equals the renderer's ids")
        seen = set(np.unique(img).tolist()) - {0}
        check(seen <= ids and len(seen) >= 2, f"{view}: ids {sorted(seen)} from the plot")
        sil = cv2.imread(base + ".png", cv2.IMREAD_UNCHANGED)
        check(np.array_equal(sil == 255, img != 0), f"{view}: ids non-zero exactly on the silhouette")
        lab = cv2.imread(base + "_label.png", cv2.IMREAD_UNCHANGED)
        check(np.all(np.isin(lab[img != 0], [1, 2, 3, 4])), f"{view}: tree pixels are wood or leaf")
        check(np.all(np.isin(lab[img == 0], [0, 5, 255])), f"{view}: other pixels ground or sky")
        depth = cv2.imread(base + "_depth.exr", cv2.IMREAD_ANYDEPTH)
        check(depth is not None and depth.dtype == np.float32, f"{view}_depth.exr reads as float32")
        if depth is not None:
            check(np.all((depth > 0) == (lab != 255)), f"{view}: depth > 0 exactly off the sky")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print("usage: test_plot_outputs.py DIR")
        sys.exit(2)
    main(sys.argv[1])
    if failures:
        print(f"{len(failures)} failure(s)")
        sys.exit(1)
    print("plot outputs: all checks passed")
