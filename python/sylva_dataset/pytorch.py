"""PyTorch datasets over a sylva dataset directory (needs torch; Debian: python3-torch).

TreeDataset: one item per tree instance, a dict of tensors of varying sizes (skeleton, mesh,
point cloud, all views); batch with DataLoader(batch_size=None) or collate_fn=list.
ViewDataset: one item per (instance, view), fixed-size tensors (mask, labels, depth, camera),
so DataLoader's default collation stacks them into batches.

Every array is the numpy reader's (sylva_dataset.Instance), turned into a tensor with
torch.from_numpy (no copy): float32 positions, radii, depths and cameras; int64 indices and
labels; uint8 masks.
"""

import os

import numpy as np
import torch

from .dataset import Dataset, read_colour
from .exr import read_exr_first_channel
from .png import read_png

__all__ = ["TreeDataset", "ViewDataset"]

TREE_FIELDS = ("skeleton", "mesh", "points", "views")


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

    root: a dataset directory or a sylva_dataset.Dataset; species: keep only these species;
    transform: applied to each item dict."""

    def __init__(self, root, fields=("skeleton",), species=None, mesh_kind="mesh", mesh_format=None,
                 transform=None):
        unknown = [f for f in fields if f not in TREE_FIELDS]
        if unknown:
            raise ValueError("TreeDataset fields %r: expected some of %s" % (unknown, TREE_FIELDS))
        self.dataset = _dataset(root)
        self.instances = [i for i in self.dataset if species is None or i.species in species]
        self.fields = tuple(fields)
        self.mesh_kind, self.mesh_format = mesh_kind, mesh_format
        self.transform = transform

    def __len__(self):
        return len(self.instances)

    def __getitem__(self, i):
        inst = self.instances[i]
        item = {"id": inst.id, "species": inst.species, "index": inst.index}
        if "skeleton" in self.fields:
            sk = inst.skeleton()
            item.update(_tensors("", positions=sk.positions, radii=sk.radii, parents=sk.parents,
                                 edges=sk.edges, order=sk.order, part=sk.part))
        if "mesh" in self.fields:
            m = inst.mesh(self.mesh_kind, self.mesh_format)
            item.update(_tensors("mesh_", positions=m.positions, faces=m.faces, normals=m.normals,
                                 uvs=m.uvs, order=m.order, part=m.part, colour=m.colour))
        if "points" in self.fields:
            p = inst.points()
            item.update(_tensors("point_", positions=p.positions, labels=p.labels, views=p.views))
        if "views" in self.fields:
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
        base = os.path.dirname(inst.path("transforms"))
        c2w, K = camera_arrays(cams, frame)
        item = {"id": inst.id, "species": inst.species, "view": k,
                "mask": torch.from_numpy(read_png(os.path.join(
                    base, frame.get("mask_path", frame["file_path"])))),
                "c2w": torch.from_numpy(c2w), "K": torch.from_numpy(K)}
        if frame.get("mask_path", frame["file_path"]) != frame["file_path"]:
            item["rgb"] = torch.from_numpy(read_colour(os.path.join(base, frame["file_path"])))
        if "label_file_path" in frame:
            labels = read_png(os.path.join(base, frame["label_file_path"])).astype(np.int64)
            item["labels"] = torch.from_numpy(labels)
        if "depth_file_path" in frame:
            item["depth"] = torch.from_numpy(
                read_exr_first_channel(os.path.join(base, frame["depth_file_path"])))
        return self.transform(item) if self.transform else item
