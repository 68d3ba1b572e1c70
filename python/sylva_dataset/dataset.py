"""A dataset directory written by ``sylva build``: dataset.json, the manifest, and per instance
the files its manifest record names (docs/outputs.md) — files in the instance's directory, or
members of a tar shard when the dataset is packed (the record's "pack")."""

import io
import json
import os
import re
import tarfile
from collections import namedtuple

import numpy as np

from .exr import read_exr_first_channel
from .las import read_las
from .meshes import read_mesh
from .ply import read_ply
from .png import read_png
from .shards import TarShards, member_name
from .source import read_source

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


class _DirectoryFiles:
    """An unpacked instance's files: names are paths relative to the dataset directory; a frame's
    files are relative to its transforms.json's directory."""

    def __init__(self, root):
        self.root = root

    def source(self, name):
        return os.path.join(self.root, name)

    def describe(self, name):
        return os.path.join(self.root, name)

    def sibling(self, of, name):
        return os.path.join(os.path.dirname(of), name)


# What a packed build keeps of an instance until it writes the instance's shard: its files as
# members of one archive in its directory (pipeline/batch/pack.h kPackStageFile).
STAGE_FILE = "staged.tar"


class _TarFiles:
    """A packed instance's files: names are members of its tar shard, and so are a frame's.
    Until the shard holds them (the build is running, or was killed before it wrote the shard)
    they are files in the instance's directory `staged`, whose transforms.json names its frames'
    files by path: either is read from there."""

    def __init__(self, shards, tar, key, staged):
        self.shards, self.tar, self.key, self.staged = shards, tar, key, staged

    def source(self, name):
        try:
            return self.shards.read(self.tar, name)
        except (FileNotFoundError, KeyError):
            path = self._staged_path(name)
            if path is not None:
                return path
            data = self._staged_member(name)
            if data is None:
                raise
            return data

    def _staged_member(self, name):
        """The bytes of a file the instance's staged archive (staged.tar in its directory: the
        files a packed build keeps until it writes the shard) holds under `name`, its path in
        the instance directory or its member name; None without one."""
        if self.staged is None:
            return None
        archive = os.path.join(self.staged, STAGE_FILE)
        if not os.path.isfile(archive):
            return None
        with tarfile.open(archive) as t:
            for m in t.getmembers():
                if m.isfile() and (m.name == name or member_name(self.key, m.name) == name):
                    return t.extractfile(m).read()
        return None

    def _staged_path(self, name):
        if self.staged is None:
            return None
        path = os.path.join(self.staged, name)  # a staged transforms.json's frame path
        if os.path.isfile(path):
            return path
        for dirpath, _, names in os.walk(self.staged):
            for n in names:
                p = os.path.join(dirpath, n)
                if member_name(self.key, os.path.relpath(p, self.staged)) == name:
                    return p
        return None

    def describe(self, name):
        return "%s:%s" % (self.shards.path(self.tar), name)

    def sibling(self, of, name):
        return name


class _SampleFiles:
    """A streamed sample's files: {member name: bytes} (sylva_dataset.iter_shard); a frame's files
    are members too."""

    def __init__(self, members, where):
        self.members, self.where = members, where

    def source(self, name):
        if name not in self.members:
            raise KeyError("%s: sample has no member %r (it has %s)"
                           % (self.where, name, ", ".join(sorted(self.members))))
        return self.members[name]

    def describe(self, name):
        return "%s:%s" % (self.where, name)

    def sibling(self, of, name):
        return name


class Instance:
    """One instance of a dataset — a tree, or a plot (kind "plot") — its manifest record and
    readers for its files, from its directory or, when the record has "pack", from the members of
    that tar shard (shards: the sylva_dataset.shards.TarShards that reads them; Dataset passes its
    own, shared by its instances)."""

    def __init__(self, dataset_dir, record, shards=None):
        self.root = dataset_dir
        self.record = record
        self.pack = record.get("pack")  # "shards/000003.tar" when packed, else None
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
        if self.pack is None:
            self._files = _DirectoryFiles(dataset_dir)
        else:
            self._files = _TarFiles(shards or TarShards(dataset_dir), self.pack, self.id,
                                    self._directory())

    @classmethod
    def from_sample(cls, key, members, where="<sample>"):
        """The instance of a sample streamed from a tar shard: key, {member name: bytes} as
        sylva_dataset.iter_shard yields them; its record is the member <key>.json. where: what
        error messages call the sample's source (its tar)."""
        name = key + ".json"
        if name not in members:
            raise KeyError("%s: sample %r has no %s member (the instance's record)"
                           % (where, key, name))
        inst = cls(None, json.loads(members[name].decode("utf-8")))
        inst._files = _SampleFiles(members, where)
        return inst

    def __repr__(self):
        if self.kind == "plot":
            return "Instance(%r, plot=%r)" % (self.id, self.plot)
        return "Instance(%r, species=%r)" % (self.id, self.species)

    def _name(self, key):
        if key not in self.files:
            raise KeyError("%s: the manifest record has no %r file (it has %s)"
                           % (self.id, key, ", ".join(sorted(self.files)) or "none"))
        return self.files[key]

    def path(self, key):
        """Absolute path of the file named by the record's files[key] (KeyError if absent). A
        packed instance has no files of its own: read_bytes(key) reads its tar member."""
        name = self._name(key)
        if self.pack is not None or self.root is None:
            raise ValueError("%s: packed (%s): files[%r] is the tar member %r, not a file; "
                             "read_bytes(%r) reads it" % (self.id, self.pack, key, name, key))
        return os.path.join(self.root, name)

    def read_bytes(self, key):
        """The bytes of the file named by files[key]: the file, or the packed instance's member."""
        name = self._name(key)
        return read_source(self._files.source(name), self._files.describe(name))[0]

    def _source(self, key):
        """(path or bytes, name for messages) of files[key]."""
        name = self._name(key)
        return self._files.source(name), self._files.describe(name)

    def _frame_source(self, name):
        """(path or bytes, name for messages) of a file a transforms.json frame names."""
        name = self._files.sibling(self._name("transforms"), name)
        return self._files.source(name), self._files.describe(name)

    @property
    def dir(self):
        """The instance directory: trees/<species>/<id>, or plots/<plot>/<id> for a plot; None
        for a packed instance (its files are members of the tar shard `pack`)."""
        if self.pack is not None or self.root is None:
            return None
        return self._directory()

    def _directory(self):
        if self.root is None:
            return None
        if self.kind == "plot":
            return os.path.join(self.root, "plots", self.plot or "", self.id)
        return os.path.join(self.root, "trees", self.species or "", self.id)

    def skeleton(self):
        """The skeleton graph from skeleton.ply (see Skeleton)."""
        ply = read_ply(*self._source("skeleton_ply"))
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
        source, name = self._source("%s_%s" % (kind, fmt))
        return read_mesh(source, fmt, name)

    def points(self):
        """The labelled point cloud (points.ply; see PointCloud)."""
        v = read_ply(*self._source("points_ply"))["vertex"]
        return PointCloud(_native(np.stack([v["x"], v["y"], v["z"]], axis=1), np.float32),
                          _native(v["label"], np.int64), _native(v["view"], np.int64), v)

    def scan(self):
        """The simulated laser scan (scan.las; see Scan)."""
        las = read_las(*self._source("scan_las"))
        f = las.fields
        return Scan(las.positions, f["classification"], f["treeID"], f["treeSP"],
                    f["semantic_seg"], f["return_number"], f["number_of_returns"],
                    f["intensity"], f["gps_time"], f["branch_order"], f["node_id"], las)

    def cameras(self):
        """transforms.json: intrinsics and one frame (camera-to-world matrix, files) per view. In
        a tar shard its frames name their files by member name (ID.views.000.png)."""
        return json.loads(self.read_bytes("transforms").decode("utf-8"))

    # One frame's files (ViewDataset reads views one at a time through these).

    def _frame_mask(self, frame):
        return read_png(*self._frame_source(frame.get("mask_path", frame["file_path"])))

    def _frame_rgb(self, frame):
        """The colour picture, or None when file_path is the silhouette (no colour pictures)."""
        path = frame.get("file_path")
        if path is None or path == frame.get("mask_path", path):
            return None
        return read_colour(*self._frame_source(path))

    def _frame_labels(self, frame):
        return read_png(*self._frame_source(frame["label_file_path"]))

    def _frame_depth(self, frame):
        return read_exr_first_channel(*self._frame_source(frame["depth_file_path"]))

    def masks(self):
        """The view silhouettes, in frame order: (H, W) uint8, 0 background, 255 tree (each
        frame's mask_path; file_path in datasets written before colour pictures)."""
        return [self._frame_mask(fr) for fr in self.cameras().get("frames", [])
                if "file_path" in fr or "mask_path" in fr]

    def rgb(self):
        """The colour pictures ([views] colour), in frame order: (H, W, 4) uint8 sRGB with
        straight alpha from the PNGs, (H, W, 3) from JPEGs (read through Pillow or OpenCV, one of
        which must be installed); [] when the dataset has none."""
        pictures = (self._frame_rgb(fr) for fr in self.cameras().get("frames", []))
        return [p for p in pictures if p is not None]

    def labels(self):
        """The label views, in frame order: (H, W) uint8, 0 background, 1 + branch order for the
        shoot's wood (at most 253), 254 root wood, 255 leaves."""
        return [self._frame_labels(fr) for fr in self.cameras().get("frames", [])
                if "label_file_path" in fr]

    def depths(self):
        """The depth views, in frame order: (H, W) float32 metres along the view axis (z-depth),
        0 = background. Read from each frame's depth_file_path EXR (its first channel, whatever its
        name); a dataset with 16-bit depth PNGs only (instant-ngp's depth_path) gives value ×
        integer_depth_scale instead, quantised to that scale."""
        cams = self.cameras()
        frames = cams.get("frames", [])
        if any("depth_file_path" in fr for fr in frames):
            return [self._frame_depth(fr) for fr in frames if "depth_file_path" in fr]
        pngs = [fr["depth_path"] for fr in frames if "depth_path" in fr]
        if not pngs:
            return []
        scale = cams.get("integer_depth_scale")
        if not scale or scale <= 0:
            raise ValueError("%s: depth PNGs without a positive integer_depth_scale in "
                             "transforms.json" % self.id)
        return [(read_png(*self._frame_source(p)).astype(np.float64) * scale).astype(np.float32)
                for p in pngs]


def read_colour(source, name=None):
    """A colour picture (a path or the file's bytes): an RGBA PNG (H, W, 4) by the package's
    decoder, a JPEG (H, W, 3) by Pillow or OpenCV."""
    data, name = read_source(source, name)
    if data.startswith(b"\x89PNG\r\n\x1a\n"):
        return read_png(data, name)
    try:
        from PIL import Image
        with Image.open(io.BytesIO(data)) as im:
            return np.asarray(im.convert("RGB"), np.uint8)
    except ImportError:
        pass
    try:
        import cv2
    except ImportError as e:
        raise ImportError("%s: reading JPEG colour pictures needs Pillow or OpenCV" % name) from e
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if img is None:
        raise ValueError("%s: not a readable JPEG" % name)
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
        self.shards = TarShards(self.root)  # member indexes and open files of the tar shards

    @property
    def packed(self):
        """True when some instance is packed in a tar shard ([outputs] pack = "tar")."""
        return any("pack" in r for r in self.records)

    def instance(self, record):
        """The Instance of a manifest record (a packed one reads through self.shards)."""
        return Instance(self.root, record, self.shards)

    def __repr__(self):
        return "Dataset(%r, %d instances)" % (self.root, len(self))

    def __len__(self):
        return len(self.records)

    def __iter__(self):
        for r in self.records:
            yield self.instance(r)

    def __getitem__(self, key):
        if isinstance(key, str):
            return self.instance(self.records[self._by_id[key]])
        return self.instance(self.records[key])

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
        return [self.instance(r) for r in self.records if r.get("species") == name]
