#!/usr/bin/python3
"""Draws a QSM cylinder table (sylva's qsm CSV, docs/scanning.md "QSM ground truth") as two
orthographic side views, x-z and y-z with z up, each cylinder a line as thick as its diameter,
coloured by branch order: brown 0 (stem), green 1, blue 2, magenta 3, yellow 4, grey >= 5.
Debian's python3 with numpy and OpenCV (python3-numpy, python3-opencv).

Usage: scripts/qsm_preview.py QSM.csv OUT.png [SIZE]   (SIZE: pixels per view, default 640)
"""
import sys

import cv2
import numpy as np

COLOURS = [(30, 60, 120), (40, 140, 40), (200, 120, 30), (160, 40, 160), (40, 180, 200),
           (90, 90, 90)]  # BGR


def main():
    q = np.genfromtxt(sys.argv[1], delimiter=",", names=True, ndmin=1)
    size = int(sys.argv[3]) if len(sys.argv) > 3 else 640
    start = np.stack([q["start_x"], q["start_y"], q["start_z"]], 1)
    end = start + np.stack([q["axis_x"], q["axis_y"], q["axis_z"]], 1) * q["length"][:, None]
    pts = np.concatenate([start, end])
    lo, hi = pts.min(0), pts.max(0)
    scale = 0.92 * size / max(np.max(hi - lo), 1e-9)

    def pixel(p, u):
        return (int(size / 2 + (p[u] - (lo[u] + hi[u]) / 2) * scale),
                int(size - 0.04 * size - (p[2] - lo[2]) * scale))

    views = []
    for u in (0, 1):
        img = np.full((size, size, 3), 255, np.uint8)
        for k in np.argsort(q["radius"])[::-1]:  # thick first, so twigs stay visible
            thickness = max(1, int(round(2 * q["radius"][k] * scale)))
            colour = COLOURS[min(int(q["BranchOrder"][k]), len(COLOURS) - 1)]
            cv2.line(img, pixel(start[k], u), pixel(end[k], u), colour, thickness, cv2.LINE_8)
        views.append(img)
    img = np.concatenate(views, 1)
    volume = np.sum(np.pi * q["radius"] ** 2 * q["length"])
    label = (f"{len(q)} cylinders, {int(q['branch'].max())} branches, volume {volume:.2f} m3 "
             "(x-z | y-z, z up)")
    cv2.putText(img, label, (10, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (0, 0, 0), 1)
    cv2.imwrite(sys.argv[2], img)


if __name__ == "__main__":
    main()
