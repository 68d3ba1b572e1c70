#!/usr/bin/python3
"""The README's three-panel picture of a plot: the oblique view by part, the top view by part
and the top view by tree (OpenCV and NumPy: Debian's python3-opencv).

usage: scripts/plot_picture.py PLOT_DIR OUT.png [PANEL_PX]
PLOT_DIR is one plot instance (plots/<name>/<id>/, built with [views] labels = true); each
1024² label or id image is averaged down to PANEL_PX (default 384). Parts: terrain grey-brown,
stem dark brown, branches orange, leaves green, roots red, ground cover pale green, sky pale blue;
trees: a colour per id from its hash, terrain and sky grey.
"""
import sys

import cv2
import numpy as np

PARTS = {0: (120, 110, 95), 1: (60, 35, 20), 2: (200, 120, 40), 3: (40, 140, 40),
         4: (150, 30, 30), 5: (150, 190, 90), 255: (235, 240, 250)}


def by_part(labels):
    rgb = np.zeros(labels.shape + (3,), np.uint8)
    for code, colour in PARTS.items():
        rgb[labels == code] = colour
    return rgb


def by_tree(ids, zero=(90, 90, 90)):
    """A colour per tree id, from the renderer's hash (colourIds: Knuth's multiplicative hash,
    a byte per channel); id 0 (terrain, sky) in `zero`."""
    h = (np.asarray(ids).astype(np.uint64) * np.uint64(2654435761)) & np.uint64(0xFFFFFFFF)
    h ^= h >> np.uint64(15)
    rgb = np.stack([(60 + ((h >> np.uint64(s)) & np.uint64(0xFF)) % np.uint64(190)).astype(np.uint8)
                    for s in (0, 8, 16)], axis=-1)
    rgb[np.asarray(ids) == 0] = zero
    return rgb


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    views, out = sys.argv[1] + "/views/", sys.argv[2]
    px = int(sys.argv[3]) if len(sys.argv) == 4 else 384
    panels = [by_part(cv2.imread(views + "oblique_label.png", cv2.IMREAD_UNCHANGED)),
              by_part(cv2.imread(views + "top_label.png", cv2.IMREAD_UNCHANGED)),
              by_tree(cv2.imread(views + "top_id.png", cv2.IMREAD_UNCHANGED))]
    small = [cv2.resize(p, (px, px), interpolation=cv2.INTER_AREA) for p in panels]
    cv2.imwrite(out, cv2.cvtColor(np.hstack(small), cv2.COLOR_RGB2BGR),
                [cv2.IMWRITE_PNG_COMPRESSION, 9])


if __name__ == "__main__":
    main()
