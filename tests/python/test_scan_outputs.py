#!/usr/bin/python3
"""Reads the scan files that the GoogleTest ScanOutputs.WritesFilesForReaders wrote into DIR with
numpy alone (no sylva code) and checks them against the closed-form scan they came from
(formulaScan in tests/pipeline/formats/scan_writers_test.cpp: 300 points, GPS start 123456.5):

  - formula.ply as ForestFormer3D's loader reads it (data/ForAINetV2/plyutils.py: the header's
    property lines become a numpy dtype, np.fromfile the records): float64 x, y, z in the survey
    frame, int32 semantic_seg and treeID;
  - formula.npy as TreeLearn's load_data reads it (np.load, an N x 4 array): x, y, z and the label
    (-1 unclassified, 0 non-tree, >= 1 tree id); and the same labels derived from formula.las the
    way load_data treats a LAS file (treeID where != 0, then 0 for classes 1 and 2, else -1);
  - formula.las and formula_rgb.las decoded with a numpy structured dtype at the LAS 1.4 offsets
    (a second reader beside tests/js/check_scan.mjs);
  - trajectory.csv and stations.json;
  - qsm.csv and qsm.txt (TreeQSM's text layout) of the hand-built tree: the known cylinders,
    TreeQSM's parent/extension invariants and the wood volume.

Usage: /usr/bin/python3 tests/python/test_scan_outputs.py DIR
"""
import json
import math
import sys
from pathlib import Path

import numpy as np

N = 300
GPS_START = 123456.5
SCALE = 0.001


def formula():
    i = np.arange(N)
    nr = 1 + (i // 4) % 15
    return {
        "x": -12.5 + 0.0731 * i,
        "y": -1.0 + 0.043 * i,
        "z": 7.25 - 0.0517 * i,
        "gps": 0.001 * i + 0.000001 * (i % 7),
        "intensity": (i * 40503) % 65536,
        "nr": nr,
        "rn": 1 + i % nr,
        "channel": i % 4,
        "source": i % 8,
        "dir": i % 2,
        "edge": (i % 11 == 0).astype(int),
        "angle": -45 + 0.3 * i,
        "elevation": (-40 + 0.37 * i).astype(np.float32).astype(np.float64),
        "purity": (0.2 + 0.1 * (i % 9)).astype(np.float32).astype(np.float64),
        "tree": i % 6,
        "node": i % 9 - 1,
        "object": (i * 13) % 1000,
        "species": (i * 37) % 1000,
        "part": i % 6,
        "order": i % 4,
        "cls": i % 7,
        "sem": i % 4,
    }


def survey(f):
    """Scene (+y up) to survey frame (z up): (x, y, z) -> (x, -z, y)."""
    return np.stack([f["x"], -f["z"], f["y"]], axis=1)


def treelearn_label(tree, cls):
    """TreeLearn's load_data on a FOR-instance LAS file (tree_learn/util/data_preparation.py)."""
    labels = np.ones(len(tree))
    tree_mask = tree != 0
    non_tree = np.isin(cls, [1, 2])
    labels[tree_mask] = tree[tree_mask]
    labels[non_tree] = 0
    labels[~tree_mask & ~non_tree] = -1
    return labels


def read_ply(path):
    """The header parsing of ForestFormer3D's plyutils.read_ply, on a binary PLY."""
    types = {b"double": "f8", b"float64": "f8", b"int": "i4", b"int32": "i4"}
    with open(path, "rb") as f:
        assert b"ply" in f.readline()
        fmt = f.readline().split()[1]
        assert fmt == b"binary_little_endian", fmt
        props, count, line = [], None, b""
        while b"end_header" not in line:
            line = f.readline()
            if b"element" in line:
                count = int(line.split()[2])
            elif b"property" in line:
                parts = line.split()
                props.append((parts[2].decode(), "<" + types[parts[1]]))
        return np.fromfile(f, dtype=props, count=count)


def read_las(path):
    b = Path(path).read_bytes()
    h = {
        "signature": b[0:4],
        "global_encoding": int(np.frombuffer(b, "<u2", 1, 6)[0]),
        "version": (b[24], b[25]),
        "header_size": int(np.frombuffer(b, "<u2", 1, 94)[0]),
        "point_offset": int(np.frombuffer(b, "<u4", 1, 96)[0]),
        "vlrs": int(np.frombuffer(b, "<u4", 1, 100)[0]),
        "format": b[104],
        "record_length": int(np.frombuffer(b, "<u2", 1, 105)[0]),
        "legacy_count": int(np.frombuffer(b, "<u4", 1, 107)[0]),
        "scale": np.frombuffer(b, "<f8", 3, 131),
        "offset": np.frombuffer(b, "<f8", 3, 155),
        "max": np.frombuffer(b, "<f8", 6, 179)[0::2],
        "min": np.frombuffer(b, "<f8", 6, 179)[1::2],
        "count": int(np.frombuffer(b, "<u8", 1, 247)[0]),
        "by_return": np.frombuffer(b, "<u8", 15, 255),
    }
    fields = [("X", "<i4"), ("Y", "<i4"), ("Z", "<i4"), ("intensity", "<u2"), ("returns", "u1"),
              ("flags", "u1"), ("classification", "u1"), ("user_data", "u1"),
              ("scan_angle", "<i2"), ("source", "<u2"), ("gps_time", "<f8")]
    if h["format"] == 7:
        fields += [("red", "<u2"), ("green", "<u2"), ("blue", "<u2")]
    fields += [("treeID", "<i4"), ("treeSP", "<u2"), ("semantic_seg", "u1"),
               ("hitObjectId", "<i4"), ("branch_order", "u1"), ("node_id", "<i4"),
               ("elevation", "<i2"), ("label_purity", "u1")]
    dtype = np.dtype(fields)
    assert dtype.itemsize == h["record_length"], (dtype.itemsize, h["record_length"])
    points = np.frombuffer(b, dtype, h["count"], h["point_offset"])
    return h, points


def main():
    out = Path(sys.argv[1])
    f = formula()
    xyz = survey(f)

    # ForestFormer3D / ForAINetV2 PLY.
    ply = read_ply(out / "formula.ply")
    assert ply.dtype.names == ("x", "y", "z", "semantic_seg", "treeID"), ply.dtype.names
    assert ply.dtype["x"] == np.float64 and ply.dtype["treeID"] == np.int32
    assert len(ply) == N
    assert np.allclose(np.stack([ply["x"], ply["y"], ply["z"]], 1), xyz, rtol=0, atol=1e-12)
    assert np.array_equal(ply["semantic_seg"], f["sem"])
    assert np.array_equal(ply["treeID"], f["tree"])

    # TreeLearn .npy, and TreeLearn's reading of the LAS file giving the same labels.
    npy = np.load(out / "formula.npy")
    assert npy.shape == (N, 4) and npy.dtype == np.float64, (npy.shape, npy.dtype)
    assert np.allclose(npy[:, :3], xyz, rtol=0, atol=1e-12)
    want = treelearn_label(f["tree"], f["cls"])
    assert np.array_equal(npy[:, 3], want)
    assert set(np.unique(npy[:, 3])) == {-1, 0, 1, 2, 3, 4, 5}, np.unique(npy[:, 3])

    # LAS, both formats.
    for name, fmt in (("formula.las", 6), ("formula_rgb.las", 7)):
        h, p = read_las(out / name)
        assert h["signature"] == b"LASF" and h["version"] == (1, 4) and h["header_size"] == 375
        assert h["global_encoding"] == 17 and h["format"] == fmt and h["vlrs"] == 2
        assert h["legacy_count"] == 0 and h["count"] == N
        assert np.array_equal(h["by_return"], np.bincount(f["rn"] - 1, minlength=15))
        assert np.all(h["scale"] == SCALE)
        assert np.array_equal(h["offset"], np.floor(xyz.min(axis=0)))
        coords = np.stack([p["X"], p["Y"], p["Z"]], 1) * h["scale"] + h["offset"]
        assert np.abs(coords - xyz).max() <= SCALE / 2 + 1e-9
        assert np.all(coords >= h["min"]) and np.all(coords <= h["max"])
        assert np.allclose(h["min"], xyz.min(axis=0), atol=SCALE / 2 + 1e-9)
        assert np.allclose(h["max"], xyz.max(axis=0), atol=SCALE / 2 + 1e-9)
        assert np.array_equal(p["intensity"], f["intensity"])
        assert np.array_equal(p["returns"] & 15, f["rn"])
        assert np.array_equal(p["returns"] >> 4, f["nr"])
        assert np.array_equal(p["flags"] & 15, np.zeros(N))
        assert np.array_equal((p["flags"] >> 4) & 3, f["channel"])
        assert np.array_equal((p["flags"] >> 6) & 1, f["dir"])
        assert np.array_equal(p["flags"] >> 7, f["edge"])
        assert np.array_equal(p["classification"], f["cls"])
        assert np.array_equal(p["source"], f["source"])
        assert np.array_equal(p["user_data"], f["part"])
        assert np.abs(p["scan_angle"] * 0.006 - f["angle"]).max() <= 0.003 + 1e-5
        assert np.allclose(p["gps_time"], GPS_START + f["gps"], rtol=0, atol=1e-9)
        for field, key in (("treeID", "tree"), ("treeSP", "species"), ("semantic_seg", "sem"),
                           ("hitObjectId", "object"), ("branch_order", "order"),
                           ("node_id", "node")):
            assert np.array_equal(p[field], f[key]), field
        # Scaled by 0.01, as their descriptors say.
        assert np.abs(p["elevation"] * 0.01 - f["elevation"]).max() <= 0.005 + 1e-6
        assert np.abs(p["label_purity"] * 0.01 - f["purity"]).max() <= 0.005 + 1e-6
        assert np.array_equal(treelearn_label(p["treeID"], p["classification"]), npy[:, 3])

    # The Python package's reader (sylva_dataset.read_las, Instance.scan) on the same files.
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))
    from sylva_dataset import read_las as package_read_las
    for name, fmt in (("formula.las", 6), ("formula_rgb.las", 7)):
        las = package_read_las(out / name)
        assert las.header["point_format"] == fmt and las.header["point_count"] == N
        assert np.abs(las.positions - xyz).max() <= SCALE / 2 + 1e-9
        assert [d["name"] for d in las.extra] == ["treeID", "treeSP", "semantic_seg",
                                                  "hitObjectId", "branch_order", "node_id",
                                                  "elevation", "label_purity"]
        for field, key in (("treeID", "tree"), ("treeSP", "species"), ("semantic_seg", "sem"),
                           ("hitObjectId", "object"), ("branch_order", "order"),
                           ("node_id", "node"), ("classification", "cls"),
                           ("return_number", "rn"), ("number_of_returns", "nr"),
                           ("scanner_channel", "channel"), ("intensity", "intensity"),
                           ("point_source_id", "source")):
            assert np.array_equal(las[field], f[key]), field
        assert np.allclose(las["gps_time"], GPS_START + f["gps"], rtol=0, atol=1e-9)
        assert np.abs(las["elevation"] - f["elevation"]).max() <= 0.005 + 1e-6
        assert np.abs(las["label_purity"] - f["purity"]).max() <= 0.005 + 1e-6
        assert ("red" in las.fields) == (fmt == 7)

    # Trajectory and stations (3 poses: scene (1.5k, 60 + k, −20 + 2.25k), heading 90).
    traj = np.genfromtxt(out / "trajectory.csv", delimiter=",", names=True)
    assert traj.dtype.names == ("gps_time", "x", "y", "z", "heading_deg", "channel")
    k = np.arange(3)
    assert np.allclose(traj["gps_time"], GPS_START + 0.1 * k, atol=1e-6)
    assert np.allclose(traj["x"], 1.5 * k) and np.allclose(traj["y"], 20 - 2.25 * k)
    assert np.allclose(traj["z"], 60 + k) and np.all(traj["heading_deg"] == 90)
    assert np.array_equal(traj["channel"], k)
    stations = json.loads((out / "stations.json").read_text())
    assert [s["station"] for s in stations] == [0, 1, 2]
    assert stations[2]["y"] == 15.5 and stations[2]["z"] == 62

    # QSM of the hand-built tree: nodes (scene frame) and radii as the test writes them.
    nodes = {0: ((0, 0, 0), 0.2), 1: ((0, 1, 0), 0.16), 2: ((0, 2, 0), 0.12), 3: ((0, 3, 0), 0.08),
             4: ((0, 4, 0), 0.04), 5: ((1, 1.5, 0), 0.05), 6: ((2, 2, 0), 0.03),
             7: ((1, 1.5, -1), 0.02)}
    parent = {1: 0, 2: 1, 3: 2, 4: 3, 5: 1, 6: 5, 7: 5}
    qsm = np.genfromtxt(out / "qsm.csv", delimiter=",", names=True)
    assert qsm.dtype.names == ("radius", "length", "start_x", "start_y", "start_z", "axis_x",
                               "axis_y", "axis_z", "parent", "extension", "branch", "BranchOrder",
                               "PositionInBranch", "added", "UnmodRadius", "node_id")
    assert len(qsm) == 7
    assert list(qsm["node_id"]) == [1, 2, 3, 4, 5, 6, 7]
    assert list(qsm["parent"]) == [0, 1, 2, 3, 1, 5, 5]
    assert list(qsm["extension"]) == [2, 3, 4, 0, 6, 0, 0]
    assert list(qsm["branch"]) == [1, 1, 1, 1, 2, 2, 3]
    assert list(qsm["BranchOrder"]) == [0, 0, 0, 0, 1, 1, 2]
    assert list(qsm["PositionInBranch"]) == [1, 2, 3, 4, 1, 2, 1]
    start = np.stack([qsm["start_x"], qsm["start_y"], qsm["start_z"]], 1)
    axis = np.stack([qsm["axis_x"], qsm["axis_y"], qsm["axis_z"]], 1)
    assert np.allclose(np.linalg.norm(axis, axis=1), 1, atol=2e-6)
    volume = 0.0
    for row, node in enumerate(qsm["node_id"].astype(int)):
        (p0, r_parent), (p1, r1) = nodes[parent[node]], nodes[node]
        z_up = lambda q: np.array([q[0], -q[2], q[1]], dtype=float)
        assert np.allclose(start[row], z_up(p0), atol=1e-6)
        assert np.allclose(start[row] + axis[row] * qsm["length"][row], z_up(p1), atol=1e-5)
        r0 = r1 if qsm["PositionInBranch"][row] == 1 and qsm["parent"][row] > 0 else r_parent
        volume += math.pi / 3 * qsm["length"][row] * (r0 * r0 + r0 * r1 + r1 * r1)
        ext = int(qsm["extension"][row])
        if ext:  # an extension starts where its parent ends and names it as parent
            assert qsm["parent"][ext - 1] == row + 1
            assert np.allclose(start[ext - 1], start[row] + axis[row] * qsm["length"][row],
                               atol=1e-5)
    assert abs(np.sum(math.pi * qsm["radius"] ** 2 * qsm["length"]) - volume) < 1e-5 * volume
    # TreeQSM's own text layout: 13 header names over 17 columns, mad and SurfCov NaN.
    lines = (out / "qsm.txt").read_text().splitlines()
    assert lines[0].split("\t") == ["radius (m)", "length (m)", "start_point", "axis_direction",
                                    "parent", "extension", "branch", "branch_order",
                                    "position_in_branch", "mad", "SurfCov", "added",
                                    "UnmodRadius (m)"]
    txt = np.loadtxt(out / "qsm.txt", skiprows=1, delimiter="\t")
    assert txt.shape == (7, 17), txt.shape
    assert np.all(np.isnan(txt[:, 13])) and np.all(np.isnan(txt[:, 14]))
    csv_cols = np.stack([qsm[n] for n in qsm.dtype.names[:13]], 1)
    assert np.allclose(txt[:, :13], csv_cols, atol=5e-5 + 1e-9)
    assert np.allclose(txt[:, 16], qsm["radius"], atol=5e-5 + 1e-9)

    print(f"test_scan_outputs: {out}: PLY, TreeLearn .npy, LAS 6 and 7, trajectory, stations, "
          "QSM CSV and TreeQSM text read by numpy as the models' loaders do")


if __name__ == "__main__":
    main()
