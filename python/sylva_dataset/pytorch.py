"""PyTorch datasets over a sylva dataset directory (needs torch; Debian: python3-torch).

TreeDataset: one item per tree instance, a dict of tensors of varying sizes (skeleton, mesh,
point cloud, all views); batch with DataLoader(batch_size=None) or collate_fn=list.
ViewDataset: one item per (instance, view), fixed-size tensors (mask, labels, depth, camera),
so DataLoader's default collation stacks them into batches.
ShardDataset: the items of TreeDataset streamed from a packed dataset's tar shards, each tar
read front to back: shard order shuffled per epoch, split across DataLoader workers and
distributed ranks, an optional shuffle buffer of samples.

TreeDataset and ViewDataset read packed and unpacked datasets alike (through
sylva_dataset.Instance). Every array is the numpy reader's, turned into a tensor with
torch.from_numpy (no copy): float32 positions, radii, depths and cameras; int64 indices and
labels; uint8 masks.
"""

import os

import numpy as np
import torch

from .dataset import Dataset, Instance
from .shards import iter_shard, shard_list

__all__ = ["TreeDataset", "ViewDataset", "ShardDataset"]

TREE_FIELDS = ("skeleton", "mesh", "points", "views", "json")


def _dataset(root):
    return root if isinstance(root, Dataset) else Dataset(root)


def _tensors(prefix, **arrays):
    return {prefix + k: torch.from_numpy(v) for k, v in arrays.items() if v is not None}


def camera_arrays(cams, frame):
    """(c2w (4, 4) float32 camera-to-world, OpenGL convention; K (3, 3) float32 pixel
    intrinsics fl_x, fl_y, cx, cy) of one transforms.json frame (per-frame values override the
    file's)."""
    get = lambda key: frame.get(key, cams.get(key))  # noqa: E731
    k = np.array([[get("fl_x"), 0, get("cx")], [0, get("fl_y"), get("cy")], [0, 0, 1]], np.float32)
    return np.array(frame["transform_matrix"], np.float32), k


def _check_fields(cls, fields):
    unknown = [f for f in fields if f not in TREE_FIELDS]
    if unknown:
        raise ValueError("%s fields %r: expected some of %s" % (cls, unknown, TREE_FIELDS))
    return tuple(fields)


def tree_item(inst, fields, mesh_kind="mesh", mesh_format=None):
    """The item TreeDataset and ShardDataset give for one Instance (see TreeDataset)."""
    item = {"id": inst.id, "species": inst.species, "index": inst.index}
    if "json" in fields:
        item["json"] = {k: v for k, v in inst.record.items() if k != "timing"}
    if "skeleton" in fields:
        sk = inst.skeleton()
        item.update(_tensors("", positions=sk.positions, radii=sk.radii, parents=sk.parents,
                             edges=sk.edges, order=sk.order, part=sk.part))
    if "mesh" in fields:
        m = inst.mesh(mesh_kind, mesh_format)
        item.update(_tensors("mesh_", positions=m.positions, faces=m.faces, normals=m.normals,
                             uvs=m.uvs, order=m.order, part=m.part, colour=m.colour))
    if "points" in fields:
        p = inst.points()
        item.update(_tensors("point_", positions=p.positions, labels=p.labels, views=p.views))
    if "views" in fields:
        cams = inst.cameras()
        frames = cams.get("frames", [])
        masks, labels, depths = inst.masks(), inst.labels(), inst.depths()
        rgb = inst.rgb()
        mats = [camera_arrays(cams, fr) for fr in frames]
        item.update(_tensors(
            "", masks=np.stack(masks) if masks else None,
            labels=np.stack(labels).astype(np.int64) if labels else None,
            depths=np.stack(depths) if depths else None,
            rgb=np.stack(rgb) if rgb else None,
            c2w=np.stack([m[0] for m in mats]) if mats else None,
            K=np.stack([m[1] for m in mats]) if mats else None))
    return item


class TreeDataset(torch.utils.data.Dataset):
    """Items: {"id", "species", "index"} plus, for each of `fields`:

    skeleton  positions (N, 3) float32, radii (N,) float32, parents (N,) int64 (−1 root),
              edges (E, 2) int64, order (N,) int64, part (N,) int64
    mesh      mesh_positions (V, 3) float32, mesh_faces (F, 3) int64, mesh_normals, mesh_uvs,
              mesh_order, mesh_part, mesh_colour (those the format has), from `mesh_kind` in
              `mesh_format` (default: the first format the manifest lists)
    points    point_positions (P, 3) float32, point_labels (P,) int64, point_views (P,) int64
    views     masks (V, H, W) uint8, labels (V, H, W) int64, depths (V, H, W) float32, rgb
              (V, H, W, 4) uint8 colour pictures (those the dataset has), c2w (V, 4, 4) float32, K (V, 3, 3) float32
    json      json: the manifest record without "timing" (a dict)

    root: a dataset directory (packed or not) or a sylva_dataset.Dataset; species: keep only
    these species; transform: applied to each item dict."""

    def __init__(self, root, fields=("skeleton",), species=None, mesh_kind="mesh", mesh_format=None,
                 transform=None):
        self.fields = _check_fields("TreeDataset", fields)
        self.dataset = _dataset(root)
        self.instances = [i for i in self.dataset if species is None or i.species in species]
        self.mesh_kind, self.mesh_format = mesh_kind, mesh_format
        self.transform = transform

    def __len__(self):
        return len(self.instances)

    def __getitem__(self, i):
        item = tree_item(self.instances[i], self.fields, self.mesh_kind, self.mesh_format)
        return self.transform(item) if self.transform else item


class ViewDataset(torch.utils.data.Dataset):
    """Items, one per (instance, view) in manifest then frame order: {"id", "species", "view"
    (the frame index), "mask" (H, W) uint8 0/255, "labels" (H, W) int64 (if the dataset has
    label views), "depth" (H, W) float32 metres, 0 = background (if it has depth views), "rgb"
    (H, W, 4) uint8 sRGB + alpha (or (H, W, 3) from JPEGs; if it has colour pictures),
    "c2w" (4, 4) float32 camera-to-world (OpenGL convention), "K" (3, 3) float32}.

    Views of one dataset share a size, so DataLoader's default collation batches them."""

    def __init__(self, root, species=None, transform=None):
        self.dataset = _dataset(root)
        self.transform = transform
        self.items = []
        for inst in self.dataset:
            if species is not None and inst.species not in species:
                continue
            coverage = inst.stats.get("silhouette_coverage")
            count = (len(coverage) if isinstance(coverage, list)
                     else len(inst.cameras().get("frames", [])) if "transforms" in inst.files else 0)
            self.items += [(inst, k) for k in range(count)]

    def __len__(self):
        return len(self.items)

    def __getitem__(self, i):
        inst, k = self.items[i]
        cams = inst.cameras()
        frame = cams["frames"][k]
        c2w, K = camera_arrays(cams, frame)
        item = {"id": inst.id, "species": inst.species, "view": k,
                "mask": torch.from_numpy(inst._frame_mask(frame)),
                "c2w": torch.from_numpy(c2w), "K": torch.from_numpy(K)}
        rgb = inst._frame_rgb(frame)
        if rgb is not None:
            item["rgb"] = torch.from_numpy(rgb)
        if "label_file_path" in frame:
            item["labels"] = torch.from_numpy(inst._frame_labels(frame).astype(np.int64))
        if "depth_file_path" in frame:
            item["depth"] = torch.from_numpy(inst._frame_depth(frame))
        return self.transform(item) if self.transform else item


class ShardDataset(torch.utils.data.IterableDataset):
    """The items of TreeDataset (same fields, keys, dtypes; "json" the record) streamed from the
    tar shards of a packed dataset ([outputs] pack = "tar"), each tar read front to back once
    per epoch: no random access, so it suits network file systems and very large datasets.

    root       a packed dataset directory; its shards come from shards/index.json
               (wids-shard-index-v1), else shards/index.shard-I-of-N.json, else shards/*.tar
    fields, species, mesh_kind, mesh_format, transform: as TreeDataset
    shuffle    shuffle the shard order each epoch (default True); False: instance order
    seed       the shuffles' seed: the same seed and epoch give the same order
    shuffle_buffer  N > 1: samples pass through a buffer of N from which each is drawn at
               random (seeded by seed, epoch, rank and worker); holds N samples' bytes
    rank, world_size  this process's part: shards k with k ≡ rank (mod world_size) of the
               epoch's order; default torch.distributed's rank and world size when it is
               initialised (when the dataset is made), else 0 and 1

    The epoch's shard order is split across ranks, then across the DataLoader's workers (shard j
    of a rank's list to worker j mod num_workers), so each sample is read once per epoch by one
    worker of one rank; a worker or rank left without a shard yields nothing, and ranks' sample
    counts differ by up to a shard. Call set_epoch(n) before each epoch (with a DataLoader whose
    workers are not persistent: they copy the dataset when an epoch starts)."""

    def __init__(self, root, fields=("skeleton",), species=None, mesh_kind="mesh", mesh_format=None,
                 shuffle=True, seed=0, shuffle_buffer=0, rank=None, world_size=None,
                 transform=None):
        self.fields = _check_fields("ShardDataset", fields)
        self.root = os.path.abspath(root)
        self.shardlist = shard_list(self.root)  # [(tar path, nsamples or None)]
        if not self.shardlist:
            raise FileNotFoundError("%s: no tar shards (shards/index.json, shards/*.tar): not a "
                                    "packed dataset ([outputs] pack = \"tar\")" % self.root)
        self.species = None if species is None else set(species)
        self.mesh_kind, self.mesh_format = mesh_kind, mesh_format
        self.shuffle, self.seed, self.shuffle_buffer = shuffle, seed, shuffle_buffer
        dist = torch.distributed
        on = dist.is_available() and dist.is_initialized()
        if rank is None:
            rank = dist.get_rank() if on else 0
        if world_size is None:
            world_size = dist.get_world_size() if on else 1
        self.rank, self.world_size = rank, world_size
        if not 0 <= self.rank < self.world_size:
            raise ValueError("ShardDataset rank %d of world_size %d" % (self.rank, self.world_size))
        self.transform = transform
        self.epoch = 0

    def set_epoch(self, epoch):
        """The epoch the next iteration reads: it sets the shard order and the buffer's draws."""
        self.epoch = epoch

    def shard_order(self, epoch=None):
        """Every shard's path in the epoch's order, before the split across ranks and workers."""
        paths = [p for p, _ in self.shardlist]
        if not self.shuffle:
            return paths
        rng = np.random.default_rng([self.seed, self.epoch if epoch is None else epoch])
        return [paths[i] for i in rng.permutation(len(paths))]

    def rank_shards(self, epoch=None):
        """The shards this rank reads in the epoch, in order (its workers share them out)."""
        return self.shard_order(epoch)[self.rank::self.world_size]

    def _samples(self, paths):
        for path in paths:
            for key, members in iter_shard(path):
                inst = Instance.from_sample(key, members, path)
                if self.species is None or inst.species in self.species:
                    yield inst

    def __iter__(self):
        info = torch.utils.data.get_worker_info()
        worker, workers = (info.id, info.num_workers) if info is not None else (0, 1)
        samples = self._samples(self.rank_shards()[worker::workers])
        if self.shuffle_buffer > 1:
            rng = np.random.default_rng([self.seed, self.epoch, self.rank, worker])
            samples = _buffer_shuffled(samples, self.shuffle_buffer, rng)
        for inst in samples:
            item = tree_item(inst, self.fields, self.mesh_kind, self.mesh_format)
            yield self.transform(item) if self.transform else item


def _buffer_shuffled(items, size, rng):
    """Items through a buffer of `size`: once it is full, each new item takes the place of one
    drawn at random, which is yielded; the rest leave in random order at the end."""
    buf = []
    for item in items:
        if len(buf) < size:
            buf.append(item)
            continue
        k = int(rng.integers(size))
        buf[k], item = item, buf[k]
        yield item
    rng.shuffle(buf)
    yield from buf
