#!/usr/bin/env python3
"""Draws the 2-D functions g_i of the canopy-envelope presets (Shesh et al. §3.2-3.3.1):

  canopy-maple-base.png    g0 of xm-canopy-maple.toml, 128 x 64 grey: 0.45 everywhere with a
                           bright longitudinal band at u = 0 (phi = 0, the +x side), spread
                           smoothly over the domain, so the canopy is lopsided towards +x
                           (the base layer of the paper's Figure 4(c) maple, lower inset).
  canopy-maple-blobs.png   three functions packed in one RGB image (128 x 128), "constant-
                           colour ellipses" softened into Gaussian bumps (§3.3.1: smooth
                           variations, no sharp edges, look better): R = five large ellipses,
                           G = eight medium ones, B = twelve small ones. A layer picks one
                           with `channel = 0, 1, 2` (the maple uses R as g1 and G as g3).
  canopy-pine-tiers.png    g0 of xm-canopy-pine.toml (conical domain, Figure 4(b)), 64 x 128
                           grey: six tiers down the cone (theta = 0 at the apex, pi at the
                           base), each widening downwards from 0.55 to 1 and dropping back
                           at the next tier (the shelves of a conifer's whorls), with a gentle
                           wobble in u so the tiers are not perfectly level or round.

Image coordinates are the envelope's (u, v) = (phi / 2 pi, theta / pi): columns across u, row 0
at theta = 0 (the top). Functions wrap in u (and, tiled, in v), so the ellipses wrap too.

Standard library only; deterministic (a fixed-seed LCG, not the random module). Run from
anywhere:
    python3 species/sketches/make_canopy_layers.py
"""
import math
import os

from lcg import Lcg
from png import write_png

HERE = os.path.dirname(os.path.abspath(__file__))


def wrap(d):
    d = abs(d) % 1.0
    return min(d, 1.0 - d)


def to_byte(x):
    return max(0, min(255, int(round(255 * x))))


def base_layer(width=128, height=64):
    # A white vertical line at u = 0 spread smoothly (Gaussian in u, sigma 0.16), strongest
    # at mid height and fading towards the poles so the lopsidedness is a girth effect.
    px = []
    for r in range(height):
        v = (r + 0.5) / height
        pole = math.sin(math.pi * v) ** 0.5
        for c in range(width):
            u = (c + 0.5) / width
            band = math.exp(-wrap(u) ** 2 / (2 * 0.16**2))
            px.append(to_byte(0.45 + 0.55 * band * pole))
    return px


def ellipses(rng, count, size, width, height):
    """count soft ellipses: a Gaussian bump over each (0.14 at the ellipse's rim), joined by a
    probabilistic OR, 1 - prod(1 - b), so overlaps stay smooth and below 1; wrapping."""
    shapes = []
    for _ in range(count):
        shapes.append((rng.uniform(), rng.uniform(0.1, 0.9), size * rng.uniform(0.7, 1.3),
                       size * rng.uniform(0.5, 0.9), rng.uniform(0, math.pi)))
    out = []
    for r in range(height):
        v = (r + 0.5) / height
        for c in range(width):
            u = (c + 0.5) / width
            miss = 1.0
            for (cu, cv, a, b, angle) in shapes:
                du = (u - cu + 0.5) % 1.0 - 0.5
                dv = (v - cv + 0.5) % 1.0 - 0.5
                x = du * math.cos(angle) + dv * math.sin(angle)
                y = -du * math.sin(angle) + dv * math.cos(angle)
                d = math.sqrt((x / a) ** 2 + (y / b) ** 2)  # 1 on the ellipse's rim
                miss *= 1.0 - math.exp(-2.0 * d * d)
            out.append(1.0 - miss)
    return out


def blob_layers(width=128, height=128):
    rng = Lcg(20230607)
    channels = [ellipses(rng, 5, 0.22, width, height),
                ellipses(rng, 8, 0.16, width, height),
                ellipses(rng, 12, 0.12, width, height)]
    px = []
    for i in range(width * height):
        for ch in channels:
            px.append(to_byte(ch[i]))
    return px


def pine_tiers(width=64, height=128, tiers=6):
    rng = Lcg(4242)
    wobble = [(rng.uniform(0.04, 0.1), rng.uniform(0, 2 * math.pi), 1 + int(rng.uniform(1, 4)))
              for _ in range(tiers)]
    px = []
    for r in range(height):
        v = (r + 0.5) / height
        k = min(tiers - 1, int(v * tiers))
        t = v * tiers - k                      # 0 at a tier's top, 1 at its bottom
        amp, phase, lobes = wobble[k]
        for c in range(width):
            u = (c + 0.5) / width
            skirt = t ** 1.5 + amp * math.sin(2 * math.pi * lobes * u + phase)
            px.append(to_byte(0.55 + 0.45 * min(1.0, max(0.0, skirt))))
    return px


def main():
    write_png(os.path.join(HERE, "canopy-maple-base.png"), 128, 64, base_layer())
    write_png(os.path.join(HERE, "canopy-maple-blobs.png"), 128, 128, blob_layers(), channels=3)
    write_png(os.path.join(HERE, "canopy-pine-tiers.png"), 64, 128, pine_tiers())


if __name__ == "__main__":
    main()
