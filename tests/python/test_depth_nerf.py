#!/usr/bin/python3
"""Depth and transforms.json of a `sylva build` as nerfstudio and instant-ngp read them.

Builds tests/data/nerf_dataset.toml with the given sylva executable, then for every instance:

- depth EXRs read with OpenCV (cv2.imread(f, cv2.IMREAD_ANYDEPTH), as nerfstudio does) and
  with OpenImageIO's Python module: one float32 channel "Y", identical arrays;
- that depth against the renderer's own buffer: points.ply holds the renderer's depth pixels
  back-projected in the build; back-projecting OpenCV's values through transforms.json the way
  nerfstudio does (origin + depth x R (x/f, -y/f, -1), z-depth) gives the same points, and
  wood pixels (label images) land on the skeleton's tubes, which reading the value as ray
  length would not (checked: it misses);
- the same build with `depth_compression = "zip"`: every EXR says "zip" to OpenImageIO and
  OpenCV reads the very bits of the RLE build's;
- the 16-bit PNG read with OpenCV as uint16 equals round(depth / integer_depth_scale), 0 off
  the tree;
- transforms.json's keys typed as the readers take them (aabb_scale an int, scale and
  integer_depth_scale floats, offset three numbers, mask_path/depth_path/depth_file_path
  strings naming existing files), and every skeleton node sphere and mesh vertex inside
  instant-ngp's unit cube after p * scale + offset.

Usage: test_depth_nerf.py SYLVA_EXE SOURCE_DIR
A missing module (numpy, cv2, OpenImageIO) is a failure, not a skip: `scripts/setup --tests`
installs python3-numpy, python3-opencv and python3-openimageio.
"""

import glob
import json
import os
import shutil
import subprocess
import sys
import tempfile

import cv2
import numpy as np
import OpenImageIO as oiio

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)


PLY_TYPES = {"float": "<f4", "double": "<f8", "int": "<i4", "uint": "<u4", "short": "<i2",
             "ushort": "<u2", "char": "i1", "uchar": "u1"}


def read_ply_scalars(path, wanted):
    """The named element of a binary little-endian PLY whose elements up to it have scalar
    properties only (sylva's skeleton.ply, and mesh.ply's leading vertex element)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    elements = []
    for line in data[:end].decode("ascii").splitlines():
        words = line.split()
        if words[:1] == ["format"]:
            assert words[1] == "binary_little_endian", path
        elif words[:1] == ["element"]:
            elements.append((words[1], int(words[2]), []))
        elif words[:1] == ["property"]:
            elements[-1][2].append((words[-1], words[1]))
    at = end
    for name, count, props in elements:
        if any(t == "list" for _, t in props):
            raise ValueError(f"{path}: list property before element {wanted}")
        dtype = np.dtype([(n, PLY_TYPES[t]) for n, t in props])
        arr = np.frombuffer(data, dtype=dtype, count=count, offset=at)
        if name == wanted:
            return arr
        at += dtype.itemsize * count
    raise KeyError(wanted)


def segment_surface_distance(points, a, b, ra, rb):
    """Distance from each point to the nearest tapered segment surface (axis distance minus the
    radius interpolated at the closest axis point); points (P, 3), segments a, b (S, 3)."""
    best = np.full(len(points), np.inf)
    ab = b - a
    ab2 = np.maximum((ab * ab).sum(1), 1e-300)
    for start in range(0, len(points), 256):
        p = points[start:start + 256, None, :]
        t = np.clip(((p - a[None]) * ab[None]).sum(2) / ab2[None], 0.0, 1.0)
        closest = a[None] + t[..., None] * ab[None]
        d = np.linalg.norm(p - closest, axis=2) - (ra[None] + t * (rb - ra)[None])
        best[start:start + 256] = d.min(1)
    return best


def check_instance(inst):
    name = os.path.basename(inst)
    with open(os.path.join(inst, "transforms.json")) as f:
        tj = json.load(f)

    # --- keys, typed as instant-ngp's loader and nerfstudio's dataparser read them ---
    check(type(tj.get("aabb_scale")) is int and tj["aabb_scale"] == 1, f"{name}: aabb_scale")
    check(type(tj.get("scale")) is float and tj["scale"] > 0, f"{name}: scale")
    off = tj.get("offset")
    check(isinstance(off, list) and len(off) == 3 and all(type(v) is float for v in off),
          f"{name}: offset")
    ids = tj.get("integer_depth_scale")
    check(type(ids) is float and ids > 0, f"{name}: integer_depth_scale")
    check(tj.get("orientation_override") == "none", f"{name}: orientation_override")
    w, h, fx, fy, cx, cy = (tj[k] for k in ("w", "h", "fl_x", "fl_y", "cx", "cy"))
    frames = tj["frames"]
    check(len(frames) == 4, f"{name}: 4 frames")
    for fr in frames:
        for key in ("file_path", "mask_path", "depth_file_path", "depth_path", "label_file_path"):
            check(isinstance(fr.get(key), str) and os.path.isfile(os.path.join(inst, fr[key])),
                  f"{name}: frame {key} names a file")

    # --- every tree point inside instant-ngp's unit cube after p * scale + offset (float32) ---
    nodes = read_ply_scalars(os.path.join(inst, "skeleton.ply"), "vertex")
    edges = read_ply_scalars(os.path.join(inst, "skeleton.ply"), "edge")
    verts = read_ply_scalars(os.path.join(inst, "mesh.ply"), "vertex")
    pos = np.stack([nodes["x"], nodes["y"], nodes["z"]], 1).astype(np.float64)
    rad = nodes["radius"].astype(np.float64)
    pts = [pos + s * rad[:, None] * np.eye(3)[a] for a in range(3) for s in (-1, 1)]
    pts.append(np.stack([verts["x"], verts["y"], verts["z"]], 1).astype(np.float64))
    pts = np.concatenate(pts).astype(np.float32)
    cube = pts * np.float32(tj["scale"]) + np.array(off, np.float32)
    check(cube.min() >= 0 and cube.max() <= 1,
          f"{name}: tree points in the unit cube (got {cube.min(0)} to {cube.max(0)})")
    check((cube.max(0) - cube.min(0)).max() > 0.5, f"{name}: the tree fills the cube")

    # The renderer's depth pixels, back-projected in the build.
    points = read_ply_scalars(os.path.join(inst, "points.ply"), "vertex")
    seg_a = pos[edges["vertex1"]]
    seg_b = pos[edges["vertex2"]]
    seg_ra = rad[edges["vertex1"]]
    seg_rb = rad[edges["vertex2"]]

    ray_length_misses = 0
    for v, fr in enumerate(frames):
        exr = os.path.join(inst, fr["depth_file_path"])
        cv = cv2.imread(exr, cv2.IMREAD_ANYDEPTH)
        check(cv is not None and cv.dtype == np.float32 and cv.shape == (h, w),
              f"{name} view {v}: OpenCV reads one float32 channel of {h}x{w}")
        inp = oiio.ImageInput.open(exr)
        spec = inp.spec()
        oi = inp.read_image("float")
        inp.close()
        check(tuple(spec.channelnames) == ("Y",), f"{name} view {v}: OIIO channel {spec.channelnames}")
        check(oi.shape == (h, w, 1) and np.array_equal(oi[:, :, 0].view(np.uint32), cv.view(np.uint32)),
              f"{name} view {v}: OpenCV and OpenImageIO read the same bits")
        hit = cv > 0
        check(hit.sum() > 20 and (~hit).sum() > 20, f"{name} view {v}: tree and background")

        # Against the renderer's buffer: OpenCV's depth back-projected as nerfstudio does.
        m = np.array(fr["transform_matrix"], np.float64)
        ys, xs = np.nonzero(hit)  # row-major, as points.ply
        d = cv[ys, xs].astype(np.float64)
        cam = np.stack([(xs + 0.5 - cx) / fx, -(ys + 0.5 - cy) / fy, -np.ones_like(d)], 1)
        world = m[:3, 3] + (cam * d[:, None]) @ m[:3, :3].T
        mine = points[points["view"] == v]
        ref = np.stack([mine["x"], mine["y"], mine["z"]], 1).astype(np.float64)
        check(len(ref) == len(world), f"{name} view {v}: {len(world)} depth pixels, {len(ref)} points")
        if len(ref) == len(world):
            err = np.abs(ref - world).max()
            check(err < 1e-5 * max(1.0, d.max()), f"{name} view {v}: OpenCV depth vs renderer {err} m")

        # Wood pixels land on the skeleton's tubes (z-depth); as ray length they would not.
        labels = cv2.imread(os.path.join(inst, fr["label_file_path"]), cv2.IMREAD_UNCHANGED)
        wood = (labels[ys, xs] > 0) & (labels[ys, xs] < 255)
        footprint = d / fx
        surf = segment_surface_distance(world[wood], seg_a, seg_b, seg_ra, seg_rb)
        tol = 1.5 * footprint[wood] + 1e-4
        check(wood.sum() > 10 and (surf <= tol).all(),
              f"{name} view {v}: wood pixels on the tubes (worst {np.max(surf - tol, initial=0)} m over)")
        ray = m[:3, 3] + (cam / np.linalg.norm(cam, axis=1)[:, None] * d[:, None]) @ m[:3, :3].T
        ray_length_misses += int((segment_surface_distance(ray[wood], seg_a, seg_b, seg_ra, seg_rb) > tol).sum())

        # The PNG: uint16, round(depth / integer_depth_scale), 0 off the tree.
        png = cv2.imread(os.path.join(inst, fr["depth_path"]), cv2.IMREAD_ANYDEPTH)
        check(png is not None and png.dtype == np.uint16 and png.shape == (h, w),
              f"{name} view {v}: OpenCV reads the PNG as uint16 {h}x{w}")
        want = np.where(hit, np.floor(cv.astype(np.float64) / ids + 0.5), 0).astype(np.uint16)
        check(np.array_equal(png, want), f"{name} view {v}: PNG = round(depth / scale)")

        mask = cv2.imread(os.path.join(inst, fr["mask_path"]), cv2.IMREAD_UNCHANGED)
        check(mask.dtype == np.uint8 and mask.shape == (h, w) and (mask[hit] > 0).all(),
              f"{name} view {v}: the mask is a single-channel image covering every depth pixel")
    check(ray_length_misses > 0, f"{name}: reading depth as ray length must miss the tubes somewhere")


def main():
    exe, src = sys.argv[1], sys.argv[2]
    tmp = tempfile.mkdtemp(prefix="sylva_depth_nerf_")
    try:
        out = os.path.join(tmp, "out")
        subprocess.run([exe, "build", os.path.join(src, "tests/data/nerf_dataset.toml"), "--out", out,
                        "--threads", "2"], check=True, stdout=subprocess.DEVNULL)
        instances = sorted(glob.glob(os.path.join(out, "trees", "*", "*")))
        check(len(instances) == 3, f"3 instances built (got {len(instances)})")
        for inst in instances:
            check_instance(inst)
        # ZIP-compressed depth: the same pixels, as OpenCV (nerfstudio's reader) decodes them.
        with open(os.path.join(src, "tests/data/nerf_dataset.toml")) as f:
            text = f.read()
        text = text.replace('file = "tiny.toml"', 'file = "%s"' % os.path.join(src, "tests/data/tiny.toml"))
        text = text.replace("depth = true\n", 'depth = true\ndepth_compression = "zip"\n', 1)
        check('depth_compression = "zip"' in text, "the ZIP spec carries the key")
        zspec = os.path.join(tmp, "zip.toml")
        with open(zspec, "w") as f:
            f.write(text)
        zout = os.path.join(tmp, "zip")
        subprocess.run([exe, "build", zspec, "--out", zout, "--threads", "2"], check=True,
                       stdout=subprocess.DEVNULL)
        exrs = sorted(glob.glob(os.path.join(out, "trees", "*", "*", "views", "*_depth.exr")))
        check(len(exrs) == 12, f"12 depth maps (got {len(exrs)})")
        for exr in exrs:
            other = os.path.join(zout, os.path.relpath(exr, out))
            a = cv2.imread(exr, cv2.IMREAD_ANYDEPTH)
            b = cv2.imread(other, cv2.IMREAD_ANYDEPTH)
            inp = oiio.ImageInput.open(other)
            compression = inp.spec().get_string_attribute("compression")
            inp.close()
            check(compression == "zip", f"{other}: compression {compression!r}")
            check(a is not None and b is not None and a.shape == b.shape and
                  np.array_equal(a.view(np.uint32), b.view(np.uint32)) and (a > 0).sum() > 20,
                  f"{other}: OpenCV reads the RLE build's bits")
            check(os.path.getsize(other) < os.path.getsize(exr), f"{other}: smaller than RLE")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if failures:
        print(f"{len(failures)} failure(s)")
        sys.exit(1)
    print("ok: OpenCV", cv2.__version__, "OpenImageIO", oiio.__version__)


if __name__ == "__main__":
    main()
