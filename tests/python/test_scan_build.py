#!/usr/bin/python3
"""Reads the scans `sylva build` wrote (tests/cli/test-scan-readers: tests/data/scan/tls_trees.toml
and uls_plot.toml) with numpy, as the models' loaders read them, and with the sylva_dataset
package, and checks for every manifest record with a scan (exit 1 on a failure):

  - scan.las decoded with a numpy structured dtype at the LAS 1.4 offsets (test_scan_outputs.py's
    reader, not sylva_dataset's) equals, field by field, what the npm package copc read
    (OUT/copc/<id>.f64, written by tests/js/check_scan_build.mjs);
  - scan_forestformer.ply, read as ForestFormer3D's plyutils reads it, has the LAS points in the
    same order: x, y, z within half the LAS scale, semantic_seg and treeID equal;
  - scan_treelearn.npy (np.load, N x 4) likewise: x, y, z within half the scale, and the label
    TreeLearn's load_data derives from the LAS's treeID and classification (docs/scanning.md);
  - a single tree's TLS scan_stations.json and scan_trajectory.csv at the spec's stations;
  - every tree's qsm.csv (a plot's trees/tree-NNNN/qsm.csv) against its skeleton.ply (read with
    numpy): one row per shoot segment of non-zero length, node_id the segment's end node, start
    and start + axis * length the segment's nodes in the survey frame, the parent row ending at
    the nearest ancestor that has a row; and every wood point of the LAS names a node of its tree
    whose branch order is the point's branch_order;
  - sylva_dataset.Dataset(out) -> inst.scan() returns the same arrays as the numpy/copc readings.

Usage: /usr/bin/python3 tests/python/test_scan_build.py OUT DATASET_DIR...
"""
import csv
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent.parent / "python"))
from test_scan_outputs import read_las, read_ply, treelearn_label  # noqa: E402
import sylva_dataset  # noqa: E402

COPC_COLUMNS = ["X", "Y", "Z", "classification", "treeID", "treeSP", "semantic_seg",
                "return_number", "number_of_returns", "intensity", "gps_time", "branch_order",
                "node_id"]

failures = []


def check(what, ok, detail=""):
    if not ok:
        failures.append("%s%s" % (what, ": " + str(detail) if detail else ""))


def skeleton(path):
    """skeleton.ply with numpy: a binary little-endian PLY, vertex (x y z radius order part) and
    edge (vertex1 vertex2) elements."""
    types = {"float": "<f4", "double": "<f8", "int": "<i4", "uchar": "u1", "uint": "<u4"}
    with open(path, "rb") as f:
        assert f.readline().strip() == b"ply"
        elements, line = [], b""
        while line.strip() != b"end_header":
            line = f.readline()
            words = line.split()
            if words[:1] == [b"format"]:
                assert words[1] == b"binary_little_endian", words
            elif words[:1] == [b"element"]:
                elements.append((words[1].decode(), int(words[2]), []))
            elif words[:1] == [b"property"]:
                elements[-1][2].append((words[2].decode(), types[words[1].decode()]))
        data = {name: np.fromfile(f, dtype=props, count=n) for name, n, props in elements}
    v, e = data["vertex"], data["edge"]
    parents = np.full(len(v), -1)
    parents[e["vertex2"]] = e["vertex1"]
    # The survey frame of the scan files (z up): scene (x, y, z) -> (x, -z, y).
    pos = np.stack([v["x"], -v["z"], v["y"]], axis=1).astype(np.float64)
    return pos, parents, v["order"].astype(np.int64), v["part"].astype(np.int64)


def check_qsm(what, qsm_path, skel_path):
    pos, parents, order, part = skeleton(skel_path)
    with open(qsm_path) as f:
        rows = list(csv.DictReader(f))
    col = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]} if rows else {}
    # The shoot's segments (parent -> node) of non-zero length, as docs/scanning.md defines them.
    seg = [n for n in range(len(pos)) if parents[n] >= 0 and part[n] == 0
           and np.linalg.norm(pos[n] - pos[parents[n]]) > 1e-9]
    nodes = col["node_id"].astype(np.int64) if rows else np.zeros(0, np.int64)
    check("%s: one QSM row per shoot segment" % what, len(rows) == len(seg), (len(rows), len(seg)))
    check("%s: QSM node_id values are the shoot segments' end nodes" % what,
          sorted(nodes.tolist()) == seg)
    if not rows or len(rows) != len(seg) or sorted(nodes.tolist()) != seg:
        return nodes
    start = np.stack([col["start_x"], col["start_y"], col["start_z"]], axis=1)
    axis = np.stack([col["axis_x"], col["axis_y"], col["axis_z"]], axis=1)
    end = start + axis * col["length"][:, None]
    err_start = np.abs(start - pos[parents[nodes]]).max()
    err_end = np.abs(end - pos[nodes]).max()
    check("%s: QSM start = the segment's parent node" % what, err_start < 2e-5, err_start)
    check("%s: QSM start + axis * length = the segment's node" % what, err_end < 1e-4, err_end)
    row_of = {int(n): k for k, n in enumerate(nodes)}
    bad_parent = 0
    for k, n in enumerate(nodes):
        a = parents[n]
        while a >= 0 and int(a) not in row_of:
            a = parents[a]
        want = row_of[int(a)] + 1 if a >= 0 else 0
        bad_parent += int(col["parent"][k]) != want
    check("%s: QSM parent = the row of the nearest ancestor with a row" % what, bad_parent == 0,
          "%d rows" % bad_parent)
    return nodes


def check_record(out, ds_dir, spec, inst):
    r = inst.record
    rid = r["id"]
    h, las = read_las(inst.path("scan_las"))
    n = h["count"]
    check("%s: LAS point count = manifest scan.points" % rid, n == r["scan"]["points"],
          (n, r["scan"]["points"]))
    xyz = np.stack([las["X"], las["Y"], las["Z"]], axis=1) * h["scale"] + h["offset"]
    half = h["scale"] / 2 + 1e-9
    numpy_fields = {
        "classification": las["classification"], "treeID": las["treeID"],
        "treeSP": las["treeSP"], "semantic_seg": las["semantic_seg"],
        "return_number": las["returns"] & 15, "number_of_returns": las["returns"] >> 4,
        "intensity": las["intensity"], "gps_time": las["gps_time"],
        "branch_order": las["branch_order"], "node_id": las["node_id"],
    }

    # copc's reading (tests/js/check_scan_build.mjs) against numpy's.
    copc_path = Path(out) / "copc" / ("%s.f64" % rid)
    check("%s: copc's reading %s exists (check_scan_build.mjs ran first)" % (rid, copc_path),
          copc_path.exists())
    copc = (np.fromfile(copc_path, "<f8").reshape(-1, len(COPC_COLUMNS)) if copc_path.exists()
            else np.zeros((0, len(COPC_COLUMNS))))
    check("%s: copc and numpy read the same number of points" % rid, len(copc) == n)
    if len(copc) == n:
        check("%s: copc's x, y, z = numpy's" % rid, np.abs(copc[:, :3] - xyz).max(initial=0) < 1e-9)
        for k, name in enumerate(COPC_COLUMNS[3:], 3):
            check("%s: copc's %s = numpy's" % (rid, name),
                  np.array_equal(copc[:, k], numpy_fields[name].astype(np.float64)))

    # ForestFormer3D's PLY: the same points in the same order.
    ply = read_ply(inst.path("scan_forestformer_ply"))
    check("%s: PLY point count" % rid, len(ply) == n, (len(ply), n))
    if len(ply) == n:
        pxyz = np.stack([ply["x"], ply["y"], ply["z"]], axis=1)
        check("%s: PLY x, y, z = LAS within half the scale" % rid,
              (np.abs(pxyz - xyz) <= half).all(), np.abs(pxyz - xyz).max(initial=0))
        check("%s: PLY semantic_seg = LAS" % rid, np.array_equal(ply["semantic_seg"], las["semantic_seg"]))
        check("%s: PLY treeID = LAS" % rid, np.array_equal(ply["treeID"], las["treeID"]))

    # TreeLearn's .npy: x, y, z and the label load_data derives from the LAS.
    npy = np.load(inst.path("scan_treelearn_npy"))
    check("%s: TreeLearn array shape" % rid, npy.shape == (n, 4) and npy.dtype == np.float64,
          (npy.shape, npy.dtype))
    if npy.shape == (n, 4):
        check("%s: TreeLearn x, y, z = LAS within half the scale" % rid,
              (np.abs(npy[:, :3] - xyz) <= half).all(), np.abs(npy[:, :3] - xyz).max(initial=0))
        want = treelearn_label(las["treeID"].astype(np.int64), las["classification"])
        bad = np.flatnonzero(npy[:, 3] != want)
        check("%s: TreeLearn label = load_data's rule on the LAS" % rid, len(bad) == 0,
              "%d points, first %s" % (len(bad), bad[:1]))

    # TLS stations and trajectory against the spec's stations (a single tree stands on flat
    # ground at height 0): survey (x, -z, height), one trajectory row per station.
    if r.get("kind") != "plot" and spec["scan"].get("platform", "tls") == "tls":
        with open(inst.path("scan_stations")) as f:
            stations = json.load(f)
        want = [(s["x"], -s["z"], s.get("height", 1.5)) for s in spec["scan"]["stations"]]
        got = [(s["x"], s["y"], s["z"]) for s in stations]
        check("%s: scan_stations.json = the spec's stations" % rid,
              len(got) == len(want) and np.allclose(got, want, atol=1e-9), (got, want))
        with open(inst.path("scan_trajectory")) as f:
            traj = list(csv.DictReader(f))
        check("%s: scan_trajectory.csv has one row per station at it" % rid,
              len(traj) == len(want) and np.allclose(
                  [(float(t["x"]), float(t["y"]), float(t["z"])) for t in traj], want, atol=1e-4))

    # QSM tables against the skeletons, and the wood points' node_id and branch_order.
    if r.get("kind") == "plot":
        tree_dirs = sorted(Path(ds_dir, r["files"]["trees"]).glob("tree-*"))
        trees = {int(d.name.split("-")[1]): (d / "qsm.csv", d / "skeleton.ply") for d in tree_dirs}
    else:
        trees = {1: (Path(inst.path("qsm_csv")), Path(inst.path("skeleton_ply")))}
    check("%s: a QSM per tree of scan.trees" % rid,
          sorted(trees) == sorted(t["tree"] for t in r["scan"]["trees"]))
    wood = las["semantic_seg"] == 2
    for tree, (qsm_path, skel_path) in trees.items():
        check_qsm("%s tree %d" % (rid, tree), qsm_path, skel_path)
        _, _, order, _ = skeleton(skel_path)
        mine = wood & (las["treeID"] == tree)
        node = las["node_id"][mine].astype(np.int64)
        inside = (node >= 0) & (node < len(order))
        check("%s tree %d: wood points' node_id are nodes of its skeleton" % (rid, tree),
              inside.all(), "%d of %d" % ((~inside).sum(), len(node)))
        if inside.all():
            bad = (order[node] != las["branch_order"][mine]).sum()
            check("%s tree %d: wood points' branch_order = their node's order" % (rid, tree),
                  bad == 0, "%d of %d" % (bad, len(node)))

    # sylva_dataset's Instance.scan() returns the same arrays.
    s = inst.scan()
    check("%s: inst.scan().positions = numpy's x, y, z" % rid,
          s.positions.shape == (n, 3) and np.abs(s.positions - xyz).max(initial=0) < 1e-9)
    for attr, name in [("classification", "classification"), ("tree_id", "treeID"),
                       ("species", "treeSP"), ("semantic", "semantic_seg"),
                       ("return_number", "return_number"),
                       ("number_of_returns", "number_of_returns"), ("intensity", "intensity"),
                       ("gps_time", "gps_time"), ("branch_order", "branch_order"),
                       ("node_id", "node_id")]:
        check("%s: inst.scan().%s = numpy's %s" % (rid, attr, name),
              np.array_equal(getattr(s, attr), numpy_fields[name]))
    return n


def main():
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    out, dirs = sys.argv[1], sys.argv[2:]
    summary = []
    for d in dirs:
        ds = sylva_dataset.Dataset(d)
        scanned = [inst for inst in ds if "scan" in inst.record]
        check("%s: every record has a scan" % d, scanned and len(scanned) == len(ds))
        for inst in scanned:
            summary.append("%s %d points" % (inst.id, check_record(out, d, ds.info["spec"], inst)))
    if failures:
        for f in failures[:40]:
            print("test_scan_build: %s" % f, file=sys.stderr)
        return 1
    print("test_scan_build: %s: copc = numpy = sylva_dataset; PLY, .npy, QSM agree"
          % "; ".join(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
