#!/usr/bin/env python3
"""Draws the silhouette mask of the silhouette-guided space-colonization preset (Liu et al.
2020 §4.3, silhouette-based modelling: markers are generated around the masked pixels):

  sc-elm-mask.png   the vase-shaped crown of an open-grown American elm, seen from the
                    front: narrow where the limbs leave the trunk, flaring out and up into a
                    broad, scalloped, flat-rounded top; crown only (the trunk below it is grown
                    straight by trunk_length); white on black, 180 x 150 px, axis at column 90
                    (sc-silhouette-elm.toml: height = 15 m, so 10 cm a pixel)

Standard library only; deterministic. Run from anywhere:
    python3 species/sketches/make_sc_masks.py
"""
import math
import os

from png import write_png

HERE = os.path.dirname(os.path.abspath(__file__))


# --- elm: 180 x 150 px, 10 cm a pixel, axis at column 90 -----------------------------------
W, H = 180, 150
AXIS = 90.0
BASE = 3.2   # metres: where the crown starts (the limbs leave the trunk)
FLARE = 11.0  # metres: the widest point of the vase
TOP = 14.6    # metres: the top of the crown
HALF = 7.4    # metres: the crown's half-width at its widest


def half_width(h):
    """Half-width of the crown (metres) at height h (metres), 0 outside the crown."""
    if h < BASE or h > TOP:
        return 0.0
    if h <= FLARE:
        # The vase: a narrow fork flaring out, concave (limbs arching up and out).
        t = (h - BASE) / (FLARE - BASE)
        return 0.5 + (HALF - 0.5) * t ** 1.6
    # The top: a flattened half-ellipse over the widest point.
    t = (h - FLARE) / (TOP - FLARE)
    return HALF * math.sqrt(max(0.0, 1.0 - t * t))


def inside(x, h):
    """x: metres from the axis, h: metres above the ground."""
    w = half_width(h)
    if w <= 0.0:
        return False
    # A scalloped outline (clumps of foliage at the branch ends), irregular but fixed: a few
    # sines of the angle about the crown's centre, stronger on the upper outline.
    a = math.atan2(h - 9.0, x)
    scallop = 0.35 * math.sin(7 * a + 0.6) + 0.22 * math.sin(11 * a + 2.1) + 0.12 * math.sin(
        17 * a + 0.3)
    scallop *= min(1.0, max(0.0, (h - BASE - 2.0) / 3.0))  # the narrow fork stays smooth
    return abs(x) <= w + scallop


def main():
    mpp = 0.1
    pixels = []
    for row in range(H):
        h = (H - row - 0.5) * mpp
        for col in range(W):
            x = (col + 0.5 - AXIS) * mpp
            pixels.append(255 if inside(x, h) else 0)
    write_png(os.path.join(HERE, "sc-elm-mask.png"), W, H, pixels)


if __name__ == "__main__":
    main()
