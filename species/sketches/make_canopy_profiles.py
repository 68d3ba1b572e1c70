#!/usr/bin/env python3
"""Draws the base layers g0 of the conical canopy envelopes of the library's canopy species
(Shesh et al. §3.2: "design overall shape of the tree canopy by creating image for g_0 and
choosing a domain"). In the conical domain the surface at height fraction t below the apex
(t = theta / pi: 0 at the apex, 1 at the base) lies rho = t * f * k from the axis, so a crown
profile rho(t) in metres is drawn as f(t) = rho(t) / (t * K), with K the envelope's radius k_x
= k_z written in the species file (chosen here so f stays within [0, 1]):

  canopy-birch-ovoid.png       silver birch: a narrow egg, pointed at the top, widest at 62 %
                               down (3.2 m), rounding in to 0.8 m at the crown base.
                               K = 8.6 m.
  canopy-cedar-tiers.png       cedar of Lebanon: a flat top and four broad flat plates of
                               foliage (6, 7.5, 8.5 and 9 m out, 1.4-2 m thick) on a trunk
                               region 1.2 m wide between them. K = 75 m.
  canopy-stone-pine-umbrella.png  stone pine: a flat dome 7 m in radius over the top 30 %, its
                               underside closing in to 5 m at 45 % down, then a funnel that
                               narrows to 1.6 m at the base (where the limbs rise; the species
                               leaves it bare with open_base). K = 38.5 m.

Each is 64 x 128 grey (u across, row 0 at the apex), with a gentle wobble in u (a fixed-seed
LCG) so tiers and rims are not perfectly round. Standard library only; deterministic:
    python3 species/sketches/make_canopy_profiles.py
"""
import math
import os

from lcg import Lcg
from png import write_png

HERE = os.path.dirname(os.path.abspath(__file__))
WIDTH, HEIGHT = 64, 128


def smoothstep(a, b, x):
    s = min(1.0, max(0.0, (x - a) / (b - a)))
    return s * s * (3 - 2 * s)


def birch(t):
    top, widest, base = 0.62, 3.2, 0.8
    if t <= top:
        return widest * math.sin(0.5 * math.pi * t / top)
    return base + (widest - base) * math.cos(0.5 * math.pi * (t - top) / (1 - top)) ** 0.7


def cedar(t):
    trunk = 1.2
    # (top, bottom, radius) of each plate, t from the apex; the top plate makes the flat top.
    plates = [(0.06, 0.15, 6.0), (0.28, 0.37, 7.5), (0.49, 0.58, 8.5), (0.71, 0.81, 9.0)]
    rho = 0.0 if t < 0.06 else trunk
    for a, b, r in plates:
        edge = 0.025  # the rounded rim of a plate
        rho = max(rho, r * smoothstep(a, a + edge, t) * (1 - smoothstep(b - edge, b, t)))
    return rho


def stone_pine(t):
    dome, under, radius, neck, base = 0.3, 0.45, 7.0, 5.0, 1.6
    if t <= dome:
        return radius * math.sin(0.5 * math.pi * t / dome)
    if t <= under:
        return neck + (radius - neck) * math.cos(0.5 * math.pi * (t - dome) / (under - dome))
    return base + (neck - base) * (1 - t) / (1 - under)


def draw(name, profile, k, wobble, seed):
    rng = Lcg(seed)
    # A wobble in u: a few random harmonics, the same for every row (a tilt of the whole
    # profile), scaled by `wobble`.
    harmonics = [(n, rng.uniform(0, 2 * math.pi), rng.uniform(0.3, 1.0)) for n in (1, 2, 3)]
    px = []
    for r in range(HEIGHT):
        t = (r + 0.5) / HEIGHT
        for c in range(WIDTH):
            u = (c + 0.5) / WIDTH
            w = sum(a * math.sin(2 * math.pi * n * u + p) for n, p, a in harmonics) / 3
            f = profile(t) * (1 + wobble * w) / (t * k)
            px.append(max(0, min(255, int(round(255 * f)))))
    write_png(os.path.join(HERE, name), WIDTH, HEIGHT, px)


if __name__ == "__main__":
    draw("canopy-birch-ovoid.png", birch, 8.6, 0.05, 11)
    draw("canopy-cedar-tiers.png", cedar, 75.0, 0.06, 12)
    draw("canopy-stone-pine-umbrella.png", stone_pine, 38.5, 0.04, 13)
