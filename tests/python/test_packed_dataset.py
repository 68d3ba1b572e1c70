#!/usr/bin/python3
"""Test of packed datasets ([outputs] pack = "tar", docs/outputs.md "Packed datasets: tar
shards") and of the sylva_dataset package reading them (python/, from the source tree).

Builds tests/data/tiny_dataset_packed.toml (24 trees in tar shards of 5) and
tests/data/tiny_dataset.toml (the same spec unpacked) with the given sylva executable, then
checks:
  - the shards against the documented layout, read by Python's tarfile (a reader independent of
    the package): member names ID.<path with "/" as ".">, a sample's members contiguous and in
    byte order, instances in position order, ustar headers (mode 0644, owner 0/0, mtime 0), the
    end of the archive; every member equal to the unpacked file with its references to the
    instance's files renamed to member names (JSON strings, OBJ mtllib, MTL map_*), byte for byte
    otherwise; ID.json equal to the manifest record without timing; the sidecar
    NNNNNN.index.json and shards/index.json; the manifest's "pack" and "files"; a build killed
    after 7 records and rerun writing the same shards as an uninterrupted one;
  - every reader of sylva_dataset (skeleton, meshes in PLY / GLB / OBJ, points, cameras, masks,
    labels, depths; colour pictures and scans through in-memory samples) giving identical arrays
    from the packed and the unpacked build, and from the killed build (records whose shard is not
    written yet: from their directories); the sidecar used when valid and ignored when missing
    or describing another tar size; a shard rewritten after it was indexed;
  - TreeDataset and ViewDataset on the packed build equal to the unpacked build's, also in
    DataLoader workers forked after the parent opened the tars; ShardDataset through a
    DataLoader of 2 workers yielding every instance once per epoch, the same items as
    TreeDataset; set_epoch changing the shard order but not the set; the same seed giving the
    same order; the shards of ranks 0 and 1 of 2 disjoint and covering all (also with the
    defaults from a torch.distributed group of two processes); the shuffle buffer; species=.

A missing numpy, OpenCV or torch fails the test (scripts/setup --tests installs them).

Usage: test_packed_dataset.py SYLVA_EXE SOURCE_DIR
"""

import collections
import io
import json
import os
import pickle
import posixpath
import shutil
import subprocess
import sys
import tarfile
import tempfile
import traceback

NEEDED = [("numpy", "python3-numpy"), ("cv2", "python3-opencv"), ("torch", "python3-torch")]
M = 5  # pack_instances in tiny_dataset_packed.toml
failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        print("$ %s\n%s" % (" ".join(cmd), r.stdout))
        raise SystemExit("test_packed_dataset: the command above failed (exit %d)" % r.returncode)
    return r.stdout


def toml_body(path, drop=()):
    """The lines of a TOML file that are not comments or blank, without the keys in `drop`."""
    with open(path) as f:
        lines = [line.strip() for line in f]
    return [line for line in lines if line and not line.startswith("#")
            and line.split("=")[0].strip() not in drop]


def records(root):
    with open(os.path.join(root, "manifest.jsonl")) as f:
        return [json.loads(line) for line in f if line.strip()]


def without(record, *keys):
    return {k: v for k, v in record.items() if k not in keys}


def instance_files(unpacked, record):
    """{path in the instance directory ("views/000.png"): bytes} of an unpacked instance."""
    d = os.path.join(unpacked, "trees", record["species"], record["id"])
    out = {}
    for dirpath, _, names in os.walk(d):
        for name in names:
            p = os.path.join(dirpath, name)
            with open(p, "rb") as f:
                out[os.path.relpath(p, d).replace(os.sep, "/")] = f.read()
    return out


def member_name(iid, rel):
    return iid + "." + rel.replace("/", ".")


def as_member(iid, rel, data, files):
    """An unpacked file as the documented shard member: its references to the instance's other
    files renamed to member names — every string of a JSON naming one (relative to the JSON's
    directory; returned parsed, to be compared parsed), an OBJ's mtllib, an MTL's map_* — and
    every other file byte for byte."""
    def member(ref):
        target = posixpath.normpath(posixpath.join(posixpath.dirname(rel), ref))
        return member_name(iid, target) if target in files else None

    if rel.endswith(".json"):
        def walk(v):
            if isinstance(v, dict):
                return {k: walk(x) for k, x in v.items()}
            if isinstance(v, list):
                return [walk(x) for x in v]
            return (member(v) or v) if isinstance(v, str) else v
        return walk(json.loads(data))
    if not rel.endswith((".obj", ".mtl")):
        return data
    lines = data.split(b"\n")
    for k, line in enumerate(lines):
        key, _, ref = line.decode("utf-8").partition(" ")
        if ref and (key == "mtllib" if rel.endswith(".obj") else key.startswith("map_")):
            m = member(ref.rstrip("\r"))
            if m:
                lines[k] = ("%s %s%s" % (key, m, "\r" if ref.endswith("\r") else "")).encode()
    return b"\n".join(lines)


def member_of(name, data):
    """A member's bytes as as_member gives them: JSON parsed, else bytes."""
    return json.loads(data) if name.endswith(".json") else data


# --- the shards, read by tarfile ------------------------------------------------------------------


def test_layout(packed, unpacked):
    ups, pks = records(unpacked), records(packed)
    check([r["id"] for r in pks] == [r["id"] for r in ups] and len(pks) == 24,
          "the packed manifest lists the unpacked build's 24 instances in order")
    leftover = [os.path.join(d, n) for d, _, names in os.walk(os.path.join(packed, "trees"))
                for n in names]
    check(not leftover, "no instance files left unpacked: %r" % leftover[:3])
    with open(os.path.join(packed, "dataset.json")) as f:
        info = json.load(f)
    nshards = (len(ups) + M - 1) // M
    with open(os.path.join(packed, "shards", "index.json")) as f:
        wids = json.load(f)
    sizes = [os.path.getsize(os.path.join(packed, "shards", "%06d.tar" % k)) for k in range(nshards)]
    check(wids == {"__kind__": "wids-shard-index-v1", "wids_version": 1, "name": info["name"],
                   "shardlist": [{"url": "%06d.tar" % k, "nsamples": min(M, len(ups) - k * M),
                                  "filesize": sizes[k]} for k in range(nshards)]},
          "shards/index.json is the wids-shard-index-v1 of the %d shards: %s" % (nshards, wids))
    check(sorted(n for n in os.listdir(os.path.join(packed, "shards")) if n.endswith(".tar"))
          == ["%06d.tar" % k for k in range(nshards)], "shards/ holds 000000.tar … %06d.tar" % (nshards - 1))

    for pos, (up, pk) in enumerate(zip(ups, pks)):
        iid, prefix = up["id"], "trees/%s/%s/" % (up["species"], up["id"])
        check(pk.get("pack") == "shards/%06d.tar" % (pos // M), "%s: pack %r" % (iid, pk.get("pack")))
        check(pk["files"] == {k: member_name(iid, v[len(prefix):]) for k, v in up["files"].items()},
              "%s: files are member names (views: %r)" % (iid, pk["files"].get("views")))
        check(without(pk, "pack", "files", "timing") == without(up, "files", "timing"),
              "%s: the record's other fields are as unpacked" % iid)

    for k in range(nshards):
        tar_path = os.path.join(packed, "shards", "%06d.tar" % k)
        shard = ups[k * M:(k + 1) * M]
        with open(tar_path, "rb") as f:
            raw = f.read()
        with tarfile.open(tar_path) as tar:
            infos = tar.getmembers()
            data = {ti.name: tar.extractfile(ti).read() for ti in infos}
        expected, want = [], {}
        for up, pk in zip(shard, pks[k * M:(k + 1) * M]):
            iid = up["id"]
            files = instance_files(unpacked, up)
            names = [member_name(iid, rel) for rel in files] + [iid + ".json"]
            expected += sorted(names, key=lambda s: s.encode())
            want.update({member_name(iid, rel): as_member(iid, rel, b, files)
                         for rel, b in files.items()})
            tj = member_name(iid, "transforms.json")
            frames = json.loads(data.get(tj, b"{}")).get("frames")
            check(frames and all(fr.get(key, "").startswith(iid + ".views.") for fr in frames
                                 for key in ("file_path", "mask_path", "depth_file_path",
                                             "label_file_path")),
                  "%s: %s names its frames' files by member name" % (tar_path, tj))
            mtl = data.get(member_name(iid, "mesh.obj"), b"").split(b"\n", 3)[:3]
            check(("mtllib %s.mesh.mtl" % iid).encode() in mtl,
                  "%s: %s.mesh.obj's mtllib names the member %s.mesh.mtl" % (tar_path, iid, iid))
            rec = json.loads(data.get(iid + ".json", b"null"))
            check(rec == without(pk, "timing"), "%s: %s.json is its manifest record without timing"
                  % (tar_path, iid))
        got = [ti.name for ti in infos]
        check(got == expected, "%s: members are the instances' files + ID.json, per sample contiguous "
              "in byte order, samples in position order; first difference at %r" % (
                  tar_path, next((a for a, b in zip(got, expected) if a != b), len(got))))
        differ = [n for n, b in want.items() if n not in data or member_of(n, data[n]) != b]
        check(not differ, "%s: every member is the unpacked file, its references to the "
              "instance's files renamed to member names: %r differ" % (tar_path, differ[:3]))
        check(all(ti.isreg() and ti.mode == 0o644 and ti.uid == 0 and ti.gid == 0 and ti.mtime == 0
                  for ti in infos), "%s: regular members, mode 0644, owner 0/0, mtime 0" % tar_path)
        check(all(raw[ti.offset + 257:ti.offset + 265] == b"ustar\x0000" for ti in infos),
              "%s: POSIX ustar headers" % tar_path)
        end = infos[-1].offset_data + (infos[-1].size + 511) // 512 * 512
        check(len(raw) % 10240 == 0 and len(raw) - end >= 1024 and not raw[end:].strip(b"\0"),
              "%s: two zero blocks at the end, padded to 10240 bytes (%d bytes, data to %d)"
              % (tar_path, len(raw), end))
        # The sidecar: where tarfile finds each member's data.
        with open(os.path.join(packed, "shards", "%06d.index.json" % k)) as f:
            side = json.load(f)
        by_key = collections.OrderedDict()
        for ti in infos:
            by_key.setdefault(ti.name.split(".", 1)[0], []).append([ti.name, ti.offset_data, ti.size])
        check(side == {"format": "sylva-tar-index-1", "tar": "%06d.tar" % k, "bytes": len(raw),
                       "samples": [{"key": key, "position": k * M + j, "members": members}
                                   for j, (key, members) in enumerate(by_key.items())]},
              "%s: the sidecar index lists every member's data offset and size" % tar_path)


# --- sylva_dataset: packed and unpacked read alike -------------------------------------------------


def same_arrays(np, a, b):
    """Two namedtuples (or lists) of arrays / None equal field by field, dtypes included."""
    if a is None or b is None:
        return a is None and b is None
    return len(a) == len(b) and all(
        (x is None and y is None) or (x is not None and y is not None and x.dtype == y.dtype
                                      and x.shape == y.shape and np.array_equal(x, y))
        for x, y in zip(a, b))


def test_readers(np, sd, packed, unpacked):
    dp, du = sd.Dataset(packed), sd.Dataset(unpacked)
    check(dp.packed and not du.packed, "Dataset.packed")
    check(len(dp) == len(du) == 24, "both builds read: %d, %d instances" % (len(dp), len(du)))
    compared = collections.Counter()
    for pos, (p, u) in enumerate(zip(dp, du)):
        what = p.id
        check(p.pack == "shards/%06d.tar" % (pos // M) and p.dir is None,
              "%s: pack %r, no directory" % (what, p.pack))
        sp, su = p.skeleton(), u.skeleton()
        check(same_arrays(np, sp[:6], su[:6]) and np.array_equal(sp.nodes, su.nodes),
              "%s: skeleton arrays identical" % what)
        for kind in ("mesh", "watertight"):
            check(p.mesh_formats(kind) == u.mesh_formats(kind) == ["ply", "glb", "obj"],
                  "%s: %s formats %r" % (what, kind, p.mesh_formats(kind)))
            for fmt in u.mesh_formats(kind):
                check(same_arrays(np, p.mesh(kind, fmt)[:7], u.mesh(kind, fmt)[:7]),
                      "%s: %s.%s arrays identical" % (what, kind, fmt))
                compared["mesh"] += 1
        pp, pu = p.points(), u.points()
        check(same_arrays(np, pp[:3], pu[:3]), "%s: point cloud identical" % what)
        cams = p.cameras()
        files = instance_files(unpacked, u.record)
        check(cams == as_member(u.id, "transforms.json", files["transforms.json"], files),
              "%s: cameras() is transforms.json with member names" % what)
        for reader in ("masks", "labels", "depths", "rgb"):
            a, b = getattr(p, reader)(), getattr(u, reader)()
            check(len(a) == len(b) and same_arrays(np, a, b), "%s: %s() identical (%d views)"
                  % (what, reader, len(b)))
            compared[reader] += len(b)
        for key, name in u.files.items():
            rel = name.split("/%s/" % u.id, 1)[1]
            if key != "views":
                check(member_of(rel, p.read_bytes(key)) == as_member(u.id, rel, files[rel], files),
                      "%s: read_bytes(%r) is the member" % (what, key))
        try:
            p.path("skeleton_ply")
            check(False, "%s: path() of a packed instance raises" % what)
        except ValueError as e:
            check("read_bytes" in str(e), "path() of a packed instance says what to do: %s" % e)
    check(compared["masks"] == compared["labels"] == compared["depths"] == 24 * 4
          and compared["mesh"] == 24 * 6, "views and meshes compared: %r" % dict(compared))


def test_killed_build(np, sd, exe, data, packed, unpacked, tmp):
    """A build killed after its 7th record (SYLVA_TEST_ABORT_AFTER, the C++ tests' kill): records
    of shard 1, not written yet, read from their instance directories; the rerun's shards are the
    uninterrupted build's bytes, and a Dataset opened before the rerun reads them."""
    out = os.path.join(tmp, "killed")
    cmd = [exe, "build", os.path.join(data, "tiny_dataset_packed.toml"), "--out", out, "--threads", "2"]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       env=dict(os.environ, SYLVA_TEST_ABORT_AFTER="7"))
    check(r.returncode != 0, "SYLVA_TEST_ABORT_AFTER=7 kills the build (exit %d)" % r.returncode)
    ds, ref = sd.Dataset(out), sd.Dataset(unpacked)
    check(len(ds) == 7 and all(i.pack for i in ds), "the killed build recorded 7 packed instances")
    check(not os.path.exists(os.path.join(out, "shards", "000001.tar")),
          "shard 1 (positions 5-9) is not written by the killed run")

    def same(inst):
        u = ref[inst.id]
        return (same_arrays(np, inst.skeleton()[:6], u.skeleton()[:6])
                and same_arrays(np, inst.mesh("glb")[:7], u.mesh("glb")[:7])
                and same_arrays(np, inst.depths(), u.depths())
                and same_arrays(np, inst.masks(), u.masks()))

    for inst in ds:
        check(same(inst), "%s (%s) read while its shard is %s" % (
            inst.id, inst.pack, "written" if os.path.exists(os.path.join(out, inst.pack))
            else "not written: from its directory"))
    run(cmd)
    for name in sorted(os.listdir(os.path.join(packed, "shards"))):
        with open(os.path.join(packed, "shards", name), "rb") as a:
            with open(os.path.join(out, "shards", name), "rb") as b:
                check(a.read() == b.read(), "resumed build: shards/%s is the uninterrupted build's" % name)
    check(len(sd.Dataset(out)) == 24, "the rerun recorded all 24")
    check(all(same(ds[k]) for k in (0, 5, 6)),
          "a Dataset opened before the rerun reads the shards it wrote")


def test_sidecar_fallback(np, sd, packed, tmp):
    """Reads through a missing sidecar and one of another tar size (the headers), and through a
    valid sidecar whose offsets were shifted (used: so reads fail) — the sidecar is used when it
    matches and only then."""
    root = os.path.join(tmp, "fallback")
    shards = os.path.join(root, "shards")
    os.makedirs(shards)
    for name in ("dataset.json", "manifest.jsonl"):
        shutil.copy(os.path.join(packed, name), root)
    for name in os.listdir(os.path.join(packed, "shards")):
        src = os.path.join(packed, "shards", name)
        if name.endswith(".tar"):
            os.link(src, os.path.join(shards, name))
        else:
            shutil.copy(src, shards)

    def edit_sidecar(k, shift, size_delta):
        p = os.path.join(shards, "%06d.index.json" % k)
        with open(p) as f:
            side = json.load(f)
        side["bytes"] += size_delta
        for s in side["samples"]:
            s["members"] = [[n, off + shift, size] for n, off, size in s["members"]]
        with open(p, "w") as f:
            json.dump(side, f)

    os.remove(os.path.join(shards, "000000.index.json"))
    edit_sidecar(1, 512, 1)  # another size: ignored, so its wrong offsets do no harm
    edit_sidecar(2, 512, 0)  # this size: used
    ref, ds = sd.Dataset(packed), sd.Dataset(root)
    for k in (0, 1):
        check(sd.tar_members(os.path.join(shards, "%06d.tar" % k))
              == sd.tar_members(os.path.join(packed, "shards", "%06d.tar" % k)),
              "shard %d: the member index from the headers equals the sidecar's" % k)
    for pos in (0, M + 1):
        a, b = ds[pos], ref[pos]
        check(same_arrays(np, a.skeleton()[:6], b.skeleton()[:6])
              and same_arrays(np, a.depths(), b.depths()),
              "%s: read through the tar's headers (sidecar %s)" % (a.id, "missing" if pos == 0
                                                                    else "of another size"))
    try:
        ds[2 * M].skeleton()
        used = False
    except ValueError:
        used = True
    check(used, "a sidecar that matches the tar's size is used (its shifted offsets break reads)")
    # A shard replaced (temp + rename: a rerun merged an instance into it) after it was indexed:
    # a member the old index lacks makes TarShards index the new file.
    def write_tar(path, members):
        with tarfile.open(path + ".tmp", "w", format=tarfile.PAX_FORMAT) as tar:
            for name, data in members:
                ti = tarfile.TarInfo(name)
                ti.size = len(data)
                tar.addfile(ti, io.BytesIO(data))
        os.replace(path + ".tmp", path)

    write_tar(os.path.join(shards, "merged.tar"), [("a.json", b"1"), ("c.json", b"3")])
    reader = sd.TarShards(root)
    first = reader.read("shards/merged.tar", "c.json")
    write_tar(os.path.join(shards, "merged.tar"), [("a.json", b"1"), ("b.json", b"2"), ("c.json", b"3")])
    check(first == b"3" and reader.read("shards/merged.tar", "b.json") == b"2"
          and reader.read("shards/merged.tar", "c.json") == b"3",
          "TarShards reads a member merged into a shard rewritten after it indexed it")
    # Pickled (a spawned DataLoader worker): indexes without files, reads still work.
    ref[0].skeleton()
    clone = pickle.loads(pickle.dumps(ref.shards))
    check(clone.read(ref[0].pack, ref[0].files["skeleton_ply"]) == ref[0].read_bytes("skeleton_ply"),
          "TarShards pickles (indexes, no open files) and reads after unpickling")


def test_samples_in_memory(np, cv2, sd, exe, src, unpacked, tmp):
    """Colour pictures and scans, which tiny_dataset has none of, read from member bytes: an
    instance made from an unpacked one's files named as members (transforms.json rewritten),
    against the same files read from disk."""
    u = sd.Dataset(unpacked)[0]
    iid = u.id
    files = instance_files(unpacked, u.record)
    members = {member_name(iid, rel): b for rel, b in files.items()}
    rng = np.random.RandomState(11)
    t = as_member(iid, "transforms.json", files["transforms.json"], files)
    pictures = []
    for k, fr in enumerate(t["frames"]):
        h, w = 48, 64
        img = rng.randint(0, 256, size=(h, w, 4)).astype(np.uint8)
        ok, png = cv2.imencode(".png", img)  # BGRA
        name = member_name(iid, "views/%03d_rgb.png" % k)
        if k == 1:  # a JPEG too
            ok, png = cv2.imencode(".jpg", img[:, :, :3])
            name = member_name(iid, "views/%03d_rgb.jpg" % k)
            img = cv2.imdecode(png, cv2.IMREAD_COLOR)
        check(ok, "cv2 encodes a colour picture")
        members[name] = png.tobytes()
        fr.setdefault("mask_path", fr["file_path"])
        fr["file_path"] = name
        pictures.append(img[:, :, [2, 1, 0, 3]] if img.shape[2] == 4 else img[:, :, ::-1])
    members[member_name(iid, "transforms.json")] = json.dumps(t).encode()
    rec = dict(u.record, pack="shards/000000.tar",
               files={k: member_name(iid, v.split("/%s/" % iid, 1)[1]) for k, v in u.files.items()})
    members[iid + ".json"] = json.dumps(without(rec, "timing")).encode()
    inst = sd.Instance.from_sample(iid, members, "memory")
    rgb = inst.rgb()
    check(len(rgb) == len(pictures) and all(a.shape == b.shape and np.array_equal(a, b)
                                            for a, b in zip(rgb, pictures)),
          "rgb() from member bytes: RGBA PNGs and a JPEG equal OpenCV's decode")
    check(same_arrays(np, inst.masks(), u.masks()) and same_arrays(np, inst.depths(), u.depths())
          and same_arrays(np, inst.skeleton()[:6], u.skeleton()[:6]),
          "masks, depths and skeleton from member bytes equal the files' (mask_path kept)")
    # A scan: a plot built unpacked, its files as members of an in-memory sample.
    plot = os.path.join(tmp, "plot")
    run([exe, "build", os.path.join(src, "tests/data/scan/uls_plot.toml"), "--out", plot, "--threads", "2"])
    pu = sd.Dataset(plot)[0]
    check(pu.kind == "plot" and "scan_las" in pu.files, "the plot has a scan")
    prefix = "plots/%s/%s/" % (pu.plot, pu.id)
    files = {}
    for dirpath, _, names in os.walk(pu.dir):
        for name in names:
            p = os.path.join(dirpath, name)
            with open(p, "rb") as f:
                files[member_name(pu.id, os.path.relpath(p, pu.dir))] = f.read()
    rec = dict(pu.record, pack="shards/000000.tar",
               files={k: member_name(pu.id, v[len(prefix):]) for k, v in pu.files.items()})
    files[pu.id + ".json"] = json.dumps(without(rec, "timing")).encode()
    ps = sd.Instance.from_sample(pu.id, files, "memory")
    a, b = ps.scan(), pu.scan()
    check(same_arrays(np, a[:11], b[:11]) and a.las.header == b.las.header,
          "scan() from member bytes equals the file's (%d points)" % len(b.positions))


# --- PyTorch ------------------------------------------------------------------------------------------


def same_items(torch, a, b, what):
    keys = set(a) - {"json"}
    ok = keys == set(b) - {"json"} and all(
        torch.equal(a[k], b[k]) if torch.is_tensor(a[k]) else a[k] == b[k] for k in keys)
    check(ok, "%s: equal items (%s)" % (what, a.get("id")))


def sharded_ranks(rank, world, init, queue, packed):
    """A process of a torch.distributed group: its ShardDataset's default rank and shards."""
    import torch.distributed as dist
    from sylva_dataset.pytorch import ShardDataset

    dist.init_process_group("gloo", init_method=init, rank=rank, world_size=world)
    ds = ShardDataset(packed, fields=(), seed=9)
    queue.put((rank, ds.rank, ds.world_size, ds.rank_shards()))
    dist.destroy_process_group()


def test_torch(np, torch, sd, packed, unpacked, tmp):
    from sylva_dataset.pytorch import ShardDataset, TreeDataset, ViewDataset

    fields = ("skeleton", "mesh", "points", "views", "json")
    tp, tu = TreeDataset(packed, fields=fields), TreeDataset(unpacked, fields=fields)
    check(len(tp) == len(tu) == 24, "TreeDataset lengths %d, %d" % (len(tp), len(tu)))
    ref = {}
    for i in range(len(tu)):
        a, b = tp[i], tu[i]
        same_items(torch, a, b, "TreeDataset packed vs unpacked")
        check(a["json"]["pack"] == "shards/%06d.tar" % (i // M) and "timing" not in a["json"],
              "TreeDataset json: the record without timing")
        ref[b["id"]] = b
    # DataLoader workers forked after the parent has the tars open: they open their own (a shared
    # descriptor's offset would move under the parent's reads: it must not move at all). The
    # parent's last read in each tar is its first skeleton, the workers' a later file.
    for k in range(0, 24, M):
        tp.instances[k].skeleton()
    parent_files = [entry[1] for entry in tp.dataset.shards._open.values() if entry[1] is not None]
    offsets = [os.lseek(f.fileno(), 0, os.SEEK_CUR) for f in parent_files]
    loader = torch.utils.data.DataLoader(tp, batch_size=None, num_workers=2)
    got = list(loader)
    check(len(got) == 24, "TreeDataset (packed) through 2 DataLoader workers: %d items" % len(got))
    for item in got:
        same_items(torch, item, ref[item["id"]], "TreeDataset in forked workers")
    check(len(parent_files) == 5 and [os.lseek(f.fileno(), 0, os.SEEK_CUR) for f in parent_files] == offsets,
          "forked workers read the tars through files of their own (the parent's offsets unmoved)")
    vp, vu = ViewDataset(packed), ViewDataset(unpacked)
    check(len(vp) == len(vu) == 24 * 4, "ViewDataset lengths %d, %d" % (len(vp), len(vu)))
    for i in range(0, len(vu), 7):
        same_items(torch, vp[i], vu[i], "ViewDataset packed vs unpacked")

    ids = [r["id"] for r in records(packed)]
    by_shard = [ids[k:k + M] for k in range(0, len(ids), M)]
    shard_of = {p: k for k, p in enumerate(os.path.join(packed, "shards", "%06d.tar" % k)
                                           for k in range(len(by_shard)))}
    # Every field, in order, through 2 workers: the items of TreeDataset.
    s = ShardDataset(packed, fields=fields, shuffle=False)
    items = list(torch.utils.data.DataLoader(s, batch_size=None, num_workers=2))
    check(sorted(i["id"] for i in items) == sorted(ids), "ShardDataset: every instance once")
    for item in items:
        same_items(torch, item, ref[item["id"]], "ShardDataset vs TreeDataset (unpacked)")
        check(item["json"] == tp[ids.index(item["id"])]["json"], "ShardDataset json: ID.json")

    def epoch_ids(ds, epoch, workers=2):
        ds.set_epoch(epoch)
        loader = torch.utils.data.DataLoader(ds, batch_size=None, num_workers=workers)
        return [item["id"] for item in loader]

    s = ShardDataset(packed, fields=("json",), seed=5)
    e0, e1 = epoch_ids(s, 0), epoch_ids(s, 1)
    check(collections.Counter(e0) == collections.Counter(e1) == collections.Counter(ids),
          "ShardDataset, 2 workers: every instance exactly once in epochs 0 and 1")
    check(s.shard_order(0) != s.shard_order(1) and sorted(s.shard_order(0)) == sorted(s.shard_order(1)),
          "set_epoch: another shard order, the same shards")
    check(e0 != e1, "epochs 0 and 1 yield different orders")
    check(epoch_ids(ShardDataset(packed, fields=("json",), seed=5), 0) == e0
          and ShardDataset(packed, seed=5).shard_order(1) == s.shard_order(1),
          "the same seed and epoch give the same order")
    check(epoch_ids(s, 1, workers=0) == [i for p in s.shard_order(1) for i in by_shard[shard_of[p]]],
          "one process reads the epoch's shards in its order, each tar front to back")
    b0 = epoch_ids(ShardDataset(packed, fields=("json",), seed=5, shuffle_buffer=6), 0, workers=0)
    b0again = epoch_ids(ShardDataset(packed, fields=("json",), seed=5, shuffle_buffer=6), 0, workers=0)
    check(sorted(b0) == sorted(ids) and b0 != epoch_ids(s, 0, workers=0) and b0 == b0again,
          "shuffle_buffer: the same instances in another order, the same for the same seed")
    # Ranks 0 and 1 of 2.
    r0, r1 = (ShardDataset(packed, fields=("json",), seed=5, rank=r, world_size=2) for r in (0, 1))
    for epoch in (0, 1):
        a, b = set(r0.rank_shards(epoch)), set(r1.rank_shards(epoch))
        check(not a & b and a | b == set(shard_of), "epoch %d: ranks 0 and 1 of 2 share no shard and "
              "cover all (%d + %d)" % (epoch, len(a), len(b)))
        ia, ib = epoch_ids(r0, epoch), epoch_ids(r1, epoch)
        check(not set(ia) & set(ib) and collections.Counter(ia + ib) == collections.Counter(ids),
              "epoch %d: ranks 0 and 1 (2 workers each) read every instance once between them" % epoch)
    tv = epoch_ids(ShardDataset(packed, fields=("json",), species=["tiny-var"]), 0)
    check(sorted(tv) == sorted(i for i in ids if i.startswith("tiny-var-")), "ShardDataset species=")
    # Defaults from an initialised torch.distributed group (two processes, gloo).
    ctx = torch.multiprocessing.get_context("spawn")
    queue = ctx.Queue()
    init = "file://" + os.path.join(tmp, "dist_init")
    procs = [ctx.Process(target=sharded_ranks, args=(r, 2, init, queue, packed)) for r in (0, 1)]
    for p in procs:
        p.start()
    got = sorted(queue.get(timeout=120) for _ in procs)
    for p in procs:
        p.join(60)
    ref0 = ShardDataset(packed, fields=(), seed=9)
    check([g[:3] for g in got] == [(0, 0, 2), (1, 1, 2)]
          and [g[3] for g in got] == [ref0.shard_order()[0::2], ref0.shard_order()[1::2]],
          "rank and world_size default to the torch.distributed group's: %r" % [g[:3] for g in got])
    # shard_list without index.json: a sharded build's index files, else the tars by name.
    alt = os.path.join(tmp, "alt")
    os.makedirs(os.path.join(alt, "shards"))
    tars = sorted(shard_of)
    for p in tars:
        os.symlink(p, os.path.join(alt, "shards", os.path.basename(p)))
    check([p for p, _ in sd.shard_list(alt)] == [os.path.join(alt, "shards", os.path.basename(p)) for p in tars],
          "shard_list: shards/*.tar by name without an index")
    with open(os.path.join(packed, "shards", "index.json")) as f:
        wids = json.load(f)
    for i, part in enumerate((wids["shardlist"][3:], wids["shardlist"][:3])):
        with open(os.path.join(alt, "shards", "index.shard-%d-of-2.json" % i), "w") as f:
            json.dump(dict(wids, shardlist=part), f)
    check([os.path.basename(p) for p, _ in sd.shard_list(alt)]
          == [s["url"] for s in wids["shardlist"][3:] + wids["shardlist"][:3]],
          "shard_list: index.shard-I-of-N.json in I order")


def checks(exe, src, tmp):
    import cv2
    import numpy as np
    import torch

    sys.path.insert(0, os.path.join(src, "python"))
    import sylva_dataset as sd

    check(os.path.realpath(sd.__file__).startswith(os.path.realpath(os.path.join(src, "python"))),
          "sylva_dataset from the source tree: %s" % sd.__file__)
    data = os.path.join(src, "tests", "data")
    check(toml_body(os.path.join(data, "tiny_dataset_packed.toml"), ("pack", "pack_instances"))
          == toml_body(os.path.join(data, "tiny_dataset.toml")),
          "tiny_dataset_packed.toml is tiny_dataset.toml with pack keys")
    packed, unpacked = os.path.join(tmp, "packed"), os.path.join(tmp, "unpacked")
    run([exe, "build", os.path.join(data, "tiny_dataset_packed.toml"), "--out", packed, "--threads", "2"])
    run([exe, "build", os.path.join(data, "tiny_dataset.toml"), "--out", unpacked, "--threads", "2"])
    for test, args in ((test_layout, (packed, unpacked)),
                       (test_readers, (np, sd, packed, unpacked)),
                       (test_killed_build, (np, sd, exe, data, packed, unpacked, tmp)),
                       (test_sidecar_fallback, (np, sd, packed, tmp)),
                       (test_samples_in_memory, (np, cv2, sd, exe, src, unpacked, tmp)),
                       (test_torch, (np, torch, sd, packed, unpacked, tmp))):
        try:
            test(*args)
        except Exception:  # a reader that raises fails its test; the others still run
            traceback.print_exc()
            check(False, "%s raised" % test.__name__)


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    exe, src = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    missing = []
    for module, package in NEEDED:
        try:
            __import__(module)
        except ImportError:
            missing.append(package)
    if missing:
        print("test_packed_dataset: %s missing for %s: scripts/setup --tests installs them "
              "(apt-get install -y %s)" % (", ".join(missing), sys.executable, " ".join(missing)))
        return 1
    tmp = tempfile.mkdtemp(prefix="sylva_packed_")
    try:
        checks(exe, src, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if failures:
        print("%d failure(s)" % len(failures))
        return 1
    print("packed datasets: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
