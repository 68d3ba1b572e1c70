#!/usr/bin/python3
"""docs/scanning.md's three-panel picture of a plot scan: a 4 m slab through the plot centre seen
from the south, the top view by class and the top view by tree (grey: treeID 0). Each point is
splatted orthographically (2 × 2 pixels); a pixel's colour is its most frequent class's (or
tree's), laid over white by how many points fell in it (NumPy and OpenCV: Debian's
python3-numpy and python3-opencv; reads the LAS with python/sylva_dataset).

usage: scripts/scan_picture.py SCAN.las OUT.png [PANEL_PX] [--side SLAB_M]

--side draws the first panel alone, of the points within SLAB_M metres north or south of the
origin (the plot centre, or a single tree's stem) instead of 2 m.
"""
import os
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
from sylva_dataset.las import read_las  # noqa: E402
from plot_picture import by_tree  # noqa: E402  (this directory)

# LAS classification (sylva's FOR-instance codes in ASPRS slots, docs/scanning.md) → colour.
CLASSES = {1: (154, 160, 60), 2: (139, 115, 85), 4: (110, 60, 30), 5: (34, 139, 34),
           6: (230, 140, 30)}


def splat(u, v, key, colours_of, lo, hi, px):
    """u right, v up in metres; [lo, hi] the square drawn; key per point (class or tree);
    colours_of(keys) -> an (n, 3) array of RGB."""
    scale = px / (hi - lo)
    i = np.clip(((hi - v) * scale).astype(int), 0, px - 1)
    j = np.clip(((u - lo) * scale).astype(int), 0, px - 1)
    inside = (u >= lo) & (u <= hi) & (v >= lo) & (v <= hi)
    i, j, key = i[inside], j[inside], key[inside]
    cell = i * px + j
    order = np.lexsort((key, cell))
    cell, key = cell[order], key[order]
    # Runs of equal (cell, key): the most frequent key per cell.
    start = np.r_[0, np.flatnonzero((np.diff(cell) != 0) | (np.diff(key) != 0)) + 1]
    counts = np.diff(np.r_[start, cell.size])
    rc, rk = cell[start], key[start]
    best = np.lexsort((-counts, rc))
    first = np.r_[True, np.diff(rc[best]) != 0]
    total = np.bincount(cell, minlength=px * px)
    img = np.full((px * px, 3), 255.0)
    c, k = rc[best][first], rk[best][first]
    a = 1.0 - 0.4 ** total[c]
    colours = np.asarray(colours_of(k), float)
    img[c] = (1 - a)[:, None] * 255.0 + a[:, None] * colours
    # Each point 2 × 2 pixels (the darker colour wins where they touch), as points are seen.
    return cv2.erode(img.reshape(px, px, 3).astype(np.uint8), np.ones((2, 2), np.uint8))


def main():
    args = sys.argv[1:]
    slab_m = None
    if "--side" in args:
        k = args.index("--side")
        if k + 1 >= len(args):
            sys.exit(__doc__)
        slab_m = float(args[k + 1])
        del args[k:k + 2]
    if len(args) not in (2, 3):
        sys.exit(__doc__)
    las = read_las(args[0])
    px = int(args[2]) if len(args) == 3 else 400
    x, y, z = las.positions.T
    cls = las.fields["classification"]
    tree = las.fields["treeID"].astype(np.int64)
    half = max(np.abs(x).max(), np.abs(y).max())
    cc = lambda keys: [CLASSES.get(int(k), (120, 120, 120)) for k in keys]
    slab = np.abs(y) < (2.0 if slab_m is None else slab_m)
    side = splat(x[slab], z[slab] - z.min() - half, cls[slab], cc, -half, half, px)  # ground at the foot
    if slab_m is not None:
        cv2.imwrite(args[1], cv2.cvtColor(side, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_PNG_COMPRESSION, 9])
        return
    top = splat(x, y, cls, cc, -half, half, px)
    ids = splat(x, y, tree, lambda t: by_tree(t, zero=(160, 160, 160)), -half, half, px)
    cv2.imwrite(args[1], cv2.cvtColor(np.hstack([side, top, ids]), cv2.COLOR_RGB2BGR),
                [cv2.IMWRITE_PNG_COMPRESSION, 9])


if __name__ == "__main__":
    main()
