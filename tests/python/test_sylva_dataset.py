#!/usr/bin/python3
"""Test of the sylva_dataset package (python/) from a clean install, as a user gets it.

The driver (Debian's /usr/bin/python3, standard library only):
  1. builds tests/data/tiny_dataset.toml with the given sylva executable (24 trees, every output);
  2. makes a virtual environment (python3 -m venv --system-site-packages, so Debian's numpy,
     OpenImageIO and torch are visible) in a temporary directory;
  3. installs a copy of python/ into it (pip --no-build-isolation --no-index: offline, Debian's
     setuptools) and runs this file's checks with the venv's interpreter (--checks): only the
     installed package is importable, so a module left out of the package fails here;
  4. reinstalls python/ itself in editable mode (pip install -e, the documented command) and
     checks that every module imports from the source tree.

The checks read the dataset back and compare with the files and with independent readers:
counts, dtypes and shapes against the manifest's stats; skeleton positions against bytes
unpacked by hand from skeleton.ply and against skeleton.swc (text); parents against the SWC's
parent column; the GLB and OBJ of each mesh against its PLY; depth views bit for bit against
OpenImageIO and equal to OpenCV's read; depth, cameras and the point cloud against each other
(each point, projected with its view's transform_matrix and intrinsics, lands on a pixel centre
at the depth the map holds);
the EXR reader on files OpenImageIO writes with every compression; GLBs whose leaves are GPU
instances against the plain GLBs of the same trees; the PyTorch datasets through a DataLoader.

A missing dependency (numpy, OpenImageIO, OpenCV, torch, venv, setuptools, wheel) is a failure, not a skip:
`scripts/setup --tests` (run by scripts/test) installs them all, and a skip would hide a broken
setup from CI. The one exception: where the archive has no python3-torch (some architectures),
the PyTorch datasets are not tested, and the test says so.

Usage: test_sylva_dataset.py SYLVA_EXE SOURCE_DIR
"""

import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
# Debian packages the checks need; scripts/setup installs each.
NEEDED = [("numpy", "python3-numpy"), ("OpenImageIO", "python3-openimageio"), ("cv2", "python3-opencv"),
          ("torch", "python3-torch"), ("ensurepip", "python3-venv"),
          ("setuptools", "python3-setuptools"), ("wheel", "python3-wheel")]

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)


# --- driver ---------------------------------------------------------------------------------------


def run(cmd, **kw):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kw)
    if r.returncode != 0:
        print("$ %s\n%s" % (" ".join(cmd), r.stdout))
        raise SystemExit("test_sylva_dataset: the command above failed (exit %d)" % r.returncode)
    return r.stdout


def in_archive(package):
    """Whether apt could install the package here (scripts/setup skips python3-torch where the
    archive has none: Debian 12 builds it for some architectures only)."""
    try:
        r = subprocess.run(["apt-cache", "policy", package], stdout=subprocess.PIPE, text=True)
    except OSError:
        return True
    return any(line.strip().startswith("Candidate:") and line.split()[-1] != "(none)"
               for line in r.stdout.splitlines())


def driver(exe, src):
    missing, with_torch = [], True
    for module, package in NEEDED:
        try:
            __import__(module)
        except ImportError:
            if module == "torch" and not in_archive(package):
                print("test_sylva_dataset: %s is not in this machine's archive: the PyTorch "
                      "datasets are not tested here" % package)
                with_torch = False
            else:
                missing.append(package)
    if missing:
        print("test_sylva_dataset: %s missing for %s: scripts/setup --tests installs them "
              "(apt-get install -y %s)" % (", ".join(missing), sys.executable, " ".join(missing)))
        return 1
    tmp = tempfile.mkdtemp(prefix="sylva_pytest_")
    env = dict(os.environ, PIP_DISABLE_PIP_VERSION_CHECK="1", PYTHONNOUSERSITE="1",
               PIP_NO_INPUT="1")
    try:
        data = os.path.join(tmp, "ds")
        run([exe, "build", os.path.join(src, "tests/data/tiny_dataset.toml"), "--out", data,
             "--threads", "2"])
        venv = os.path.join(tmp, "venv")
        run([sys.executable, "-m", "venv", "--system-site-packages", venv])
        py, pip = os.path.join(venv, "bin", "python"), [os.path.join(venv, "bin", "python"), "-m", "pip"]
        pip_install = pip + ["install", "--no-build-isolation", "--no-index"]
        # A regular install of a copy (so the source tree gets no build/ or egg-info litter).
        copy = os.path.join(tmp, "pkg")
        shutil.copytree(os.path.join(src, "python"), copy)
        run(pip_install + [copy], env=env)
        r = subprocess.run([py, os.path.abspath(__file__), "--checks", exe, src, data, tmp,
                            "torch" if with_torch else "no-torch"],
                           cwd=tmp, env=env)
        if r.returncode != 0:
            return 1
        # The documented editable install: every module from the source tree.
        run(pip_install + ["-e", os.path.join(src, "python")], env=env)
        probe = ("import json, sylva_dataset, sylva_dataset.exr as p, importlib.metadata as m;"
                 "print(json.dumps([sylva_dataset.__file__, p.__file__, sylva_dataset.__version__,"
                 " m.version('sylva-dataset')]))")
        init, module, version, dist = json.loads(run([py, "-c", probe], cwd=tmp, env=env))
        pkg = os.path.realpath(os.path.join(src, "python", "sylva_dataset"))
        check(os.path.realpath(init) == os.path.join(pkg, "__init__.py")
              and os.path.realpath(module) == os.path.join(pkg, "exr.py"),
              "editable install imports from the source tree: %s, %s" % (init, module))
        check(version == dist, "__version__ %s = the installed distribution's %s" % (version, dist))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if failures:
        print("%d failure(s)" % len(failures))
        return 1
    print("sylva_dataset: all checks passed (installed copy and editable install)")
    return 0


# --- checks (inside the venv) ---------------------------------------------------------------------


def png_bytes(np, rows, channels, filters, depth=8):
    """Encodes rows of bytes (H, W*channels*depth/8; 16-bit samples big-endian) with the given
    per-row filter types."""
    h, stride = rows.shape
    bpp = channels * depth // 8
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

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", stride // bpp, h, depth, ctype, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(bytes(out))) + chunk(b"IEND", b""))


def test_png_filters(np, sd, tmp):
    rng = np.random.RandomState(3)
    for channels in (1, 2, 3, 4):
        img = rng.randint(0, 256, size=(7, 5 * channels)).astype(np.uint8)
        p = os.path.join(tmp, "f%d.png" % channels)
        with open(p, "wb") as f:
            f.write(png_bytes(np, img, channels, [0, 1, 2, 3, 4]))
        got = sd.read_png(p)
        want = img if channels == 1 else img.reshape(7, 5, channels)
        check(got.shape == want.shape and (got == want).all(), "PNG filters 0-4, %d channel(s)" % channels)
        img16 = rng.randint(0, 65536, size=(6, 4 * channels)).astype(">u2")
        with open(p, "wb") as f:
            f.write(png_bytes(np, img16.view(np.uint8).reshape(6, -1), channels, [0, 1, 2, 3, 4], 16))
        got = sd.read_png(p)
        want = img16.astype(np.uint16) if channels == 1 else img16.astype(np.uint16).reshape(6, 4, channels)
        check(got.dtype == np.uint16 and got.shape == want.shape and (got == want).all(),
              "16-bit PNG filters 0-4, %d channel(s)" % channels)


def test_png16_opencv_and_depth_png(np, sd, cv2, tmp):
    """16-bit grey PNGs written by OpenCV (its own filter choices) read back equal, and an
    instance with depth PNGs only (instant-ngp's depth_path) gives value × integer_depth_scale."""
    rng = np.random.RandomState(9)
    depth = rng.randint(0, 65536, size=(19, 23)).astype(np.uint16)
    depth[3:8] = 0
    views = os.path.join(tmp, "inst", "views")
    os.makedirs(views)
    frames = []
    for k in range(2):
        name = "%03d_depth.png" % k
        check(cv2.imwrite(os.path.join(views, name), depth + k), "cv2 writes a 16-bit PNG")
        frames.append({"file_path": "views/%03d.png" % k, "depth_path": "views/" + name})
        got = sd.read_png(os.path.join(views, name))
        check(got.dtype == np.uint16 and np.array_equal(got, cv2.imread(os.path.join(views, name),
                                                                        cv2.IMREAD_UNCHANGED)),
              "16-bit PNG %d equals OpenCV's read" % k)
    with open(os.path.join(tmp, "inst", "transforms.json"), "w") as f:
        json.dump({"integer_depth_scale": 0.002, "frames": frames}, f)
    inst = sd.Instance(tmp, {"id": "png-only", "species": "x", "files": {"transforms": "inst/transforms.json"}})
    d = inst.depths()
    check(len(d) == 2 and all(x.dtype == np.float32 and np.array_equal(x, ((depth + k) * 0.002).astype(np.float32))
                              for k, x in enumerate(d)), "depths() from depth PNGs × integer_depth_scale")


def test_ply_mixed_lists(sd, tmp):
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


def test_exr_compressions(np, sd, oiio, tmp):
    """EXRs written by OpenImageIO (OpenEXR) with mixed channel types, read by sylva_dataset's
    own decoder (none, rle, zips, zip) and its OpenImageIO fallback (piz), bit for bit."""
    rng = np.random.RandomState(5)
    w, h = 37, 21  # odd sizes, a ZIP block of 16 lines plus a short one
    pixels = (rng.rand(h, w, 3) * 10).astype(np.float32)
    pixels[5:9] = 0  # runs for RLE
    for comp in ("none", "rle", "zips", "zip", "piz"):
        p = os.path.join(tmp, "c_%s.exr" % comp)
        spec = oiio.ImageSpec(w, h, 3, oiio.FLOAT)
        spec.channelnames = ("depth", "B", "Y")
        spec.channelformats = (oiio.TypeDesc("half"), oiio.TypeDesc("float"), oiio.TypeDesc("uint"))
        spec.attribute("compression", comp)
        out = oiio.ImageOutput.create(p)
        out.open(p, spec)
        out.write_image(pixels)
        out.close()
        got = sd.read_exr(p)
        inp = oiio.ImageInput.open(p)
        names = list(inp.spec().channelnames)
        kinds = [str(f) for f in inp.spec().channelformats]
        native = comp != "piz"  # piz goes through OpenImageIO: every channel as float32
        refs = [inp.read_image(0, 0, c, c + 1, kinds[c] if native else "float")[:, :, 0]
                for c in range(len(names))]
        inp.close()
        check(list(got) == names == ["B", "Y", "depth"], "EXR %s channel order %r" % (comp, list(got)))
        for name, ref in zip(names, refs):
            g = got.get(name)
            check(g is not None and g.dtype == ref.dtype and g.shape == (h, w)
                  and np.array_equal(g.view(np.uint8), ref.view(np.uint8)),
                  "EXR %s channel %s equals OpenImageIO's (%s)" % (comp, name, kinds[names.index(name)]))
        first = sd.read_exr_first_channel(p)
        check(first.dtype == np.float32 and np.array_equal(first, refs[0].astype(np.float32)),
              "EXR %s first channel" % comp)


def test_obj_general(np, sd, tmp):
    """An OBJ with a quad, negative indices, v//vn corners and a g group: the general path."""
    p = os.path.join(tmp, "general.obj")
    with open(p, "w") as f:
        f.write("# test\nmtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 1.0\n"
                "vn 0 0 1\ng leaves\nusemtl leaf\nv 0 0 1\nf 1//1 2//1 3//1 4//1\nf -1//1 1//1 2//1\n")
    m = sd.read_obj(p)
    check(m.positions.shape == (5, 3) and m.positions[4].tolist() == [0, 0, 1], "OBJ positions (w dropped)")
    check(m.faces.tolist() == [[0, 1, 2], [0, 2, 3], [4, 0, 1]], "OBJ quad fan and negative index: %r" % m.faces.tolist())
    check(m.uvs is None and m.normals is not None and m.normals[4].tolist() == [0, 0, 1], "OBJ v//vn")
    check(m.part.tolist() == [0, 0, 0, 0, 1], "OBJ part from the 'leaves' group")


def test_glb_transform(np, sd, tmp):
    """A hand-made GLB: one triangle under a node translated by (1, 2, 3) and scaled by 2."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4")
    idx = np.array([0, 2, 1], "<u2")
    binary = pos.tobytes() + idx.tobytes() + b"\0\0"
    gltf = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
            "nodes": [{"children": [1], "translation": [1, 2, 3]}, {"mesh": 0, "scale": [2, 2, 2]}],
            "meshes": [{"name": "leaves", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
            "buffers": [{"byteLength": len(binary)}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                          {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]}
    js = json.dumps(gltf).encode()
    js += b" " * (-len(js) % 4)
    body = struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(binary), b"BIN\0") + binary
    p = os.path.join(tmp, "t.glb")
    with open(p, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)
    m = sd.read_glb(p)
    check(m.positions.tolist() == [[1, 2, 3], [3, 2, 3], [1, 4, 3]], "GLB node transforms: %r" % m.positions.tolist())
    check(m.faces.tolist() == [[0, 2, 1]] and m.part.tolist() == [1, 1, 1], "GLB faces (uint16) and part")
    # A compressed file is refused by name, not misread.
    for codec in ("KHR_draco_mesh_compression", "EXT_meshopt_compression"):
        js = json.dumps(dict(gltf, extensionsUsed=[codec])).encode()
        js += b" " * (-len(js) % 4)
        body = struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(binary), b"BIN\0") + binary
        try:
            sd.read_glb(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body, "c.glb")
            check(False, "a GLB using %s was read" % codec)
        except ValueError as e:
            check(codec in str(e) and "c.glb" in str(e), "the refusal names %s: %s" % (codec, e))


def ply_vertex_bytes(path):
    """skeleton.ply's vertex records unpacked by hand (x y z radius: float, order: int, part:
    uchar; little-endian): an independent check of read_ply."""
    with open(path, "rb") as f:
        data = f.read()
    start = data.index(b"end_header\n") + len(b"end_header\n")
    n = int(data[:start].split(b"element vertex ")[1].split(b"\n")[0])
    return [struct.unpack_from("<4fiB", data, start + 21 * k) for k in range(n)]


def read_swc(path):
    rows = []
    with open(path) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                rows.append([float(x) for x in line.split()])
    return rows


def plain(np, a, dtype, shape, what):
    check(a is not None and a.dtype == np.dtype(dtype) and a.shape == shape and a.flags.c_contiguous
          and a.dtype.isnative, "%s: C-contiguous native %s %r, got %s" % (
              what, dtype, shape, None if a is None else (a.dtype, a.shape, a.strides)))


def test_dataset(np, sd, oiio, cv2, out):
    ds = sd.Dataset(out)
    check(len(ds) == ds.info["counts"]["instances_in_dataset"] == 24, "instance count %d" % len(ds))
    check(ds.species == ["tiny", "tiny-var"], "species %r" % ds.species)
    check([i.species for i in ds] == ["tiny"] * 12 + ["tiny-var"] * 12, "instance order")
    check(len({i.id for i in ds}) == 24, "unique ids")
    check(len(ds.by_species("tiny")) == 12, "by_species")
    first = ds[0]
    check(ds[first.id].id == first.id, "lookup by id")
    views = ds.info["spec"]["views"]
    w, h, nv = views["resolution"][0], views["resolution"][1], views["count"]
    leaves_seen = 0
    for inst in ds:
        st = inst.stats
        # Skeleton: plain arrays, values as in the file's bytes and the SWC.
        sk = inst.skeleton()
        n = st["nodes"]
        plain(np, sk.positions, "float32", (n, 3), inst.id + " skeleton positions")
        plain(np, sk.radii, "float32", (n,), inst.id + " skeleton radii")
        plain(np, sk.parents, "int64", (n,), inst.id + " skeleton parents")
        plain(np, sk.edges, "int64", (st["segments"], 2), inst.id + " skeleton edges")
        plain(np, sk.order, "int64", (n,), inst.id + " skeleton order")
        check(sk.radius is sk.radii, "radius is radii")
        raw = ply_vertex_bytes(inst.path("skeleton_ply"))
        check(len(raw) == n and all(tuple(sk.positions[k]) == raw[k][:3] and sk.radii[k] == raw[k][3]
                                    and sk.order[k] == raw[k][4] and sk.part[k] == raw[k][5]
                                    for k in (0, 1, n // 2, n - 1)),
              "%s skeleton nodes 0, 1, N/2, N-1 equal skeleton.ply's bytes" % inst.id)
        check(sk.positions[0].tolist() == [0, 0, 0], "%s root node at the origin" % inst.id)
        swc = np.array(read_swc(inst.path("skeleton_swc")))
        check(swc.shape == (n, 7) and np.allclose(swc[:, 2:5], sk.positions, rtol=1e-5, atol=1e-6)
              and np.allclose(swc[:, 5], sk.radii, rtol=1e-5, atol=1e-7),
              "%s positions and radii agree with skeleton.swc" % inst.id)
        swc_parent = swc[:, 6].astype(np.int64)
        check(sk.parents[0] == -1 and np.array_equal(np.where(swc_parent < 0, -1, swc_parent - 1), sk.parents),
              "%s parents equal the SWC's parent column" % inst.id)
        # Meshes: every format the manifest lists, each equal to the PLY.
        for kind, nvert, ntri in (("mesh", st["mesh_vertices"], st["mesh_triangles"]),
                                  ("watertight", st["watertight_vertices"], st["watertight_triangles"])):
            fmts = inst.mesh_formats(kind)
            check(fmts == ["ply", "glb", "obj"], "%s %s formats %r" % (inst.id, kind, fmts))
            ref = inst.mesh(kind)
            for fmt in fmts:
                m = inst.mesh(kind, fmt)
                what = "%s %s.%s" % (inst.id, kind, fmt)
                plain(np, m.positions, "float32", (nvert, 3), what + " positions")
                plain(np, m.faces, "int64", (ntri, 3), what + " faces")
                plain(np, m.normals, "float32", (nvert, 3), what + " normals")
                plain(np, m.uvs, "float32", (nvert, 2), what + " uvs")
                plain(np, m.part, "int64", (nvert,), what + " part")
                if fmt != "obj":
                    plain(np, m.order, "int64", (nvert,), what + " order")
                    check(np.array_equal(m.order, ref.order), what + " order equals the PLY's")
                check(m.faces.min() >= 0 and m.faces.max() < nvert, what + " face indices")
                check(np.array_equal(m.positions, ref.positions) and np.array_equal(m.faces, ref.faces)
                      and np.array_equal(m.normals, ref.normals) and np.array_equal(m.uvs, ref.uvs)
                      and np.array_equal(m.part, ref.part), what + " equals the PLY")
            leaves_seen += int((ref.part == 1).sum()) if kind == "mesh" else 0
        glb = inst.mesh("glb")  # the KeyError: 'glb_ply'
        check(len(glb.positions) == st["mesh_vertices"], "%s inst.mesh('glb')" % inst.id)
        with open(inst.path("mesh_obj")) as f:
            check(sum(1 for line in f if line.startswith("v ")) == st["mesh_vertices"],
                  "%s mesh.obj 'v' lines" % inst.id)
        # Views.
        cams = inst.cameras()
        check(len(cams["frames"]) == nv, "%s camera count" % inst.id)
        masks, labels, depths = inst.masks(), inst.labels(), inst.depths()
        check(len(masks) == len(labels) == len(depths) == nv == len(st["silhouette_coverage"]),
              "%s view counts" % inst.id)
        base = os.path.dirname(inst.path("transforms"))
        for k, (mask, label, depth) in enumerate(zip(masks, labels, depths)):
            check(mask.shape == (h, w) and mask.dtype == np.uint8, "%s mask %d shape %r" % (inst.id, k, mask.shape))
            check(set(np.unique(mask)) <= {0, 255}, "%s mask %d values" % (inst.id, k))
            cov = float((mask == 255).sum()) / (w * h)
            check(abs(cov - st["silhouette_coverage"][k]) < 1e-12,
                  "%s mask %d coverage %g vs %g" % (inst.id, k, cov, st["silhouette_coverage"][k]))
            check(((label > 0) == (mask > 0)).all(), "%s labels %d cover exactly the silhouette" % (inst.id, k))
            plain(np, depth, "float32", (h, w), "%s depth %d" % (inst.id, k))
            inp = oiio.ImageInput.open(os.path.join(base, cams["frames"][k]["depth_file_path"]))
            ref = inp.read_image(0, 0, 0, 1, "float")[:, :, 0]
            inp.close()
            check(np.array_equal(depth.view(np.uint32), ref.view(np.uint32)),
                  "%s depth %d equals OpenImageIO's read, bit for bit" % (inst.id, k))
            cv = cv2.imread(os.path.join(base, cams["frames"][k]["depth_file_path"]), cv2.IMREAD_ANYDEPTH)
            check(cv is not None and np.array_equal(depth, cv),
                  "%s depth %d equals OpenCV's read (what nerfstudio calls)" % (inst.id, k))
            check(((depth > 0) == (mask == 255)).all() and (depth >= 0).all(),
                  "%s depth %d: > 0 exactly on the silhouette" % (inst.id, k))
        # The point cloud is the depth maps back-projected, in view then row-major pixel order.
        pc = inst.points()
        total = sum(int((d > 0).sum()) for d in depths)
        plain(np, pc.positions, "float32", (total, 3), inst.id + " points")
        plain(np, pc.labels, "int64", (total,), inst.id + " point labels")
        check(np.array_equal(pc.labels, np.concatenate([l[d > 0] for l, d in zip(labels, depths)])),
              "%s point labels equal the label views" % inst.id)
        for k, fr in enumerate(cams["frames"]):
            w2c = np.linalg.inv(np.array(fr["transform_matrix"], np.float64))
            p = pc.positions[pc.views == k].astype(np.float64) @ w2c[:3, :3].T + w2c[:3, 3]
            rows, cols = np.nonzero(depths[k] > 0)
            u = cams["cx"] + cams["fl_x"] * p[:, 0] / -p[:, 2]
            v = cams["cy"] - cams["fl_y"] * p[:, 1] / -p[:, 2]
            check(len(p) == len(rows) and np.abs(-p[:, 2] - depths[k][rows, cols]).max() < 1e-4
                  and np.abs(u - (cols + 0.5)).max() < 1e-3 and np.abs(v - (rows + 0.5)).max() < 1e-3,
                  "%s view %d: points project to their pixel centres at the depth map's depth" % (inst.id, k))
    check(leaves_seen > 0, "the dataset has leaf vertices (part 1) to compare")
    # Errors name what is missing.
    bare = sd.Instance(out, {"id": "x", "species": "tiny", "files": {"mesh_ply": "m.ply"}})
    try:
        bare.mesh("obj")
        check(False, "a format the manifest does not list raises KeyError")
    except KeyError as e:
        check("mesh_obj" in str(e) and "mesh_ply" in str(e), "KeyError names the key and those present: %s" % e)


def test_plot_dataset(np, sd, exe, src, tmp):
    """A plot dataset (tests/data/scan/uls_plot.toml, one plot scanned): its instance is a plot
    in plots/<plot>/<id>, and it has no tree species of its own in the manifest."""
    data = os.path.join(tmp, "plot_ds")
    run([exe, "build", os.path.join(src, "tests/data/scan/uls_plot.toml"), "--out", data])
    ds = sd.Dataset(data)
    check(len(ds) == 1, "one plot instance: %d" % len(ds))
    check(ds.species == [], "a plot dataset lists no tree species: %r" % (ds.species,))
    check(ds.plots == ["stand"], "its plot: %r" % (ds.plots,))
    inst = ds[0]
    check(inst.kind == "plot" and inst.plot == "stand" and inst.species is None,
          "the instance is the plot: %r" % (inst,))
    check(inst.dir == os.path.join(ds.root, "plots", "stand", inst.id)
          and os.path.isfile(os.path.join(inst.dir, "plot.json")),
          "the plot's directory holds plot.json: %s" % inst.dir)
    check(os.path.dirname(inst.path("scan_las")) == inst.dir, "scan.las in the plot's directory")


def test_leaf_instances(np, sd, exe, src, tmp):
    """read_glb on GLBs whose leaves are GPU instances ([outputs] leaf_instances,
    tests/data/keys/dataset-leaf-instances.toml) gives each tree's plain GLB (the same spec
    without leaf_instances): the same vertices in the same order, faces, UVs and attributes."""
    keys = os.path.join(src, "tests", "data", "keys")
    spec = os.path.join(keys, "dataset-leaf-instances.toml")
    inst, plain = os.path.join(tmp, "inst_ds"), os.path.join(tmp, "inst_plain_ds")
    run([exe, "build", spec, "--out", inst])
    with open(spec) as f:
        text = f.read()
    plain_spec = os.path.join(tmp, "inst_plain.toml")
    with open(plain_spec, "w") as f:
        f.write(text.replace("leaf_instances = true\n", "")
                .replace('file = "', 'file = "%s/' % keys))
    run([exe, "build", plain_spec, "--out", plain])
    meshes = 0
    for inst_i, plain_i in zip(sd.Dataset(inst), sd.Dataset(plain)):
        a, b = inst_i.mesh("glb"), plain_i.mesh("glb")
        meshes += 1
        check(a.positions.shape == b.positions.shape and
              np.abs(a.positions - b.positions).max() < 2e-5,
              "%s: instanced leaves' positions" % inst_i.id)
        check(np.array_equal(a.faces, b.faces), "%s: instanced leaves' faces" % inst_i.id)
        check(np.abs(a.normals - b.normals).max() < 1e-5, "%s: normals" % inst_i.id)
        for field in ("uvs", "order", "part", "colour"):
            check(np.array_equal(getattr(a, field), getattr(b, field)),
                  "%s: instanced leaves' %s" % (inst_i.id, field))
        check((a.part == 1).sum() > 0, "%s: has leaves" % inst_i.id)
    check(meshes == 3, "three instanced meshes read: %d" % meshes)


def test_torch(np, sd, out):
    import torch
    from sylva_dataset.pytorch import TreeDataset, ViewDataset

    check(sd.torch_available(), "torch_available()")
    ds = sd.Dataset(out)
    trees = TreeDataset(out, fields=("skeleton", "mesh", "points", "views"), species=["tiny-var"])
    check(len(trees) == 12, "TreeDataset species filter: %d" % len(trees))
    item = trees[3]
    inst = ds[item["id"]]
    sk, m = inst.skeleton(), inst.mesh()
    for key, ref, dtype in (("positions", sk.positions, torch.float32), ("radii", sk.radii, torch.float32),
                            ("parents", sk.parents, torch.int64), ("edges", sk.edges, torch.int64),
                            ("mesh_positions", m.positions, torch.float32),
                            ("mesh_faces", m.faces, torch.int64),
                            ("point_positions", inst.points().positions, torch.float32),
                            ("depths", np.stack(inst.depths()), torch.float32),
                            ("labels", np.stack(inst.labels()).astype(np.int64), torch.int64),
                            ("masks", np.stack(inst.masks()), torch.uint8)):
        t = item.get(key)
        check(t is not None and t.dtype == dtype and np.array_equal(t.numpy(), ref),
              "TreeDataset %s: %s equal to the numpy reader" % (key, dtype))
    check(tuple(item["c2w"].shape) == (4, 4, 4) and tuple(item["K"].shape) == (4, 3, 3),
          "TreeDataset cameras (V, 4, 4) and (V, 3, 3)")
    check(np.allclose(item["c2w"][2].numpy(), np.array(inst.cameras()["frames"][2]["transform_matrix"])),
          "TreeDataset c2w equals transforms.json")
    trees_loader = torch.utils.data.DataLoader(trees, batch_size=None, shuffle=False)
    check(sum(1 for _ in trees_loader) == 12, "TreeDataset through a DataLoader (batch_size=None)")

    views = ViewDataset(out)
    nv = ds.info["spec"]["views"]["count"]
    check(len(views) == 24 * nv, "ViewDataset length %d" % len(views))
    loader = torch.utils.data.DataLoader(views, batch_size=nv, shuffle=False)
    batch = next(iter(loader))
    w, h = ds.info["spec"]["views"]["resolution"]
    check(tuple(batch["depth"].shape) == (nv, h, w) and batch["depth"].dtype == torch.float32
          and batch["mask"].dtype == torch.uint8 and batch["labels"].dtype == torch.int64
          and tuple(batch["c2w"].shape) == (nv, 4, 4) and tuple(batch["K"].shape) == (nv, 3, 3),
          "ViewDataset default collation: %r" % {k: tuple(v.shape) for k, v in batch.items() if hasattr(v, "shape")})
    check(list(batch["id"]) == [ds[0].id] * nv and batch["view"].tolist() == list(range(nv)),
          "ViewDataset order: instance then view")
    check(np.array_equal(batch["depth"].numpy(), np.stack(ds[0].depths()))
          and np.array_equal(batch["mask"].numpy(), np.stack(ds[0].masks())),
          "ViewDataset batch equals the numpy reader")


def checks(exe, src, out, tmp, torch):
    import numpy as np
    import OpenImageIO as oiio
    import cv2
    import sylva_dataset as sd

    check("torch" not in sys.modules, "importing sylva_dataset does not import torch")
    check(os.path.realpath(sd.__file__).startswith(os.path.realpath(sys.prefix)),
          "sylva_dataset imported from the venv's install: %s" % sd.__file__)
    check(not sd.__file__.startswith(os.path.realpath(os.path.join(src, "python"))),
          "not from the source tree")
    test_png_filters(np, sd, tmp)
    test_ply_mixed_lists(sd, tmp)
    test_png16_opencv_and_depth_png(np, sd, cv2, tmp)
    test_exr_compressions(np, sd, oiio, tmp)
    test_obj_general(np, sd, tmp)
    test_glb_transform(np, sd, tmp)
    test_dataset(np, sd, oiio, cv2, out)
    test_plot_dataset(np, sd, exe, src, tmp)
    test_leaf_instances(np, sd, exe, src, tmp)
    if torch == "torch":
        test_torch(np, sd, out)
    else:
        check(not sd.torch_available(), "torch_available() is False without torch")
    if failures:
        print("%d failure(s) in the installed package" % len(failures))
        return 1
    return 0


def main():
    if len(sys.argv) == 7 and sys.argv[1] == "--checks":
        return checks(*sys.argv[2:7])
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    return driver(os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2]))


if __name__ == "__main__":
    sys.exit(main())
