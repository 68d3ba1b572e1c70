#!/usr/bin/env python3
"""Sim-to-real benchmark of wood/leaf point classification on TLS tree scans.

A random forest on per-point eigenvalue features is trained on sylva's simulated TLS scans only
and tested on real, hand-labelled TLS trees, next to the same classifier trained on real trees
(leave-one-tree-out, or spatial blocks when there is one real tree). Both sides are thinned to a
common voxel spacing first, so point density does not decide; the features are computed the same
way for both. Also printed: KS distances between the sim and real distributions of each feature,
the point density by relative height, and return-count shares.

    /usr/bin/python3 bench/sim2real.py                          # bench/sim2real.toml, real trees
                                                                # of bench/data/real/trees.toml
    /usr/bin/python3 bench/sim2real.py --quick                  # a ≤ 3 min smoke run
    /usr/bin/python3 bench/sim2real.py --real-manifest my.toml  # other real trees (format below)
    /usr/bin/python3 bench/sim2real.py --real tree.las --real-label classification \
        --real-wood 0 --real-leaf 1

Real trees are described by a TOML manifest (paths relative to it):

    [[tree]]
    name = "FagSyl_BR01_01"           # optional, default: the file name
    path = "FagSyl_BR01_01.las"       # .las (1.0–1.4, formats 0–10), .ply, .txt/.xyz/.csv/.asc/.pts, .npy, .npz
    label = "classification"          # field (LAS/PLY/NPZ) or 0-based column (text, .npy); default:
                                      # the first of semantic_seg, label, labels, class, classification,
                                      # scalar_label, wood, truth (LAS/PLY/NPZ), the last column (text, .npy)
    wood = [0]                        # label values that are wood (stem, branches)
    leaf = [1]                        # label values that are leaf; other values are dropped
    species = "european-beech"        # the library preset it stands for (only recorded)
    scanner = "RIEGL VZ-400"          # recorded
    source = "doi:..."                # recorded
    licence = "CC-BY-4.0"             # recorded
    # or, for a tree split into two unlabelled files:
    # wood_path = "tree_wood.txt"
    # leaf_path = "tree_leaf.txt"
    labels_are = "manual"             # "manual" (default) or e.g. "algorithm:GBS": recorded and
                                      # printed, so pseudo-labels are never mistaken for truth

Method. Ground is dropped (sylva: semantic_seg 1); each tree is thinned to one point per
voxel of --voxel (auto: 1.5 cm, or the real trees' median point spacing when coarser), and a
seeded sample of query points gets, per radius r (0.1/0.2/0.4/0.8 m), the eigenvalue features
of its neighbours within r (at most 96) among the tree's points thinned again to r/3 — the same
geometry, whatever the scanner's density — plus its height above the lowest point over the
tree height. Small-scale features are those of radii ≤ --small-max (0.25 m), large-scale the
others. The forest (scikit-learn, 60 trees, balanced class weights) trains on sim only
(sim → real), on the other real trees (real → real, leave-one-tree-out; with one real tree,
folds of 3 m cubes of it, training points 0.2 m inside their cubes), and, as a reference, on
the other sim species (sim → sim, leave-one-species-out). Scores are per point of the query
samples: balanced accuracy, wood recall and precision, wood and leaf IoU and their mean (mIoU),
and wood recall above --crown-frac (1/3) of the tree height.

Writes OUT/results.json and OUT/results.md (OUT: --out, default build/sim2real or
build/sim2real-quick); OUT/sim/ is the sylva build (reused when rerun), OUT/features/ caches
each tree's features by a hash of their inputs.

Needs numpy, scipy and scikit-learn (Debian: python3-numpy python3-scipy python3-sklearn).
Deterministic: every sample and the forests are seeded (--seed).
"""

import argparse
import hashlib
import json
import math
import os
import struct
import subprocess
import sys
import time
import tomllib

import numpy as np
from scipy.spatial import cKDTree
from scipy.stats import ks_2samp

sys.dont_write_bytecode = True  # no __pycache__ in python/ or bench/
HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(REPO, "python"))
from sylva_dataset.las import read_las  # noqa: E402  (sylva's own LAS 1.4 reader)

FEATURES = ["linearity", "planarity", "sphericity", "omnivariance", "anisotropy",
            "eigenentropy", "curvature_change", "verticality"]
LABEL_FIELDS = ["semantic_seg", "label", "labels", "class", "classification", "scalar_label",
                "wood", "truth"]
WOOD, LEAF = 1, 0


def log(msg):
    print(msg, flush=True)


# --------------------------------------------------------------------------------------------
# Readers for the real trees (own code; formats from the LAS 1.0–1.4 and PLY specifications)
# --------------------------------------------------------------------------------------------

_LAS_BASE = {0: 20, 1: 28, 2: 26, 3: 34, 4: 57, 5: 63, 6: 30, 7: 36, 8: 38, 9: 59, 10: 67}
_EXTRA_TYPES = {1: "u1", 2: "i1", 3: "<u2", 4: "<i2", 5: "<u4", 6: "<i4", 7: "<u8", 8: "<i8",
                9: "<f4", 10: "<f8"}


def read_any_las(path):
    """LAS 1.0–1.4, point formats 0–10 (uncompressed), with Extra Bytes: (xyz, fields dict)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"LASF":
        raise ValueError("%s: not a LAS file (LAZ must be decompressed first)" % path)
    header_size = struct.unpack_from("<H", data, 94)[0]
    offset, nvlr = struct.unpack_from("<II", data, 96)
    fmt_byte = data[104]
    if fmt_byte & 0xC0:
        raise ValueError("%s: compressed (LAZ) points; decompress to LAS first" % path)
    fmt = fmt_byte & 0x3F
    rec_len = struct.unpack_from("<H", data, 105)[0]
    n = struct.unpack_from("<I", data, 107)[0]
    if (data[24], data[25]) >= (1, 4) and header_size >= 255:
        n = struct.unpack_from("<Q", data, 247)[0] or n
    scale = np.array(struct.unpack_from("<3d", data, 131))
    off = np.array(struct.unpack_from("<3d", data, 155))
    extra, pos = [], header_size
    for _ in range(nvlr):
        user = data[pos + 2:pos + 18].split(b"\0")[0]
        rid, length = struct.unpack_from("<HH", data, pos + 18)
        if user == b"LASF_Spec" and rid == 4:
            p = data[pos + 54:pos + 54 + length]
            for k in range(len(p) // 192):
                d = p[192 * k:192 * (k + 1)]
                name = d[4:36].split(b"\0")[0].decode("ascii", "replace")
                opts = d[3]
                extra.append((name, d[2], opts,
                              struct.unpack_from("<d", d, 112)[0] if opts & 8 else None,
                              struct.unpack_from("<d", d, 136)[0] if opts & 16 else None))
        pos += 54 + length
    if fmt not in _LAS_BASE:
        raise ValueError("%s: point format %d" % (path, fmt))
    # bytes 14–17 of every format: returns, flags (6–10) or classification (0–5),
    # classification (6–10) or scan angle rank (0–5), user data
    names = ["X", "Y", "Z", "intensity", "b14", "b15", "b16", "user_data"]
    formats = ["<i4", "<i4", "<i4", "<u2", "u1", "u1", "u1", "u1"]
    offsets = [0, 4, 8, 12, 14, 15, 16, 17]
    pos = _LAS_BASE[fmt]
    for k, (name, dtype, opts, sc, of) in enumerate(extra):
        if dtype == 0:
            pos += opts
            continue
        if dtype not in _EXTRA_TYPES:
            raise ValueError("%s: extra bytes %r of deprecated type %d" % (path, name, dtype))
        names.append("extra:" + name)
        formats.append(_EXTRA_TYPES[dtype])
        offsets.append(pos)
        pos += np.dtype(_EXTRA_TYPES[dtype]).itemsize
    dt = np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": rec_len})
    rec = np.frombuffer(data, dtype=dt, count=n, offset=offset)
    xyz = np.stack([rec["X"], rec["Y"], rec["Z"]], 1).astype(np.float64) * scale + off
    fields = {"intensity": rec["intensity"].astype(np.int64),
              "user_data": rec["user_data"].astype(np.int64)}
    if fmt >= 6:
        fields["return_number"] = (rec["b14"] & 0x0F).astype(np.int64)
        fields["number_of_returns"] = (rec["b14"] >> 4).astype(np.int64)
        fields["classification"] = rec["b16"].astype(np.int64)
    else:
        fields["return_number"] = (rec["b14"] & 0x07).astype(np.int64)
        fields["number_of_returns"] = ((rec["b14"] >> 3) & 0x07).astype(np.int64)
        fields["classification"] = (rec["b15"] & 0x1F).astype(np.int64)
    for name, dtype, opts, sc, of in extra:
        if dtype == 0:
            continue
        v = rec["extra:" + name]
        v = v.astype(np.float64) * (sc or 1.0) + (of or 0.0) if (sc or of) else v.astype(np.float64)
        fields[name] = v
    return xyz, fields


_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2",
              "int16": "i2", "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4",
              "uint": "u4", "uint32": "u4", "float": "f4", "float32": "f4", "double": "f8",
              "float64": "f8"}


def read_ply(path):
    """PLY (ascii, binary little/big endian): the vertex element's scalar properties."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise ValueError("%s: not a PLY file" % path)
    body = end + len(b"end_header")
    body += 2 if data[body:body + 2] == b"\r\n" else 1
    fmt, elements, cur = None, [], None
    for line in data[:end].decode("ascii", "replace").splitlines():
        t = line.split()
        if not t:
            continue
        if t[0] == "format":
            fmt = t[1]
        elif t[0] == "element":
            cur = [t[1], int(t[2]), []]
            elements.append(cur)
        elif t[0] == "property":
            if t[1] == "list":
                raise ValueError("%s: list properties are not read" % path)
            cur[2].append((t[2], _PLY_TYPES[t[1]]))
    pos, rec = body, None
    for name, count, props in elements:
        if fmt == "ascii":
            text = data[pos:].decode("ascii").split("\n")
            if name == "vertex":
                rows = np.array([r.split() for r in text[:count]], dtype=np.float64)
                rec = {p: rows[:, i] for i, (p, _) in enumerate(props)}
                break
            raise ValueError("%s: ascii PLY with elements before the vertices" % path)
        endian = "<" if fmt == "binary_little_endian" else ">"
        dt = np.dtype([(p, endian + t) for p, t in props])
        if name == "vertex":
            arr = np.frombuffer(data, dtype=dt, count=count, offset=pos)
            rec = {p: arr[p].astype(np.float64) for p, _ in props}
            break
        pos += dt.itemsize * count
    if rec is None:
        raise ValueError("%s: no vertex element" % path)
    xyz = np.stack([rec["x"], rec["y"], rec["z"]], 1)
    return xyz, {k: v for k, v in rec.items() if k not in ("x", "y", "z")}


def read_text(path):
    """Whitespace-, comma- or semicolon-separated columns; header lines are skipped."""
    rows = []
    with open(path, "r", errors="replace") as f:
        for line in f:
            s = line.strip().replace(",", " ").replace(";", " ")
            if not s or s[0] in "#/":
                continue
            try:
                rows.append([float(x) for x in s.split()])
            except ValueError:
                continue  # a header line
    width = min(len(r) for r in rows)
    return np.array([r[:width] for r in rows], dtype=np.float64)


def load_real_tree(entry, base):
    """One manifest entry -> dict(name, xyz, wood (bool), fields, meta)."""
    def p(x):
        return x if os.path.isabs(x) else os.path.join(base, x)

    if "wood_path" in entry:
        parts = []
        for key, lab in (("wood_path", True), ("leaf_path", False)):
            x, fields = load_xyz_fields(p(entry[key]))
            parts.append((x, np.full(len(x), lab), fields))
        xyz = np.concatenate([a[0] for a in parts])
        wood = np.concatenate([a[1] for a in parts])
        fields = {}
        for k in set(parts[0][2]) & set(parts[1][2]):
            fields[k] = np.concatenate([parts[0][2][k], parts[1][2][k]])
        files = [p(entry["wood_path"]), p(entry["leaf_path"])]
        keep = np.ones(len(xyz), bool)
    else:
        path = p(entry["path"])
        xyz, fields = load_xyz_fields(path)
        label = entry.get("label")
        if label is None:
            label = next((f for f in LABEL_FIELDS if f in fields), None)
            if label is None and "_columns" in fields:
                label = fields["_columns"].shape[1] - 1
        if isinstance(label, int):
            lab = fields["_columns"][:, label]
        elif label in fields:
            lab = fields[label]
        else:
            raise ValueError("%s: no label field %r (has %s)" % (path, label, sorted(fields)))
        if "wood" not in entry or "leaf" not in entry:
            raise ValueError("%s: give the wood = [...] and leaf = [...] label values" % path)
        lab = np.rint(np.asarray(lab, np.float64)).astype(np.int64)
        is_wood = np.isin(lab, entry["wood"])
        is_leaf = np.isin(lab, entry["leaf"])
        keep = is_wood | is_leaf
        wood = is_wood
        files = [path]
        entry = dict(entry, label=label)
    fields.pop("_columns", None)
    xyz, wood = xyz[keep], wood[keep]
    fields = {k: v[keep] for k, v in fields.items()}
    name = entry.get("name") or os.path.splitext(os.path.basename(files[0]))[0]
    meta = {k: v for k, v in entry.items() if k not in ("path", "wood_path", "leaf_path")}
    meta["files"] = [{"path": f, "bytes": os.path.getsize(f), "sha256": sha256(f)} for f in files]
    meta["points_labelled"] = int(len(xyz))
    meta["labels_are"] = entry.get("labels_are", "manual")
    return {"name": name, "xyz": xyz, "wood": wood, "fields": fields, "meta": meta}


def load_xyz_fields(path):
    ext = os.path.splitext(path)[1].lower()
    if ext == ".las":
        return read_any_las(path)
    if ext == ".laz":
        raise ValueError("%s: LAZ is not read here; decompress it to LAS first" % path)
    if ext == ".ply":
        return read_ply(path)
    if ext == ".npy":
        a = np.load(path)
        return a[:, :3].astype(np.float64), {"_columns": a}
    if ext == ".npz":
        z = np.load(path)
        xyz_key = next(k for k in ("xyz", "points", "coords", "coord", "pos") if k in z.files)
        fields = {k: z[k] for k in z.files if k != xyz_key}
        return z[xyz_key][:, :3].astype(np.float64), fields
    a = read_text(path)
    return a[:, :3], {"_columns": a}


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


# --------------------------------------------------------------------------------------------
# The simulated trees
# --------------------------------------------------------------------------------------------

def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, dict):
        return "{ " + ", ".join("%s = %s" % (k, toml_value(x)) for k, x in v.items()) + " }"
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    raise TypeError(v)


def write_spec(spec, path):
    """A minimal TOML writer for a dataset spec: top-level keys, [[species]], tables."""
    lines = []
    for k, v in spec.items():
        if not isinstance(v, (dict, list)) or (isinstance(v, list) and not
                                                (v and isinstance(v[0], dict))):
            lines.append("%s = %s" % (k, toml_value(v)))
    for k, v in spec.items():
        if isinstance(v, list) and v and isinstance(v[0], dict):
            for item in v:
                lines.append("\n[[%s]]" % k)
                lines += ["%s = %s" % (a, toml_value(b)) for a, b in item.items()]
    for k, v in spec.items():
        if isinstance(v, dict):
            lines.append("\n[%s]" % k)
            sub = []
            for a, b in v.items():
                if isinstance(b, dict):
                    sub.append((a, b))
                else:
                    lines.append("%s = %s" % (a, toml_value(b)))
            for a, b in sub:
                lines.append("\n[%s.%s]" % (k, a))
                lines += ["%s = %s" % (c, toml_value(d)) for c, d in b.items()]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def derive_spec(args):
    with open(args.spec, "rb") as f:
        spec = tomllib.load(f)
    base = os.path.dirname(os.path.abspath(args.spec))
    species = []
    for s in spec["species"]:
        s = dict(s)
        s["file"] = os.path.normpath(os.path.join(base, s["file"]))
        species.append(s)
    if args.species:
        names = [x.strip() for x in args.species.split(",") if x.strip()]
        species = [{"file": os.path.join(REPO, "species", "presets", n + ".toml"), "count": 1}
                   for n in names]
    if args.trees_per_species:
        for s in species:
            s["count"] = args.trees_per_species
    if args.quick:
        keep = [s for s in species if any(k in s["file"] for k in
                                          ("european-beech", "norway-maple", "scots-pine"))]
        species = keep or species[:3]
        for s in species:
            s["count"] = 1
        spec["scan"]["horizontal_step_deg"] = 0.1
        spec["scan"]["vertical_step_deg"] = 0.1
        spec["scan"]["sub_rays"] = 1
        spec["name"] = spec["name"] + "-quick"
    spec["species"] = species
    return spec


def build_sim(args, spec):
    sim_dir = os.path.join(args.out, "sim")
    os.makedirs(sim_dir, exist_ok=True)
    spec_path = os.path.join(args.out, "sim_spec.toml")
    write_spec(spec, spec_path)
    cmd = [args.sylva, "build", spec_path, "--out", sim_dir]
    log("sim: " + " ".join(cmd))
    t = time.time()
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        sys.stdout.write(r.stdout[-4000:])
        raise SystemExit("sylva build failed (exit %d)" % r.returncode)
    last = [l for l in r.stdout.splitlines() if l.strip()][-1:]
    log("sim: %s (%.0f s)" % (last[0] if last else "built", time.time() - t))
    commit = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    version = "repo %s" % (commit.stdout.strip() or "?")
    records = []
    with open(os.path.join(sim_dir, "manifest.jsonl")) as f:
        for line in f:
            if line.strip():
                records.append(json.loads(line))
    records.sort(key=lambda r: r["id"])
    if records:
        with open(os.path.join(sim_dir, records[0]["files"]["scan_las"]), "rb") as f:
            software = f.read(90)[58:90].split(b"\0")[0].decode("ascii", "replace")
        version = "%s, %s" % (software, version)
    return sim_dir, spec_path, version, records


def load_sim_tree(sim_dir, rec):
    las = read_las(os.path.join(sim_dir, rec["files"]["scan_las"]))
    sem = las.fields["semantic_seg"]
    keep = (sem == 2) | (sem == 3)  # wood, leaf; ground (1) dropped
    fields = {"return_number": las.fields["return_number"][keep],
              "number_of_returns": las.fields["number_of_returns"][keep]}
    return {"name": rec["id"], "species": rec["species"], "xyz": las.positions[keep],
            "wood": sem[keep] == 2, "fields": fields,
            "meta": {"sylva_height_m": rec["stats"]["height_m"],
                     "sylva_crown_base_height_m": rec["stats"]["crown_base_height_m"],
                     "scan_points": rec["scan"]["points"],
                     "wood_surface_hit": rec["scan"]["wood_surface_hit_mean"]}}


# --------------------------------------------------------------------------------------------
# Thinning and features
# --------------------------------------------------------------------------------------------

def raw_spacing(xyz, rng, n=4000):
    """Median distance from a point to its nearest neighbour (of a seeded sample)."""
    i = rng.choice(len(xyz), min(n, len(xyz)), replace=False)
    d, _ = cKDTree(xyz, balanced_tree=False, compact_nodes=False).query(xyz[i], k=2)
    return float(np.median(d[:, 1]))


def voxel_pick(xyz, size, rng):
    """One point per occupied voxel of the given size (a seeded random one): indices."""
    perm = rng.permutation(len(xyz))
    k = np.floor((xyz[perm] - xyz.min(0)) / size).astype(np.int64)
    k -= k.min(0)
    dims = k.max(0) + 1
    key = (k[:, 0] * dims[1] + k[:, 1]) * dims[2] + k[:, 2]
    _, first = np.unique(key, return_index=True)
    return np.sort(perm[first])


def eigen_features(query, support, radius, jobs, k_max=96, chunk=20000):
    """Eigenvalue features of the support points within `radius` of each query point."""
    tree = cKDTree(support, balanced_tree=False, compact_nodes=False)
    pad = np.vstack([support, np.zeros((1, 3))])
    out = np.full((len(query), len(FEATURES)), -1.0)
    for s in range(0, len(query), chunk):
        q = query[s:s + chunk]
        d, idx = tree.query(q, k=k_max, distance_upper_bound=radius, workers=jobs)
        mask = np.isfinite(d)
        cnt = mask.sum(1)
        pts = pad[idx] - q[:, None, :]
        w = mask[..., None]
        mean = (pts * w).sum(1) / np.maximum(cnt, 1)[:, None]
        dev = (pts - mean[:, None, :]) * w
        cov = np.einsum("qki,qkj->qij", dev, dev) / np.maximum(cnt, 1)[:, None, None]
        evals, evecs = np.linalg.eigh(cov)  # ascending
        lam = np.clip(evals[:, ::-1], 1e-12, None)  # l1 >= l2 >= l3
        e = lam / lam.sum(1, keepdims=True)
        l1, l2, l3 = e[:, 0], e[:, 1], e[:, 2]
        normal = evecs[:, :, 0]
        f = np.stack([(l1 - l2) / l1, (l2 - l3) / l1, l3 / l1, np.cbrt(l1 * l2 * l3),
                      (l1 - l3) / l1, -(e * np.log(e)).sum(1), l3, 1.0 - np.abs(normal[:, 2])], 1)
        ok = cnt >= 4
        out[s:s + chunk][ok] = f[ok]
    return out


def cached(args, key, make):
    """prepare_tree's result, kept in OUT/features/ under a hash of its inputs."""
    h = hashlib.sha256(json.dumps([key, args.voxel, args.radii, args.query_points,
                                   args.height_bins, FEATURES, 2]).encode()).hexdigest()[:16]
    path = os.path.join(args.out, "features", h + ".npz")
    if os.path.exists(path):
        z = np.load(path, allow_pickle=False)
        info = json.loads(str(z["info"]))
        return dict(info, X=z["X"], y=z["y"], rel=z["rel"], query=z["query"])
    t = make()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    info = {k: v for k, v in t.items() if k not in ("X", "y", "rel", "query")}
    np.savez(path + ".tmp.npz", X=t["X"], y=t["y"], rel=t["rel"], query=t["query"],
             info=json.dumps(info, default=float))
    os.replace(path + ".tmp.npz", path)
    return t


def prepare_tree(tree, args, seed):
    """Thin to the common voxel, sample query points and compute their features."""
    rng = np.random.default_rng(seed)
    xyz = tree["xyz"]
    z0 = np.percentile(xyz[:, 2], 0.05)
    height = np.percentile(xyz[:, 2], 99.95) - z0
    rel_raw = (xyz[:, 2] - z0) / height
    spacing = raw_spacing(xyz, rng)
    vox = voxel_pick(xyz, args.voxel, rng)
    v_xyz, v_wood = xyz[vox], tree["wood"][vox]
    nq = min(args.query_points, len(v_xyz))
    q = np.sort(rng.choice(len(v_xyz), nq, replace=False))
    query = v_xyz[q]
    cols, names = [], []
    for r in args.radii:
        sup = v_xyz[voxel_pick(v_xyz, max(args.voxel, r / 3.0), rng)]
        cols.append(eigen_features(query, sup, r, args.jobs))
        names += ["%s_r%g" % (f, r) for f in FEATURES]
    rel = (query[:, 2] - z0) / height
    cols.append(rel[:, None])
    names.append("rel_height")
    bins = np.linspace(0, 1, args.height_bins + 1)
    hist_raw = np.histogram(np.clip(rel_raw, 0, 1 - 1e-9), bins)[0]
    rel_vox = np.clip((v_xyz[:, 2] - z0) / height, 0, 1 - 1e-9)
    hist_vox = np.histogram(rel_vox, bins)[0]
    wood_hist = np.histogram(rel_vox[v_wood], bins)[0]
    returns = None
    f = tree["fields"]
    if "number_of_returns" in f and np.any(f["number_of_returns"] > 0):
        nr, rn = f["number_of_returns"], f["return_number"]
        w = tree["wood"]
        returns = {
            "multiple_share": float(np.mean(nr > 1)),
            "multiple_share_wood": float(np.mean(nr[w] > 1)) if w.any() else None,
            "multiple_share_leaf": float(np.mean(nr[~w] > 1)) if (~w).any() else None,
            "by_number_of_returns": {str(k): float(np.mean(nr == k)) for k in (1, 2, 3)}
            | {"4+": float(np.mean(nr >= 4))},
            "by_return_number": {str(k): float(np.mean(rn == k)) for k in (1, 2, 3)}
            | {"4+": float(np.mean(rn >= 4))},
        }
    return {
        "name": tree["name"], "species": tree.get("species"), "X": np.hstack(cols),
        "names": names, "y": v_wood[q].astype(np.int64), "rel": rel, "query": query,
        "stats": {"points": int(len(xyz)), "points_voxel": int(len(v_xyz)), "query": int(nq),
                  "spacing_m": spacing,
                  "wood_share_voxel": float(v_wood.mean()), "height_m": float(height),
                  "density_by_height_raw": (hist_raw / hist_raw.sum()).tolist(),
                  "density_by_height_voxel": (hist_vox / hist_vox.sum()).tolist(),
                  "wood_share_by_height": (wood_hist / np.maximum(hist_vox, 1)).tolist(),
                  "returns": returns},
        "meta": tree.get("meta", {}),
    }


# --------------------------------------------------------------------------------------------
# Classification experiments
# --------------------------------------------------------------------------------------------

def feature_sets(names, radii, small_max):
    small = [r for r in radii if r <= small_max]
    large = [r for r in radii if r > small_max]
    def cols(rs, height):
        sel = [i for i, n in enumerate(names)
               if (n == "rel_height" and height) or
               any(n.endswith("_r%g" % r) for r in rs)]
        return sel
    return {"all": cols(radii, True),
            "small": cols(small, False),
            "large": cols(large, False)}


def metrics(y, p, rel, crown_frac):
    tp = int(np.sum((p == 1) & (y == 1)))
    fp = int(np.sum((p == 1) & (y == 0)))
    fn = int(np.sum((p == 0) & (y == 1)))
    tn = int(np.sum((p == 0) & (y == 0)))
    def div(a, b):
        return a / b if b else float("nan")
    rec_w, rec_l = div(tp, tp + fn), div(tn, tn + fp)
    crown = rel > crown_frac
    ct, cf = np.sum((p == 1) & (y == 1) & crown), np.sum((p == 0) & (y == 1) & crown)
    iou_w, iou_l = div(tp, tp + fp + fn), div(tn, tn + fn + fp)
    return {"balanced_accuracy": (rec_w + rec_l) / 2, "wood_recall": rec_w,
            "wood_precision": div(tp, tp + fp), "leaf_recall": rec_l,
            "wood_iou": iou_w, "leaf_iou": iou_l, "miou": (iou_w + iou_l) / 2,
            "crown_wood_recall": div(int(ct), int(ct + cf)), "points": int(len(y)),
            "wood_share": div(tp + fn, len(y))}


def train_sample(trees, cols, cap, rng):
    per = max(1, cap // max(1, len(trees)))
    X, y = [], []
    for t in trees:
        i = rng.choice(len(t["y"]), min(per, len(t["y"])), replace=False)
        X.append(t["X"][i][:, cols])
        y.append(t["y"][i])
    return np.vstack(X), np.concatenate(y)


def forest(args):
    from sklearn.ensemble import RandomForestClassifier
    # Each tree sees a quarter of the samples and stops at 5 per leaf, depth 24: a forest of
    # 60 such trees on 100 k points fits in seconds, not minutes, and scores the same.
    return RandomForestClassifier(n_estimators=args.trees, min_samples_leaf=5, max_depth=24,
                                  max_samples=0.25, max_features="sqrt",
                                  class_weight="balanced_subsample", n_jobs=args.jobs,
                                  random_state=args.seed)


def evaluate(train, tests, cols, args, rng):
    X, y = train_sample(train, cols, args.train_points, rng)
    clf = forest(args).fit(X, y)
    per, ys, ps, rels = {}, [], [], []
    for t in tests:
        p = clf.predict(t["X"][:, cols])
        per[t["name"]] = metrics(t["y"], p, t["rel"], args.crown_frac)
        ys.append(t["y"])
        ps.append(p)
        rels.append(t["rel"])
    return per, (np.concatenate(ys), np.concatenate(ps), np.concatenate(rels))


def pooled(parts, crown_frac):
    y = np.concatenate([a[0] for a in parts])
    p = np.concatenate([a[1] for a in parts])
    r = np.concatenate([a[2] for a in parts])
    return metrics(y, p, r, crown_frac)


def spatial_blocks(t, n_folds, cube, buffer, seed):
    """Folds of cubes: the tree's space cut into cubes of `cube` m, the cubes dealt at random
    (seeded) to `n_folds` folds. A fold is tested by a forest trained on the other folds'
    points farther than `buffer` from their cube's faces, so no test point lies within
    `buffer` of a training point. Within one tree this is still optimistic: the larger
    neighbourhoods reach across cubes. (Sectors around the stem, the other choice, would leave
    the stem, shared by all sectors, out of every training set.)"""
    xyz = t["query"]
    k = np.floor((xyz - xyz.min(0)) / cube).astype(np.int64)
    _, cube_id = np.unique(k, axis=0, return_inverse=True)
    cube_id = cube_id.ravel()
    rng = np.random.default_rng(seed)
    fold_of_cube = rng.permutation(cube_id.max() + 1) % n_folds
    fold = fold_of_cube[cube_id]
    frac = (xyz - xyz.min(0)) / cube - k
    inner = np.all((frac * cube > buffer) & ((1 - frac) * cube > buffer), axis=1)
    return [((fold != f) & inner, fold == f) for f in range(n_folds)]


def subset(t, mask, suffix):
    return dict(t, X=t["X"][mask], y=t["y"][mask], rel=t["rel"][mask], query=t["query"][mask],
                name=t["name"] + suffix)


def run_experiments(sim, real, args):
    names = sim[0]["names"] if sim else real[0]["names"]
    sets = feature_sets(names, args.radii, args.small_max)
    res = {}
    rng_seed = args.seed
    if real:
        res["sim_to_real"] = {}
        for fs, cols in sets.items():
            rng = np.random.default_rng(rng_seed)
            per, part = evaluate(sim, real, cols, args, rng)
            res["sim_to_real"][fs] = {"pooled": pooled([part], args.crown_frac), "per_tree": per}
        res["real_to_real"] = {}
        for fs, cols in sets.items():
            parts, per = [], {}
            if len(real) >= 2:
                split = "leave-one-tree-out"
                for i, t in enumerate(real):
                    rng = np.random.default_rng(rng_seed + i)
                    pt, part = evaluate([r for j, r in enumerate(real) if j != i], [t], cols,
                                        args, rng)
                    per.update(pt)
                    parts.append(part)
            else:
                split = ("within one tree (optimistic): %d folds of %g m cubes, training "
                         "points %g m inside their cubes" % (args.blocks, args.block_size,
                                                             args.block_buffer))
                t = real[0]
                for b, (tr, te) in enumerate(spatial_blocks(t, args.blocks, args.block_size,
                                                            args.block_buffer, args.seed)):
                    rng = np.random.default_rng(rng_seed + b)
                    pt, part = evaluate([subset(t, tr, "")], [subset(t, te, "/block%d" % b)],
                                        cols, args, rng)
                    per.update(pt)
                    parts.append(part)
            res["real_to_real"][fs] = {"pooled": pooled(parts, args.crown_frac),
                                       "per_tree": per, "split": split}
    if args.sim_to_sim and len({t["species"] for t in sim}) >= 2:
        res["sim_to_sim"] = {}
        species = sorted({t["species"] for t in sim})
        for fs in ["all"]:
            cols = sets[fs]
            parts, per = [], {}
            for i, s in enumerate(species):
                rng = np.random.default_rng(rng_seed + 100 + i)
                pt, part = evaluate([t for t in sim if t["species"] != s],
                                    [t for t in sim if t["species"] == s], cols, args, rng)
                per.update(pt)
                parts.append(part)
            res["sim_to_sim"][fs] = {"pooled": pooled(parts, args.crown_frac), "per_tree": per,
                                     "split": "leave-one-species-out"}
    return res, {k: [names[i] for i in v] for k, v in sets.items()}


# --------------------------------------------------------------------------------------------
# Domain-gap diagnostics
# --------------------------------------------------------------------------------------------

def ks_distances(sim, real, args):
    rng = np.random.default_rng(args.seed + 7)
    names = sim[0]["names"]
    def pool(trees, cls):
        X = []
        for t in trees:
            m = np.ones(len(t["y"]), bool) if cls is None else t["y"] == cls
            X.append(t["X"][m])
        X = np.vstack(X)
        if len(X) > args.ks_points:
            X = X[rng.choice(len(X), args.ks_points, replace=False)]
        return X
    out, med = {}, {}
    for key, cls in (("all", None), ("wood", WOOD), ("leaf", LEAF)):
        a, b = pool(sim, cls), pool(real, cls)
        out[key] = {n: float(ks_2samp(a[:, i], b[:, i]).statistic) for i, n in enumerate(names)}
        med[key] = {n: [float(np.median(a[:, i])), float(np.median(b[:, i]))]
                    for i, n in enumerate(names)}
    by_radius = {}
    for r in args.radii:
        keys = ["%s_r%g" % (f, r) for f in FEATURES]
        by_radius["r%g" % r] = {c: float(np.mean([out[c][k] for k in keys])) for c in out}
    return {"per_feature": out, "median_sim_real": med, "mean_by_radius": by_radius}


def mean_lists(trees, key):
    arr = np.array([t["stats"][key] for t in trees], dtype=np.float64)
    return arr.mean(0).tolist()


def returns_summary(trees):
    got = [t["stats"]["returns"] for t in trees if t["stats"]["returns"]]
    if not got:
        return None
    def avg(k):
        v = [g[k] for g in got if g[k] is not None]
        return float(np.mean(v)) if v else None
    out = {k: avg(k) for k in ("multiple_share", "multiple_share_wood", "multiple_share_leaf")}
    for k in ("by_number_of_returns", "by_return_number"):
        out[k] = {c: float(np.mean([g[k][c] for g in got])) for c in got[0][k]}
    out["trees"] = len(got)
    return out


# --------------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------------

def fmt(x, nd=3):
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else ("%.*f" % (nd, x))


COLS = [("balanced_accuracy", "bal. acc."), ("wood_recall", "wood recall"),
        ("wood_precision", "wood precision"), ("miou", "mIoU"), ("wood_iou", "wood IoU"),
        ("leaf_iou", "leaf IoU"), ("crown_wood_recall", "crown wood recall")]


def report(results, args):
    L = []
    L.append("# Sim-to-real wood/leaf benchmark\n")
    c = results["config"]
    L.append("sylva `%s` (%s), spec `%s`; voxel %.3f m, radii %s m, %d query points per tree, "
             "random forest of %d trees (seed %d); crown = above %.2f of the tree height.\n"
             % (c["sylva"], c["sylva_version"], c["spec"], c["voxel"], c["radii"],
                c["query_points"], c["forest_trees"], c["seed"], c["crown_frac"]))
    if not results["real_trees"]:
        L.append("**No real labelled trees were given** (bench/data/real/README.md says where "
                 "they come from and how to pass them): only the simulated side ran.\n")
    for t in results["real_trees"]:
        if t["labels_are"] != "manual":
            L.append("**Not ground truth:** the labels of real tree %s are `%s`, not hand "
                     "labels; its figures measure agreement with that, not accuracy.\n"
                     % (t["name"], t["labels_are"]))
    L.append("## Classification\n")
    L.append("| train → test | features | " + " | ".join(h for _, h in COLS) + " | points |")
    L.append("|---" * (len(COLS) + 3) + "|")
    for exp, label in (("sim_to_real", "sim → real"), ("real_to_real", "real → real"),
                       ("sim_to_sim", "sim → sim (other species)")):
        for fs, r in results["experiments"].get(exp, {}).items():
            m = r["pooled"]
            L.append("| %s | %s | %s | %d |" % (label, fs, " | ".join(fmt(m[k]) for k, _ in COLS),
                                               m["points"]))
    for exp in ("sim_to_real", "real_to_real"):
        r = results["experiments"].get(exp, {}).get("all")
        if r:
            L.append("\nPer tree, %s, all features%s:\n" % (
                exp.replace("_", " "), " (" + r["split"] + ")" if "split" in r else ""))
            L.append("| tree | " + " | ".join(h for _, h in COLS) + " |")
            L.append("|---" * (len(COLS) + 1) + "|")
            for name, m in r["per_tree"].items():
                L.append("| %s | %s |" % (name, " | ".join(fmt(m[k]) for k, _ in COLS)))
    ks = results.get("ks")
    if ks:
        L.append("\n## KS distance, sim vs real feature distributions\n")
        L.append("| radius | all points | wood | leaf |")
        L.append("|---|---|---|---|")
        for r, v in ks["mean_by_radius"].items():
            L.append("| %s | %s | %s | %s |" % (r, fmt(v["all"]), fmt(v["wood"]), fmt(v["leaf"])))
        L.append("\n| feature | " + " | ".join("r = %g m" % r for r in c["radii"]) + " |")
        L.append("|---" * (len(c["radii"]) + 1) + "|")
        for f in FEATURES:
            L.append("| %s | %s |" % (f, " | ".join(fmt(ks["per_feature"]["all"]["%s_r%g" % (f, r)])
                                                  for r in c["radii"])))
        L.append("| rel_height | %s |" % fmt(ks["per_feature"]["all"]["rel_height"]))
        L.append("\nMedians, sim / real, of the features with the largest KS distance:\n")
        L.append("| feature | KS | all | wood | leaf |")
        L.append("|---|---|---|---|---|")
        worst = sorted(ks["per_feature"]["all"].items(), key=lambda kv: -kv[1])[:8]
        for k, v in worst:
            L.append("| %s | %s | %s |" % (k, fmt(v), " | ".join(
                "%s / %s" % tuple(fmt(x) for x in ks["median_sim_real"][c][k])
                for c in ("all", "wood", "leaf"))))
    d = results["density_by_height"]
    L.append("\n## Point share by relative height (after the voxel; raw in results.json)\n")
    L.append("| height | sim points | real points | sim wood share | real wood share |")
    L.append("|---|---|---|---|---|")
    for i in range(len(d["bins"]) - 1):
        L.append("| %.1f–%.1f | %s | %s | %s | %s |" % (
            d["bins"][i], d["bins"][i + 1], fmt(d["sim_voxel"][i]),
            fmt(d["real_voxel"][i] if d["real_voxel"] else None), fmt(d["sim_wood_share"][i]),
            fmt(d["real_wood_share"][i] if d["real_wood_share"] else None)))
    rs = results["returns"]
    L.append("\n## Returns\n")
    for side in ("sim", "real"):
        r = rs.get(side)
        if r:
            L.append("- %s: multiple-return share %s (wood %s, leaf %s); by number of returns %s"
                     % (side, fmt(r["multiple_share"]), fmt(r["multiple_share_wood"]),
                        fmt(r["multiple_share_leaf"]),
                        ", ".join("%s: %s" % (k, fmt(v)) for k, v in r["by_number_of_returns"].items())))
        else:
            L.append("- %s: no return numbers" % side)
    L.append("\n## Trees\n")
    L.append("| side | tree | species | points | voxel points | wood share | height m | labels |")
    L.append("|---|---|---|---|---|---|---|---|")
    for side in ("sim", "real"):
        for t in results["%s_trees" % side]:
            L.append("| %s | %s | %s | %d | %d | %s | %s | %s |" % (
                side, t["name"], t.get("species") or "—", t["points"], t["points_voxel"],
                fmt(t["wood_share_voxel"]), fmt(t["height_m"], 1),
                t.get("labels_are", "simulated")))
    L.append("\nWall time %.0f s." % results["timing"]["total_s"])
    return "\n".join(L) + "\n"


def print_summary(results):
    log("")
    for exp, label in (("sim_to_real", "sim -> real"), ("real_to_real", "real -> real"),
                       ("sim_to_sim", "sim -> sim ")):
        for fs, r in results["experiments"].get(exp, {}).items():
            m = r["pooled"]
            log("%s  %-5s  BA %s  wood recall %s  wood precision %s  mIoU %s  crown wood recall %s"
                % (label, fs, fmt(m["balanced_accuracy"]), fmt(m["wood_recall"]),
                   fmt(m["wood_precision"]), fmt(m["miou"]), fmt(m["crown_wood_recall"])))
    ks = results.get("ks")
    if ks:
        log("KS sim vs real, mean over the 8 features: " + ", ".join(
            "%s %s (wood %s, leaf %s)" % (r, fmt(v["all"]), fmt(v["wood"]), fmt(v["leaf"]))
            for r, v in ks["mean_by_radius"].items()))
        radii = results["config"]["radii"]
        log("KS sim vs real per feature (all points):  " + "  ".join(
            "r=%-5g" % r for r in radii))
        for f in FEATURES:
            log("  %-17s %s" % (f, "  ".join("%-7s" % fmt(ks["per_feature"]["all"]["%s_r%g" % (f, r)])
                                             for r in radii)))
        log("  %-17s %s" % ("rel_height", fmt(ks["per_feature"]["all"]["rel_height"])))
        worst = sorted(ks["per_feature"]["all"].items(), key=lambda kv: -kv[1])[:6]
        log("largest KS, median sim / real (wood; leaf): " + "; ".join(
            "%s %s/%s (%s/%s; %s/%s)" % ((k,) + tuple(fmt(x, 2) for c in ("all", "wood", "leaf")
                                                      for x in ks["median_sim_real"][c][k]))
            for k, _ in worst))
    d = results["density_by_height"]
    log("point share by rel. height (voxel), sim:  " + " ".join(fmt(x, 2) for x in d["sim_voxel"]))
    if d["real_voxel"]:
        log("point share by rel. height (voxel), real: " + " ".join(fmt(x, 2) for x in d["real_voxel"]))
    log("wood share by rel. height, sim:  " + " ".join(fmt(x, 2) for x in d["sim_wood_share"]))
    if d["real_wood_share"]:
        log("wood share by rel. height, real: " + " ".join(fmt(x, 2) for x in d["real_wood_share"]))
    for side in ("sim", "real"):
        r = results["returns"].get(side)
        if r:
            log("%s multiple-return share %s (wood %s, leaf %s)" % (
                side, fmt(r["multiple_share"]), fmt(r["multiple_share_wood"]),
                fmt(r["multiple_share_leaf"])))


# --------------------------------------------------------------------------------------------

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sylva", default=os.path.join(REPO, "build", "sylva"))
    ap.add_argument("--spec", default=os.path.join(HERE, "sim2real.toml"))
    ap.add_argument("--out", default=None, help="default build/sim2real (-quick)")
    ap.add_argument("--quick", action="store_true", help="3 species, 1 tree each, 0.1° steps, "
                    "fewer points and forest trees: a smoke run of ≤ 3 min")
    ap.add_argument("--species", help="comma-separated library presets instead of the spec's")
    ap.add_argument("--trees-per-species", type=int)
    ap.add_argument("--real-manifest", default=None,
                    help="TOML list of real trees (default bench/data/real/trees.toml if present)")
    ap.add_argument("--real", action="append", default=[], help="a real labelled tree file")
    ap.add_argument("--real-label", help="label field or column of the --real files")
    ap.add_argument("--real-wood", help="comma-separated wood label values of --real files")
    ap.add_argument("--real-leaf", help="comma-separated leaf label values of --real files")
    ap.add_argument("--voxel", default="auto",
                    help="common spacing (m); auto: 0.015, or the real trees' median point "
                    "spacing when that is coarser, so both sides are thinned to the sparser one")
    ap.add_argument("--radii", default="0.1,0.2,0.4,0.8")
    ap.add_argument("--small-max", type=float, default=0.25,
                    help="radii up to this (m) are the small-scale set, the rest large-scale")
    ap.add_argument("--query-points", type=int, default=None, help="per tree")
    ap.add_argument("--train-points", type=int, default=None, help="per forest")
    ap.add_argument("--trees", type=int, default=None, help="trees per random forest")
    ap.add_argument("--crown-frac", type=float, default=1.0 / 3.0)
    ap.add_argument("--blocks", type=int, default=4,
                    help="folds of spatial blocks when there is one real tree")
    ap.add_argument("--block-size", type=float, default=3.0, help="block cube edge (m)")
    ap.add_argument("--block-buffer", type=float, default=0.2,
                    help="training points this close to their block's faces are dropped (m)")
    ap.add_argument("--height-bins", type=int, default=10)
    ap.add_argument("--ks-points", type=int, default=20000)
    ap.add_argument("--no-sim-to-sim", dest="sim_to_sim", action="store_false")
    ap.add_argument("--seed", type=int, default=1129)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    args.radii = [float(r) for r in args.radii.split(",")]
    q = args.quick
    args.query_points = args.query_points or (6000 if q else 25000)
    args.train_points = args.train_points or (30000 if q else 100000)
    args.trees = args.trees or (40 if q else 60)
    args.out = os.path.abspath(args.out or os.path.join(
        REPO, "build", "sim2real-quick" if q else "sim2real"))
    os.makedirs(args.out, exist_ok=True)
    t_start = time.time()
    timing = {}

    # Real trees first: a bad manifest should fail before the build.
    entries, base = [], os.getcwd()
    manifest = args.real_manifest
    if manifest is None and not args.real:
        default = os.path.join(HERE, "data", "real", "trees.toml")
        manifest = default if os.path.exists(default) else None
    if manifest:
        with open(manifest, "rb") as f:
            entries = tomllib.load(f).get("tree", [])
        base = os.path.dirname(os.path.abspath(manifest))
    for pth in args.real:
        e = {"path": os.path.abspath(pth)}
        if args.real_label is not None:
            e["label"] = int(args.real_label) if args.real_label.isdigit() else args.real_label
        if args.real_wood:
            e["wood"] = [int(x) for x in args.real_wood.split(",")]
        if args.real_leaf:
            e["leaf"] = [int(x) for x in args.real_leaf.split(",")]
        entries.append(e)
    t = time.time()
    loaded = [load_real_tree(e, base) for e in entries]
    spacing = [raw_spacing(tr["xyz"], np.random.default_rng(args.seed)) for tr in loaded]
    if args.voxel == "auto":
        args.voxel = max([0.015] + [math.ceil(sp * 1000) / 1000 for sp in spacing])
    else:
        args.voxel = float(args.voxel)
    real = []
    for i, (e, tree) in enumerate(zip(entries, loaded)):
        log("real: %s: %d labelled points, point spacing %.4f m, wood share %.3f, labels %s" % (
            tree["name"], len(tree["xyz"]), spacing[i], tree["wood"].mean(),
            tree["meta"]["labels_are"]))
        key = ["real", tree["name"], [f["sha256"] for f in tree["meta"]["files"]],
               e.get("label"), e.get("wood"), e.get("leaf"), args.seed + 5000 + i]
        real.append(cached(args, key, lambda: prepare_tree(tree, args, args.seed + 5000 + i)))
        real[-1]["species"] = e.get("species")
        real[-1]["labels_are"] = tree["meta"]["labels_are"]
        loaded[i] = None
    if not real:
        log("real: no labelled real trees given (bench/data/real/README.md says how): "
            "only the simulated side runs")
    log("common voxel %.3f m" % args.voxel)
    timing["real_s"] = time.time() - t

    t = time.time()
    spec = derive_spec(args)
    sim_dir, spec_path, version, records = build_sim(args, spec)
    timing["sim_build_s"] = time.time() - t
    t = time.time()
    sim = []
    for i, rec in enumerate(records):
        las = os.path.join(sim_dir, rec["files"]["scan_las"])
        st = os.stat(las)
        key = ["sim", rec["id"], rec["seed"], st.st_size, st.st_mtime_ns, args.seed + i]
        sim.append(cached(args, key, lambda: prepare_tree(load_sim_tree(sim_dir, rec), args,
                                                          args.seed + i)))
        log("sim: %s: %d points, %d after the voxel, wood share %.3f" % (
            rec["id"], sim[-1]["stats"]["points"], sim[-1]["stats"]["points_voxel"],
            sim[-1]["stats"]["wood_share_voxel"]))
    timing["sim_features_s"] = time.time() - t

    t = time.time()
    experiments, sets = run_experiments(sim, real, args)
    timing["forests_s"] = time.time() - t
    bins = np.linspace(0, 1, args.height_bins + 1).tolist()
    results = {
        "config": {"sylva": args.sylva, "sylva_version": version,
                   "spec": os.path.relpath(args.spec, REPO), "derived_spec": spec_path,
                   "quick": args.quick, "voxel": args.voxel, "radii": args.radii,
                   "small_max": args.small_max, "query_points": args.query_points,
                   "train_points": args.train_points, "forest_trees": args.trees,
                   "crown_frac": args.crown_frac, "seed": args.seed, "feature_sets": sets,
                   "real_manifest": manifest},
        "sim_trees": [dict(name=s["name"], species=s["species"], **{
            k: v for k, v in s["stats"].items() if not isinstance(v, (list, dict))},
            **s["meta"]) for s in sim],
        "real_trees": [dict(name=r["name"], species=r["species"], labels_are=r["labels_are"], **{
            k: v for k, v in r["stats"].items() if not isinstance(v, (list, dict))},
            meta=r["meta"]) for r in real],
        "experiments": experiments,
        "ks": ks_distances(sim, real, args) if real else None,
        "density_by_height": {
            "bins": bins,
            "sim_raw": mean_lists(sim, "density_by_height_raw"),
            "sim_voxel": mean_lists(sim, "density_by_height_voxel"),
            "sim_wood_share": mean_lists(sim, "wood_share_by_height"),
            "real_raw": mean_lists(real, "density_by_height_raw") if real else None,
            "real_voxel": mean_lists(real, "density_by_height_voxel") if real else None,
            "real_wood_share": mean_lists(real, "wood_share_by_height") if real else None,
        },
        "returns": {"sim": returns_summary(sim), "real": returns_summary(real) if real else None},
    }
    timing["total_s"] = time.time() - t_start
    results["timing"] = timing
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(results, f, indent=1, default=float)
    with open(os.path.join(args.out, "results.md"), "w") as f:
        f.write(report(results, args))
    print_summary(results)
    log("\nwrote %s/results.json and results.md (%.0f s)" % (args.out, timing["total_s"]))


if __name__ == "__main__":
    main()
