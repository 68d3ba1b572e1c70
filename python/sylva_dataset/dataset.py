"""A dataset directory written by ``sylva build``: dataset.json, the manifest, and per instance
the files its manifest record names (docs/outputs.md)."""

import json
import os
import re
from collections import namedtuple

import numpy as np

from .exr import read_exr_first_channel
from .las import read_las
from .meshes import read_mesh
from .ply import read_ply
from .png import read_png

__all__ = ["Dataset", "Instance", "Skeleton", "PointCloud", "Scan", "MESH_FORMATS"]

MESH_FORMATS = ("ply", "glb", "obj")  # in the order Instance.mesh picks a default
MESH_KINDS = ("mesh", "watertight")


class Skeleton(namedtuple("Skeleton", "positions radii parents edges order part nodes")):
    """A skeleton graph as plain arrays (torch.from_numpy takes each):

    positions  (N, 3) float32 node positions, metres
    radii      (N,) float32 node radii, metres (also as .radius)
    parents    (N,) int64 parent node index, −1 for the root (node 0)
    edges      (E, 2) int64 (parent, child) node indices, E = N − 1
    order      (N,) int64 branch order (0 = trunk; the taproot is order 0 of the roots)
    part       (N,) int64: 0 shoot, 1 root system
    nodes      the PLY vertex element as read (structured array: x y z radius order part)
    """

    @property
    def radius(self):
        return self.radii


class PointCloud(namedtuple("PointCloud", "positions labels views vertices")):
    """points.ply as plain arrays:

    positions  (P, 3) float32 world points, metres
    labels     (P,) int64, as the label images (1 + order wood, 254 roots, 255 leaves)
    views      (P,) int64 the view each point was seen from
    vertices   the PLY vertex element as read (structured array)
    """


class Scan(namedtuple("Scan", "positions classification tree_id species semantic return_number "
                               "number_of_returns intensity gps_time branch_order node_id las")):
    """A simulated laser scan (scan.las, docs/scanning.md) as plain arrays:

    positions          (P, 3) float64 metres, LAS frame (x east, y north, z up)
    classification     (P,) int64 FOR-instance class: 0 unclassified, 1 low vegetation,
                       2 terrain, 3 out-points, 4 stem, 5 live branches, 6 woody branches
    tree_id            (P,) int64 treeID: the tree table's id, 0 = no tree
    species            (P,) int64 treeSP: species index
    semantic           (P,) int64 semantic_seg: 1 ground, 2 wood, 3 leaf
    return_number, number_of_returns, intensity: (P,) int64; gps_time (P,) float64 seconds
    branch_order       (P,) int64 (0 = stem)
    node_id            (P,) int64 the skeleton node hit (−1: none)
    las                the LasFile (header, every field, the Extra Bytes descriptors)
    """


def _native(a, dtype):
    """A C-contiguous copy in native byte order (structured-array fields are strided views, and
    a big-endian PLY gives byte-swapped ones; torch.from_numpy takes neither)."""
    return np.ascontiguousarray(a, dtype=dtype)


class Instance:
    """One instance of a dataset — a tree, or a plot (kind "plot") — its manifest record and
    readers for its files."""

    def __init__(self, dataset_dir, record):
        self.root = dataset_dir
        self.record = record
        self.id = record.get("id")
        self.kind = record.get("kind", "tree")  # "tree" or "plot"
        self.species = record.get("species")   # a tree's species; None for a plot
        self.plot = record.get("plot")         # a plot's name; None for a tree
        self.index = record.get("index")
        self.seed = record.get("seed")
        self.stats = record.get("stats", {})
        self.params = record.get("params", {})
        self.sweep = record.get("sweep", {})
        self.files = record.get("files", {})

    def __repr__(self):
        if self.kind == "plot":
            return "Instance(%r, plot=%r)" % (self.id, self.plot)
        return "Instance(%r, species=%r)" % (self.id, self.species)

    def path(self, key):
        """Absolute path of the file named by the record's files[key] (KeyError if absent)."""
        if key not in self.files:
            raise KeyError("%s: the manifest record has no %r file (it has %s)"
                           % (self.id, key, ", ".join(sorted(self.files)) or "none"))
        return os.path.join(self.root, self.files[key])

    @property
    def dir(self):
        """The instance directory: trees/<species>/<id>, or plots/<plot>/<id> for a plot."""
        if self.kind == "plot":
            return os.path.join(self.root, "plots", self.plot, self.id)
        return os.path.join(self.root, "trees", self.species, self.id)

    def skeleton(self):
        """The skeleton graph from skeleton.ply (see Skeleton)."""
        ply = read_ply(self.path("skeleton_ply"))
        v, e = ply["vertex"], ply.get("edge")
        n = len(v)
        edges = (np.stack([e["vertex1"], e["vertex2"]], axis=1) if e is not None and len(e)
                 else np.zeros((0, 2)))
        edges = _native(edges, np.int64)
        parents = np.full(n, -1, np.int64)
        parents[edges[:, 1]] = edges[:, 0]
        return Skeleton(_native(np.stack([v["x"], v["y"], v["z"]], axis=1), np.float32),
                        _native(v["radius"], np.float32), parents, edges,
                        _native(v["order"], np.int64), _native(v["part"], np.int64), v)

    def mesh_formats(self, kind="mesh"):
        """The formats of <kind> ("mesh" or "watertight") this instance has, in MESH_FORMATS order."""
        return [f for f in MESH_FORMATS if "%s_%s" % (kind, f) in self.files]

    def mesh(self, kind="mesh", fmt=None):
        """A Mesh of plain arrays (sylva_dataset.Mesh) from <kind>.<fmt>.

        kind: "mesh" (branch tubes + leaves) or "watertight" (the closed union of the branches);
        fmt: "ply", "glb" or "obj"; None: the first of those the manifest lists. A format alone
        names the plain mesh: inst.mesh("glb") == inst.mesh("mesh", "glb")."""
        if kind in MESH_FORMATS and fmt is None:
            kind, fmt = "mesh", kind
        if kind not in MESH_KINDS:
            raise ValueError("mesh kind %r: expected one of %s (or a format: %s)"
                             % (kind, ", ".join(MESH_KINDS), ", ".join(MESH_FORMATS)))
        if fmt is None:
            have = self.mesh_formats(kind)
            if not have:
                raise KeyError("%s: the manifest lists no %s file (%s)"
                               % (self.id, kind, ", ".join("%s_%s" % (kind, f) for f in MESH_FORMATS)))
            fmt = have[0]
        if fmt not in MESH_FORMATS:
            raise ValueError("mesh format %r: expected one of %s" % (fmt, ", ".join(MESH_FORMATS)))
        return read_mesh(self.path("%s_%s" % (kind, fmt)))

    def points(self):
        """The labelled point cloud (points.ply; see PointCloud)."""
        v = read_ply(self.path("points_ply"))["vertex"]
        return PointCloud(_native(np.stack([v["x"], v["y"], v["z"]], axis=1), np.float32),
                          _native(v["label"], np.int64), _native(v["view"], np.int64), v)

    def scan(self):
        """The simulated laser scan (scan.las; see Scan)."""
        las = read_las(self.path("scan_las"))
        f = las.fields
        return Scan(las.positions, f["classification"], f["treeID"], f["treeSP"],
                    f["semantic_seg"], f["return_number"], f["number_of_returns"],
                    f["intensity"], f["gps_time"], f["branch_order"], f["node_id"], las)

    def cameras(self):
        """transforms.json: intrinsics and one frame (camera-to-world matrix, files) per view."""
        with open(self.path("transforms")) as f:
            return json.load(f)

    def _frame_files(self, key):
        cams = self.cameras()
        base = os.path.dirname(self.path("transforms"))
        return [os.path.join(base, fr[key]) for fr in cams.get("frames", []) if key in fr]

    def masks(self):
        """The view silhouettes, in frame order: (H, W) uint8, 0 background, 255 tree (each
        frame's mask_path; file_path in datasets written before colour pictures)."""
        cams = self.cameras()
        base = os.path.dirname(self.path("transforms"))
        return [read_png(os.path.join(base, fr.get("mask_path", fr["file_path"])))
                for fr in cams.get("frames", []) if "file_path" in fr or "mask_path" in fr]

    def rgb(self):
        """The colour pictures ([views] colour), in frame order: (H, W, 4) uint8 sRGB with
        straight alpha from the PNGs, (H, W, 3) from JPEGs (read through Pillow or OpenCV, one of
        which must be installed); [] when the dataset has none."""
        cams = self.cameras()
        base = os.path.dirname(self.path("transforms"))
        out = []
        for fr in cams.get("frames", []):
            if "file_path" not in fr or fr["file_path"] == fr.get("mask_path", fr["file_path"]):
                continue  # file_path is the silhouette: no colour picture
            out.append(read_colour(os.path.join(base, fr["file_path"])))
        return out

    def labels(self):
        """The label views, in frame order: (H, W) uint8, 0 background, 1 + branch order for the
        shoot's wood (at most 253), 254 root wood, 255 leaves."""
        return [read_png(p) for p in self._frame_files("label_file_path")]

    def depths(self):
        """The depth views, in frame order: (H, W) float32 metres along the view axis (z-depth),
        0 = background. Read from each frame's depth_file_path EXR (its first channel, whatever its
        name); a dataset with 16-bit depth PNGs only (instant-ngp's depth_path) gives value ×
        integer_depth_scale instead, quantised to that scale."""
        exrs = self._frame_files("depth_file_path")
        if exrs:
            return [read_exr_first_channel(p) for p in exrs]
        pngs = self._frame_files("depth_path")
        if not pngs:
            return []
        scale = self.cameras().get("integer_depth_scale")
        if not scale or scale <= 0:
            raise ValueError("%s: depth PNGs without a positive integer_depth_scale in "
                             "transforms.json" % self.id)
        return [(read_png(p).astype(np.float64) * scale).astype(np.float32) for p in pngs]


def read_colour(path):
    """A colour picture: an RGBA PNG (H, W, 4) by the package's decoder, a JPEG (H, W, 3) by
    Pillow or OpenCV."""
    if path.lower().endswith(".png"):
        return read_png(path)
    try:
        from PIL import Image
        with Image.open(path) as im:
            return np.asarray(im.convert("RGB"), np.uint8)
    except ImportError:
        pass
    try:
        import cv2
    except ImportError as e:
        raise ImportError("%s: reading JPEG colour pictures needs Pillow or OpenCV" % path) from e
    img = cv2.imread(path, cv2.IMREAD_COLOR)
    if img is None:
        raise ValueError("%s: not a readable JPEG" % path)
    return img[:, :, ::-1].copy()


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
        if not os.path.isdir(self.root):
            raise FileNotFoundError("%s: no such dataset directory" % self.root)
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

    def __repr__(self):
        return "Dataset(%r, %d instances)" % (self.root, len(self))

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
        """The species of the tree instances, in first-seen manifest order (a plot's trees are
        in its plot.json, not the manifest: a plot-only dataset has none here)."""
        return self._first_seen("species")

    @property
    def plots(self):
        """The names of the plots of the plot instances, in first-seen manifest order."""
        return self._first_seen("plot")

    def _first_seen(self, key):
        seen = []
        for r in self.records:
            v = r.get(key)
            if v is not None and v not in seen:
                seen.append(v)
        return seen

    def by_species(self, name):
        return [Instance(self.root, r) for r in self.records if r.get("species") == name]
