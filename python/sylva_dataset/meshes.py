"""Mesh readers for the three formats sylva writes (docs/outputs.md, "Meshes"), each returning
the same Mesh of plain numpy arrays.

- PLY (mesh.ply, watertight.ply): vertex x y z nx ny nz u v, int order, uchar part, uchar colour;
  face list uchar uint vertex_indices (triangles).
- GLB (glTF 2.0 binary): one node per part, meshes "wood" and "leaves", triangle primitives with
  POSITION, NORMAL, TEXCOORD_0 and the application attributes _ORDER and _COLOUR (floats).
- OBJ: "o wood" / "o leaves" objects of v, vt, vn and f a/a/a lines (1-based, global indices).

Parts follow the PLY convention everywhere: 0 wood, 1 leaves (GLB: the mesh named "leaves";
OBJ: the object named "leaves"). Every reader takes a path or the file's bytes (a tar shard's
member); the OBJ reader does not read the MTL its mtllib names.
"""

import json
import os
import struct
from collections import namedtuple

import numpy as np

from .ply import read_ply
from .source import read_source

__all__ = ["Mesh", "read_mesh", "read_mesh_ply", "read_glb", "read_obj"]


class Mesh(namedtuple("Mesh", "positions faces normals uvs order part colour vertices")):
    """A triangle mesh as plain arrays (torch.from_numpy takes each):

    positions  (N, 3) float32, metres
    faces      (F, 3) int64 vertex indices (an object array of index arrays only for a PLY whose
               faces are not all triangles)
    normals    (N, 3) float32, or None (OBJ without vn)
    uvs        (N, 2) float32, or None
    order      (N,) int64 branch order, or None (OBJ has no per-vertex attributes)
    part       (N,) int64: 0 wood, 1 leaves
    colour     (N,) int64 leaf colour class, or None
    vertices   the PLY vertex element as read (structured array); None for GLB and OBJ
    """


def _f32(a, width=None):
    a = np.ascontiguousarray(a, dtype=np.float32)
    return a.reshape(-1, width) if width else a


def _i64(a):
    return np.ascontiguousarray(a, dtype=np.int64)


def read_mesh_ply(source, name=None):
    ply = read_ply(source, name)
    v = ply["vertex"]
    names = v.dtype.names
    faces = ply["face"]["vertex_indices"] if "face" in ply else np.zeros((0, 3), np.int64)
    if faces.dtype != object:
        faces = _i64(faces).reshape(len(faces), -1)

    def column(*fields):
        if not all(f in names for f in fields):
            return None
        return np.stack([v[f] for f in fields], axis=1)

    positions = _f32(column("x", "y", "z"), 3)
    n = len(positions)
    normals = column("nx", "ny", "nz")
    uvs = column("u", "v")
    return Mesh(positions, faces,
                None if normals is None else _f32(normals, 3),
                None if uvs is None else _f32(uvs, 2),
                _i64(v["order"]) if "order" in names else None,
                _i64(v["part"]) if "part" in names else np.zeros(n, np.int64),
                _i64(v["colour"]) if "colour" in names else None,
                v)


# --- GLB ------------------------------------------------------------------------------------------

_GLTF_COMPONENTS = {5120: "i1", 5121: "u1", 5122: "i2", 5123: "u2", 5125: "u4", 5126: "f4"}
_GLTF_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def _glb_chunks(data, path):
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF" or version != 2:
        raise ValueError("%s: not a glTF 2.0 binary (GLB) file" % path)
    pos, gltf, binary = 12, None, b""
    while pos < min(length, len(data)):
        size, kind = struct.unpack_from("<I4s", data, pos)
        chunk = data[pos + 8:pos + 8 + size]
        if kind == b"JSON":
            gltf = json.loads(chunk.decode("utf-8"))
        elif kind == b"BIN\0" and not binary:
            binary = chunk
        pos += 8 + size
    if gltf is None:
        raise ValueError("%s: GLB without a JSON chunk" % path)
    return gltf, binary


def _accessor(gltf, binary, index, path):
    acc = gltf["accessors"][index]
    if "sparse" in acc or "bufferView" not in acc:
        raise ValueError("%s: accessor %d: sparse or view-less accessors are not read" % (path, index))
    view = gltf["bufferViews"][acc["bufferView"]]
    if view.get("buffer", 0) != 0 or "uri" in gltf["buffers"][view.get("buffer", 0)]:
        raise ValueError("%s: accessor %d: only the GLB's own binary chunk is read" % (path, index))
    dt = np.dtype("<" + _GLTF_COMPONENTS[acc["componentType"]])
    width = _GLTF_WIDTHS[acc["type"]]
    count = acc["count"]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = view.get("byteStride", 0) or width * dt.itemsize
    if stride == width * dt.itemsize:
        out = np.frombuffer(binary, dt, count * width, start).reshape(count, width)
    else:
        rows = np.frombuffer(binary, np.uint8, stride * (count - 1) + width * dt.itemsize, start)
        out = np.lib.stride_tricks.as_strided(rows, (count, width * dt.itemsize), (stride, 1))
        out = np.ascontiguousarray(out).view(dt).reshape(count, width)
    return out if width > 1 else out[:, 0]


def _quat_matrix(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _node_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], np.float64).reshape(4, 4).T  # column-major in glTF
    m = np.eye(4)
    m[:3, :3] = _quat_matrix(node.get("rotation", [0, 0, 0, 1])) * np.array(node.get("scale", [1, 1, 1]))
    m[:3, 3] = node.get("translation", [0, 0, 0])
    return m


def _quat_matrices(q):
    """Rotation matrices (K, 3, 3) of unit quaternions (K, 4) as x, y, z, w."""
    x, y, z, w = (q[:, k] for k in range(4))
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=1)],
        axis=1)


def _instances(gltf, binary, node, path):
    """A node's EXT_mesh_gpu_instancing transforms as matrices (K, 4, 4) and its _LEAF ids (or
    None)."""
    a = node["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]

    def get(name, width):
        if name not in a:
            return None
        v = _accessor(gltf, binary, a[name], path).astype(np.float64).reshape(-1, width)
        acc = gltf["accessors"][a[name]]
        if acc.get("normalized") and acc["componentType"] != 5126:  # normalised integers
            info = np.iinfo(_GLTF_COMPONENTS[acc["componentType"]])
            v = np.maximum(v / info.max, -1.0)
        return v

    t, r, s = get("TRANSLATION", 3), get("ROTATION", 4), get("SCALE", 3)
    count = next(len(v) for v in (t, r, s, np.zeros((0, 1))) if v is not None)
    m = np.tile(np.eye(4), (count, 1, 1))
    if r is not None:
        m[:, :3, :3] = _quat_matrices(r)
    if s is not None:
        m[:, :3, :3] *= s[:, None, :]
    if t is not None:
        m[:, :3, 3] = t
    ids = _accessor(gltf, binary, a["_LEAF"], path) if "_LEAF" in a else None
    return m, ids


def _instances_in_order(groups):
    """One part of every instance drawn out, in the order of their _LEAF ids (the leaves' order
    in the tree; without ids, file order): each group's arrays scattered to its instances'
    places at once. groups: (ids or None, the mesh's arrays, positions (K, n, 3), normals)."""
    ids = [np.asarray(g[0], np.int64) if g[0] is not None else None for g in groups]
    if any(i is None for i in ids):  # no ids: file order
        start = 0
        for k, g in enumerate(groups):
            ids[k] = np.arange(start, start + len(g[2]))
            start += len(g[2])
    count = sum(len(i) for i in ids)
    verts = np.zeros(count, np.int64)  # per leaf: its vertices, then its triangles
    tris = np.zeros(count, np.int64)
    for i, (_, p, pos, _) in zip(ids, groups):
        verts[i] = pos.shape[1]
        tris[i] = len(p["faces"])
    vstart = np.concatenate([[0], np.cumsum(verts)])
    tstart = np.concatenate([[0], np.cumsum(tris)])
    out = {}

    def put(key, per_leaf, values, i, width):
        """Scatters `values` ((K, m, width) or the mesh's (m, width), repeated) to the rows of
        the instances `i`."""
        start = vstart if per_leaf == "v" else tstart
        m = values.shape[-2]
        rows = (start[i][:, None] + np.arange(m)[None, :]).ravel()
        if key not in out:
            total = vstart[-1] if per_leaf == "v" else tstart[-1]
            out[key] = np.zeros((total, width), values.dtype)
        out[key][rows] = np.broadcast_to(values, (len(i), m, width)).reshape(-1, width)

    for i, (_, p, pos, normals) in zip(ids, groups):
        put("positions", "v", pos, i, 3)
        if normals is not None:
            put("normals", "v", normals, i, 3)
        for key, width in (("uvs", 2), ("order", 1), ("colour", 1), ("part", 1)):
            if p[key] is not None:
                put(key, "v", np.asarray(p[key]).reshape(-1, width), i, width)
        put("faces", "t", np.asarray(p["faces"], np.int64), i, 3)
    # Each leaf's faces index its own vertices: shift by the leaf's first vertex.
    leaf_of_tri = np.repeat(np.arange(count), tris)
    out["faces"] += vstart[:-1][leaf_of_tri][:, None]
    part = {k: (v[:, 0] if k in ("order", "colour", "part") else v) for k, v in out.items()}
    for key in ("normals", "uvs", "order", "colour"):
        part.setdefault(key, None)
    return part


def read_glb(source, name=None):
    """Reads the triangle primitives of a GLB's default scene (node transforms applied) into one
    Mesh, in node order; vertex arrays missing from some primitive are None. source: a path or
    the file's bytes; name: what error messages call it. Leaves written as GPU instances
    ([outputs] leaf_instances: EXT_mesh_gpu_instancing) are drawn out, one copy of the node's
    mesh per instance, in the order of their _LEAF ids: the same vertices, in the same order, as
    the plain file's leaves (up to float rounding). A compressed file (EXT_meshopt_compression,
    KHR_draco_mesh_compression) is not read."""
    data, path = read_source(source, name)
    gltf, binary = _glb_chunks(data, path)
    for codec, readers in (("KHR_draco_mesh_compression", "three.js, glTF Transform, Blender"),
                           ("EXT_meshopt_compression", "three.js, gltfpack, Blender")):
        if codec in gltf.get("extensionsUsed", []):
            raise ValueError("%s: %s is not read here (%s read it); write the plain GLB to read "
                             "it with numpy" % (path, codec, readers))
    scenes = gltf.get("scenes", [])
    roots = scenes[gltf.get("scene", 0)].get("nodes", []) if scenes else range(len(gltf.get("nodes", [])))
    parts = []
    groups = []  # instanced leaves: (ids, per-instance arrays of one primitive)

    def primitives(node):
        mesh = gltf["meshes"][node["mesh"]]
        part = 1 if mesh.get("name", node.get("name")) == "leaves" else 0
        for prim in mesh["primitives"]:
            if prim.get("mode", 4) != 4:
                raise ValueError("%s: primitive mode %d: only triangles are read" % (path, prim["mode"]))
            a = prim["attributes"]

            def get(name):
                return _accessor(gltf, binary, a[name], path) if name in a else None

            pos = get("POSITION")
            n = len(pos)
            idx = (_accessor(gltf, binary, prim["indices"], path) if "indices" in prim
                   else np.arange(n))
            yield dict(positions=pos, faces=idx.reshape(-1, 3), normals=get("NORMAL"),
                       uvs=get("TEXCOORD_0"), order=get("_ORDER"), colour=get("_COLOUR"),
                       part=np.full(n, part))

    def transformed(p, m):
        """p's positions and normals through m (K, 4, 4) or (4, 4): arrays (K, n, 3) or (n, 3)."""
        lin = m[..., :3, :3]
        pos = np.einsum("...ij,nj->...ni", lin, p["positions"]) + m[..., None, :3, 3]
        normals = p["normals"]
        if normals is not None:
            inv_t = np.swapaxes(np.linalg.inv(lin), -1, -2)  # normals: the inverse transpose
            normals = np.einsum("...ij,nj->...ni", inv_t, normals)
            normals /= np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-30)
        return pos, normals

    def visit(index, parent):
        node = gltf["nodes"][index]
        m = parent @ _node_matrix(node)
        if "mesh" in node and "EXT_mesh_gpu_instancing" in node.get("extensions", {}):
            mats, ids = _instances(gltf, binary, node, path)
            world = m @ mats
            for p in primitives(node):
                pos, normals = transformed(p, world)
                groups.append((ids, p, pos, normals))
        elif "mesh" in node:
            for p in primitives(node):
                if not np.array_equal(m, np.eye(4)):  # sylva's nodes have no transform
                    p["positions"], p["normals"] = transformed(p, m)
                parts.append(p)
        for child in node.get("children", []):
            visit(child, m)

    for r in roots:
        visit(r, np.eye(4))
    if groups:
        parts.append(_instances_in_order(groups))
    return _concatenate(parts)


def _concatenate(parts):
    """One Mesh from per-primitive dicts of arrays; an attribute missing from any part is None."""
    def cat(key):
        """Parts lacking the attribute get zeros (sylva's GLB has _COLOUR on leaves only; the PLY
        gives wood colour 0); None when no part has it."""
        have = [p[key] for p in parts if p[key] is not None]
        if not have:
            return None
        shape = np.asarray(have[0]).shape[1:]
        return np.concatenate([np.asarray(p[key]) if p[key] is not None
                               else np.zeros((len(p["positions"]),) + shape) for p in parts])

    def as_int(a):
        return None if a is None else _i64(np.rint(a))

    starts = np.cumsum([0] + [len(p["positions"]) for p in parts])
    faces = [_i64(p["faces"]) + s for p, s in zip(parts, starts)]
    positions, normals, uvs = cat("positions"), cat("normals"), cat("uvs")
    return Mesh(_f32(positions if positions is not None else np.zeros((0, 3)), 3),
                np.concatenate(faces) if faces else np.zeros((0, 3), np.int64),
                None if normals is None else _f32(normals, 3), None if uvs is None else _f32(uvs, 2),
                as_int(cat("order")), as_int(cat("part")) if parts else np.zeros(0, np.int64),
                as_int(cat("colour")), None)


# --- OBJ ------------------------------------------------------------------------------------------


def read_obj(source, name=None):
    """Reads a Wavefront OBJ's v / vt / vn / f lines into a Mesh. Polygons are split into
    triangle fans. Normals and UVs are per vertex when every face corner uses the same UV and
    normal for the same position (as sylva writes, f a/a/a); otherwise they are None. The part
    of each vertex is 1 under an object or group named "leaves", else 0. source: a path or the
    file's bytes (UTF-8); name: what error messages call it."""
    data, _ = read_source(source, name)
    lines = {"v": [], "vt": [], "vn": [], "f": []}
    part_starts = []  # (index of the first vertex after an o/g line, part)
    for line in data.decode("utf-8").splitlines():
        tag, _, rest = line.strip().partition(" ")
        if tag in lines:
            lines[tag].append(rest)
        elif tag in ("o", "g"):
            part_starts.append((len(lines["v"]), 1 if rest.split()[:1] == ["leaves"] else 0))
    positions = _f32(_obj_numbers(lines["v"], 3), 3)
    part = np.zeros(len(positions), np.int64)
    for start, p in part_starts:
        part[start:] = p
    corners = _obj_corners(lines["f"], (len(positions), len(lines["vt"]), len(lines["vn"])))

    def per_vertex(tag, slot, width):
        if not lines[tag] or (corners[:, slot] < 0).any():
            return None
        values = _obj_numbers(lines[tag], width)[corners[:, slot]]
        out = np.zeros((len(positions), width), np.float64)
        out[corners[:, 0]] = values
        if not np.array_equal(out[corners[:, 0]], values):
            return None  # some vertex has two different UVs or normals
        return _f32(out, width)

    return Mesh(positions, corners[:, 0].reshape(-1, 3).copy(), per_vertex("vn", 2, 3),
                per_vertex("vt", 1, 2), None, part, None, None)


def _obj_numbers(rows, width):
    """The first `width` numbers of each row (v may carry a w or colours; vt a w)."""
    flat = " ".join(rows).split()
    if len(flat) == width * len(rows):  # the usual case: exactly `width` numbers per row
        return np.array(flat, np.float64).reshape(-1, width)
    return np.array([r.split()[:width] for r in rows], np.float64).reshape(-1, width)


def _obj_corners(rows, counts):
    """Triangle corners (3 per triangle) as rows of (v, vt, vn) 0-based indices, −1 absent."""
    flat = " ".join(rows).replace("/", " ").split()
    if len(flat) == 9 * len(rows) and "//" not in "".join(rows):  # all "f a/b/c a/b/c a/b/c"
        idx = np.array(flat, np.int64).reshape(-1, 3)
        if (idx > 0).all():
            return idx - 1
    corners = []
    for r in rows:
        ids = []
        for c in r.split():
            k = (c.split("/") + ["", ""])[:3]
            ids.append([_obj_index(t, n) for t, n in zip(k, counts)])
        for i in range(1, len(ids) - 1):  # a triangle fan
            corners += (ids[0], ids[i], ids[i + 1])
    return np.array(corners, np.int64).reshape(-1, 3)


def _obj_index(s, count):
    if not s:
        return -1
    i = int(s)
    return i - 1 if i > 0 else count + i  # 1-based, or negative = relative to the end


def read_mesh(source, fmt=None, name=None):
    """A Mesh from a .ply, .glb or .obj file. source: a path or the file's bytes; fmt: "ply",
    "glb" or "obj", by default the extension of `name` or of the path (a member name such as
    ID.mesh.glb has one too)."""
    what = name or ("<bytes>" if isinstance(source, (bytes, bytearray, memoryview))
                    else os.fspath(source))
    ext = (fmt or what.rsplit(".", 1)[-1]).lower()
    readers = {"ply": read_mesh_ply, "glb": read_glb, "obj": read_obj}
    if ext not in readers:
        raise ValueError("%s: unknown mesh format %r (ply, glb, obj)" % (what, ext))
    return readers[ext](source, name)
