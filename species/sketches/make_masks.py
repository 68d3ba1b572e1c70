#!/usr/bin/env python3
"""Draws the silhouette masks of the mask presets (Liu et al. 2020 §4.3, silhouette-based
modelling), and the empty mask of the bad-spec fixture:

  oak-mask.png          rounded, lobed oak crown on a trunk, white on black
                        (xm-mask-oak.toml, type = "mask-revolution")
  acacia-front.png      wide, flat-topped acacia crown on a forked trunk, seen from the front
  acacia-side.png       the same tree from the side: a narrower crown, a straight trunk;
                        both black on white (invert = true) (xm-mask-acacia.toml, "visual-hull")
  ../../tests/data/bad/empty_mask.png   8 x 8, all black: a mask with no inside pixel

Standard library only; deterministic. Run from anywhere:
    python3 species/sketches/make_masks.py
"""
import math
import os

from png import write_png

HERE = os.path.dirname(os.path.abspath(__file__))


def rasterise(width, height, inside, on=255, off=0):
    """A mask whose pixel (x, y) is `on` where inside(x + 0.5, y + 0.5), rows top first."""
    return [on if inside(x + 0.5, y + 0.5) else off
            for y in range(height) for x in range(width)]


def in_ellipse(x, y, cx, cy, rx, ry):
    return ((x - cx) / rx) ** 2 + ((y - cy) / ry) ** 2 <= 1.0


def in_segment(x, y, ax, ay, bx, by, r0, r1):
    """Inside a tapered capsule from (ax, ay), radius r0, to (bx, by), radius r1."""
    dx, dy = bx - ax, by - ay
    t = max(0.0, min(1.0, ((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy)))
    px, py = ax + t * dx, ay + t * dy
    return math.hypot(x - px, y - py) <= r0 + (r1 - r0) * t


# --- oak: 160 x 200 px, axis at column 80 ---------------------------------------------------
OAK_W, OAK_H = 160, 200
# Crown: an ellipse fringed with lobes (the clumped outline of an open-grown oak), the lobes
# placed round the ellipse at irregular angles and sizes.
OAK_CROWN = (80.0, 78.0, 58.0, 52.0)            # centre x, y, radii x, y (pixels)
OAK_LOBES = [(-90, 21), (-58, 19), (-30, 22), (-5, 18), (22, 21), (48, 17), (75, 20),
             (105, 19), (135, 21), (160, 16), (185, 20), (212, 18), (238, 21), (262, 19)]


def oak_inside(x, y):
    cx, cy, rx, ry = OAK_CROWN
    if in_ellipse(x, y, cx, cy, rx, ry):
        return True
    for angle, r in OAK_LOBES:
        a = math.radians(angle)
        lx, ly = cx + (rx - 8) * math.cos(a), cy + (ry - 8) * math.sin(a)
        if math.hypot(x - lx, y - ly) <= r:
            return True
    # Trunk from the ground into the crown, flaring at the root.
    if abs(x - 80) <= 6.5 and y >= 110:
        return True
    return y >= 188 and abs(x - 80) <= 6.5 + (y - 188) * 0.5


# --- acacia: 200 x 160 px front, 140 x 160 px side, axis at the centre column -------------
AC_H = 160
AC_TOP, AC_BASE = 24, 62            # crown rows: flat top, underside at the middle


def acacia_crown(x, y, cx, half):
    """Flat top, straight-ish sides rounding into a shallow, slightly sagging underside."""
    if y < AC_TOP or y > AC_BASE + 6:
        return False
    u = (x - cx) / half                                  # −1 .. 1 across the crown
    if abs(u) > 1.0:
        return False
    underside = AC_BASE + 6 * (1 - u * u) - 30 * max(0.0, abs(u) - 0.75) ** 2 * 4
    top = AC_TOP + 14 * max(0.0, abs(u) - 0.82) ** 2 / 0.0324  # rounded top corners
    return top <= y <= underside


def acacia_front_inside(x, y):
    cx = 100.0
    if acacia_crown(x, y, cx, 92.0):
        return True
    # Trunk forking into three limbs that reach the crown's underside.
    if in_segment(x, y, cx, AC_H, cx, 112, 9.0, 8.0):
        return True
    for bx in (42.0, 100.0, 158.0):
        if in_segment(x, y, cx, 114, bx, AC_BASE, 8.0, 6.0):
            return True
    return False


def acacia_side_inside(x, y):
    cx = 70.0
    if acacia_crown(x, y, cx, 58.0):
        return True
    if in_segment(x, y, cx, AC_H, cx, 112, 9.0, 8.0):
        return True
    for bx in (40.0, 100.0):
        if in_segment(x, y, cx, 114, bx, AC_BASE, 8.0, 6.0):
            return True
    return False


def main():
    write_png(os.path.join(HERE, "oak-mask.png"), OAK_W, OAK_H,
              rasterise(OAK_W, OAK_H, oak_inside))
    # Black drawings on white paper: the presets read them with invert = true.
    write_png(os.path.join(HERE, "acacia-front.png"), 200, AC_H,
              rasterise(200, AC_H, acacia_front_inside, on=0, off=255))
    write_png(os.path.join(HERE, "acacia-side.png"), 140, AC_H,
              rasterise(140, AC_H, acacia_side_inside, on=0, off=255))
    bad = os.path.join(HERE, "..", "..", "tests", "data", "bad", "empty_mask.png")
    write_png(os.path.normpath(bad), 8, 8, [0] * 64)


if __name__ == "__main__":
    main()
