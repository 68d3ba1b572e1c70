#!/usr/bin/env python3
"""Draws twotier.png: a two-tier crown outline sketched beside its axis (Xu & Mould 2012,
Figure 8 style), for the `revolution` volume's `image` source (xm-sketch-twotier.toml).

Standard library only. The stroke is black on white; the axis (column AXIS) is drawn as light
grey dashes, which the tracer ignores (luminance above 0.5). Run from anywhere:
    python3 species/sketches/make_twotier_png.py
"""
import os

from png import write_png

W, H = 320, 480          # pixels
AXIS = 60                # axis column (the preset's axis_x)
PX_PER_M = 44.0          # drawing scale (the preset rescales to `height` metres anyway)
TOP, BOTTOM = 30, 452    # rows of the crown's top and bottom
THICK = 2                # stroke half-width, pixels

# The outline, (distance from the axis, height above the crown's base) in metres: a wide
# lower tier, a waist, a smaller upper tier and a pointed top.
POINTS = [(0.05, 0.0), (0.9, 0.25), (2.3, 0.9), (3.5, 2.0), (3.6, 3.0), (2.8, 3.9),
          (1.3, 4.6), (0.95, 5.1), (1.9, 5.8), (2.5, 6.7), (2.3, 7.7), (1.5, 8.6),
          (0.7, 9.2), (0.1, 9.6)]


def catmull_rom(points, steps=24):
    """Centripetal-free (uniform) Catmull-Rom through the points, ends repeated."""
    pts = [points[0]] + points + [points[-1]]
    out = []
    for i in range(1, len(pts) - 2):
        p0, p1, p2, p3 = pts[i - 1], pts[i], pts[i + 1], pts[i + 2]
        for s in range(steps):
            t = s / steps
            t2, t3 = t * t, t * t * t
            out.append(tuple(0.5 * ((2 * p1[k]) + (-p0[k] + p2[k]) * t +
                                    (2 * p0[k] - 5 * p1[k] + 4 * p2[k] - p3[k]) * t2 +
                                    (-p0[k] + 3 * p1[k] - 3 * p2[k] + p3[k]) * t3)
                             for k in range(2)))
    out.append(points[-1])
    return out


def to_pixel(p):
    x, h = p
    return AXIS + x * PX_PER_M, BOTTOM - h * PX_PER_M


def main():
    img = bytearray([255]) * (W * H)

    def disc(cx, cy, r, value):
        for y in range(int(cy - r) - 1, int(cy + r) + 2):
            for x in range(int(cx - r) - 1, int(cx + r) + 2):
                if 0 <= x < W and 0 <= y < H and (x - cx) ** 2 + (y - cy) ** 2 <= r * r:
                    img[y * W + x] = min(img[y * W + x], value)

    # The axis: light grey dashes over the whole height.
    for y in range(10, H - 10):
        if (y // 10) % 2 == 0:
            img[y * W + AXIS] = 190
    # The stroke: discs along the densely sampled curve.
    curve = [to_pixel(p) for p in catmull_rom(POINTS)]
    for (x0, y0), (x1, y1) in zip(curve, curve[1:]):
        n = max(1, int(max(abs(x1 - x0), abs(y1 - y0))))
        for s in range(n + 1):
            disc(x0 + (x1 - x0) * s / n, y0 + (y1 - y0) * s / n, THICK, 0)

    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "twotier.png")
    write_png(out, W, H, img)
    print(out)


if __name__ == "__main__":
    main()
