#!/usr/bin/env python3
"""Reference distributions of broadleaf tree architecture from published TreeQSM models.

A recipe, not run in CI: it writes species/reference/treeqsm-broadleaf.json (quantile tables
that `sylva stats DIR --reference FILE` compares a dataset's species with). The QSM files are
not in the repository; bring them here from the public repositories in TREES (cited in
species/reference/README.md): clone each (TobyDJackson/treeRchitecture, zoeschindler/qsm2r,
aidanmorales/rTwig, lmterryn/ITSMe from GitHub) and write every .mat file it ever committed
(treeRchitecture keeps most of its trees only in its history) to DATA/<repository>/ under its
path with '/' replaced by '_', the newest version of a path last:

    extract() {  # extract REPO_GIT_DIR OUT_DIR
        mkdir -p "$2"
        git -C "$1" rev-list --all --reverse | while read c; do git -C "$1" ls-tree -r $c; done |
            awk '$4 ~ /[.]mat$/ {print $3, $4}' | awk '!seen[$0]++' | while read blob path; do
                git -C "$1" cat-file blob $blob > "$2/$(echo $path | tr / _)" || true; done
    }
    for r in treeRchitecture qsm2r rTwig ITSMe; do extract $r DATA/$r; done

then
    /usr/bin/python3 scripts/reference_from_treeqsm.py DATA \
        --out species/reference/treeqsm-broadleaf.json --markdown TABLE.md --split

The temperate set (species/reference/treeqsm-temperate.json, 21 Wytham Woods trees; no split:
no species is fitted to it, so all of it is held out) comes from one zip in
TobyDJackson/WindAndTrees_FEM:

    git -C WindAndTrees_FEM show HEAD:Wytham_QSMs_GitHub.zip > w.zip
    unzip -q w.zip -d DATA/WindAndTrees_FEM
    /usr/bin/python3 scripts/reference_from_treeqsm.py DATA --set temperate \
        --out species/reference/treeqsm-temperate.json --markdown TABLE.md

With --split it also writes treeqsm-broadleaf-fit.json and treeqsm-broadleaf-holdout.json next
to --out: the same tables over two fixed halves of the trees (SPLIT_RULE below: stratified by
source and height, 26 trees fit, 25 held out; each file's "split" names the rule and its trees,
its "trees", "sources" and n/trees counts are its half's), for fitting species to one half and
judging them on the other. It prints the two-sample KS distance between the halves per
distribution — the noise floor a model cannot be expected to beat on the held-out trees — both
between the tree-weighted samples and between the two quantile tables as `sylva stats` reads
them; --random-splits N adds its median and 90th percentile over N random splits of the same
sizes per source.

Needs numpy and scipy (Debian: python3-numpy python3-scipy; scipy.io.loadmat reads the .mat
files). TreeQSM's cylinder fields (treeqsm.m): radius, length (m), start (xyz, z up), axis
(unit), parent (1-based index of the parent cylinder, 0 for none), extension (the cylinder
continuing the same branch, 0 for none), branch (index of the cylinder's branch), BranchOrder
(0 stem, 1 branches from the stem, ...), PositionInBranch (1 for a branch's first cylinder).
TreeQSM 2.0 files store the same as Rad, Len, Sta, Axe, CPar, CExt and BoC = (branch, order,
position in branch).

Definitions (the same as species/model/reference_metrics.cpp applies to a sylva skeleton;
docs/metrics.md "Reference distributions"):
  fork            a cylinder with >= 2 child cylinders (cylinders naming it as parent); its
                  *laterals* are the children that begin another branch (branch differs), the
                  *extension* the child continuing its branch.
  capped fork     TreeQSM caps a branch's cylinders at 0.95 x the radius of the cylinder it
                  leaves (cylinders.m, adjustments: MaxR = 0.95*parcyl.radius): a fork with a
                  lateral of ratio >= 0.949 is left out of (a) and (b).
  (a) radius_ratio        per lateral of an uncapped fork: r_lateral / r_parent.
  (b) radius_exponent     per uncapped fork: n in [0.5, 6] with r_parent^n = sum r_child^n over
                          every child (bisection, as sylva's radiusExponent); only forks with
                          0 < r_child < r_parent for every child.
  (c) branch_angle_deg    per order-1 branch: angle between the axis of the stem cylinder it
                          leaves and the axis of its first cylinder.
  (d) tip_path_ratio      per tip (a cylinder without children): the length along the
                          cylinders from the base (start of the first cylinder) to the tip's end,
                          over the tree height. A child leaves its parent at the projection of
                          its start on the parent's axis, not at the parent's end.
  (e) branch_length_order{1,2,3}  per branch of that order: the sum of its cylinders' lengths
                          over the tree height.
  (f) tip_height_ratio    per tip: the height of the tip's end above the base over the tree
                          height (with (d): how far a tip's path exceeds its height).
  tree height     highest cylinder end (or start) above the base, along z.

Pooling: every tree has the same total weight (a tree's values weigh 1/n_tree each), so the
large high-resolution models do not outweigh the rest (one walnut has 1,128 forks, the median
tropical model 50); a tree joins a distribution only with >= MIN_VALUES values of it.
Quantiles of the weighted distribution interpolate linearly between the sorted values at
cumulative-weight midpoints (numpy's linear / R's type 7 for equal weights).
"""
import argparse
import json
import math
import os
import sys

import numpy as np
import scipy.io as sio

# Every tree of the reference: (source, path under DATA/<source>/, variable, species, note).
# treeRchitecture: Jackson et al.'s tropical broadleaf QSMs (LPG01: Lope, Gabon; SEP09:
# Sepilok, Sabah), wood models (*_wood, *wnb). The four LPG01_<n>.mat without _wood are the same
# trees (same base) modelled again with 3-5 times the cylinder length, presumably before the
# leaves were separated from the wood; they are left out.
_TR = ["example_data_LPG01_%d_wood.mat" % i
       for i in (0, 1, 4, 5, 7, 8, 9, 10, 26, 27, 29, 30, 31, 34, 35, 37, 38, 39, 40, 42)]
_TR += ["example_data_SEP09_%dwnb.mat" % i
        for i in (3, 5, 6, 8, 9, 11, 12, 13, 98, 99, 100, 101, 102, 103, 104, 105, 106, 800, 801,
                  802, 803, 804, 805)]
TREES = [("treeRchitecture", f, "qsm", "tropical broadleaf (Gabon, Malaysian Borneo)", "")
         for f in _TR]
TREES += [
    ("qsm2r", "inst_extdata_QSM_Juglans_regia_S.mat", "OptQSM", "Juglans regia", ""),
    ("qsm2r", "inst_extdata_QSM_Juglans_regia_M.mat", "OptQSM", "Juglans regia", ""),
    ("rTwig", "inst_extdata_QSM.mat", "OptQSM", "Gymnocladus dioicus", ""),
    # ITSMe's example and test QSMs: one model per distinct tree (the repeated models of the
    # same tree — buttressed_tree_*_qsm_2/3, the QSMs arrays, qsm_tree_v230*, qsms_* — the
    # trunk-only qsm_trunk, the TreeQSM 2.0 qsm_tree_v200 and single_qsm/tree_1, a trunk with
    # two stubs and one fork, are left out).
    ("ITSMe", "inst_extdata_example_qsm_1_1.mat", "QSM", "broadleaf", ""),
    ("ITSMe", "tests_buttressed_trees_buttressed_tree_1_qsm_1.mat", "QSM", "tropical broadleaf",
     "buttressed"),
    ("ITSMe", "tests_buttressed_trees_buttressed_tree_2_qsm_1.mat", "QSM", "tropical broadleaf",
     "buttressed"),
    ("ITSMe", "tests_non_buttressed_trees_single_qsm_tree_2_qsm.mat", "QSM", "broadleaf", ""),
    ("ITSMe", "tests_qsms_qsm_tree_v240.mat", "QSM", "broadleaf", ""),
]

# A second, separate reference (--set temperate, species/reference/treeqsm-temperate.json): 21
# temperate broadleaves of Wytham Woods (Oxfordshire, UK) that Jackson et al. 2019 fitted with
# TreeQSM for their finite-element study, from TobyDJackson/WindAndTrees_FEM's
# Wytham_QSMs_GitHub.zip (unzipped into DATA/WindAndTrees_FEM/, paths as in the zip). Each model
# is a TreeQSM 2.x cylinder matrix CylData_updated. Seven trees were modelled from a leaf-off and
# a leaf-on scan; the leaf-off model is used (the leaf-on ones fit leaves as extra twigs). The
# site's trees are ash, sycamore and English oak (Jackson et al. 2018, Front. For. Glob. Change
# 1:13); the repository does not say which tree is which.
_WY = ["Wytham_QSMs_GitHub/cyl_data_Tf%s_Validation_1_1.mat" % t
       for t in ["1_LeafOff", "2_LeafOff", "3_LeafOff"] + [str(i) for i in range(4, 18)]
       + ["18_LeafOff", "19_LeafOff", "20_LeafOff", "21_LeafOff"]]
TEMPERATE = [("WindAndTrees_FEM", f, "CylData_updated",
              "temperate broadleaf (Wytham Woods, UK: ash, sycamore, oak)", "") for f in _WY]

SOURCES = {
    "treeRchitecture": ("TobyDJackson/treeRchitecture",
                        "Jackson et al. 2021, Biotropica 53(1):110-120; Verbeeck et al. 2019, "
                        "Front. For. Glob. Change 2:43"),
    "qsm2r": ("zoeschindler/qsm2r", "Schindler 2023, qsm2r, doi:10.5281/zenodo.14871356"),
    "rTwig": ("aidanmorales/rTwig", "Morales & MacFarlane 2024, Forestry 98(3):394-409, "
                                    "doi:10.1093/forestry/cpae046"),
    "ITSMe": ("lmterryn/ITSMe", "Terryn et al. 2020, ISPRS J. Photogramm. Remote Sens. "
                                "168:170-181"),
    "WindAndTrees_FEM": ("TobyDJackson/WindAndTrees_FEM",
                         "Jackson et al. 2019, Agric. For. Meteorol. 265:137-144, "
                         "doi:10.1016/j.agrformet.2018.11.014"),
}
MIN_VALUES = 5  # a tree joins a distribution with at least this many values of it
CAP_RATIO = 0.949  # TreeQSM's 0.95 cap on a branch's radius relative to its parent cylinder
THICK_FORK = 0.02  # m: forks this thick or more are counted for the thickest child's share
DISTRIBUTIONS = [
    ("radius_ratio", "-", "r_lateral / r_parent at uncapped forks, per lateral child"),
    ("radius_exponent", "-", "n in [0.5, 6] with r_parent^n = sum r_child^n, per uncapped fork"),
    ("branch_angle_deg", "deg", "angle between the stem and an order-1 branch's first segment"),
    ("tip_path_ratio", "-", "path length from the base to a tip / tree height, per tip"),
    ("branch_length_order1", "-", "length of an order-1 branch / tree height"),
    ("branch_length_order2", "-", "length of an order-2 branch / tree height"),
    ("branch_length_order3", "-", "length of an order-3 branch / tree height"),
    ("tip_height_ratio", "-", "height of a tip's end above the base / tree height, per tip"),
]


class Qsm:
    """Cylinders of one TreeQSM model as numpy arrays (0-based parent, -1 for none)."""

    def __init__(self, radius, length, start, axis, parent, branch, order):
        self.radius = np.asarray(radius, float).ravel()
        self.length = np.asarray(length, float).ravel()
        self.start = np.atleast_2d(np.asarray(start, float))
        axis = np.atleast_2d(np.asarray(axis, float))
        self.axis = axis / np.linalg.norm(axis, axis=1)[:, None]
        self.parent = np.asarray(parent, int).ravel() - 1
        self.branch = np.asarray(branch, int).ravel()
        self.order = np.asarray(order, int).ravel()
        n = len(self.radius)
        assert all(len(a) == n for a in (self.length, self.start, self.axis, self.parent,
                                          self.branch, self.order))


def load_qsm(path, var):
    m = sio.loadmat(path, squeeze_me=True, struct_as_record=False)
    if var == "CylData_updated" and var in m:
        # TreeQSM 2.x's cylinder matrix, one row per cylinder: radius, length, start (3), axis
        # (3), parent, extension, branch, order, position in branch, added (14 columns).
        c = np.asarray(m[var], float)
        if c.ndim != 2 or c.shape[1] < 13:
            raise SystemExit("%s: %s is %s, not a 13+ column cylinder matrix" %
                             (path, var, c.shape))
        return Qsm(c[:, 0], c[:, 1], c[:, 2:5], c[:, 5:8], c[:, 8], c[:, 10], c[:, 11])
    if var in m:
        q = m[var]
        if isinstance(q, np.ndarray):
            q = q.ravel()[0]
        c = q.cylinder
        return Qsm(c.radius, c.length, c.start, c.axis, c.parent, c.branch, c.BranchOrder)
    if "Rad" in m:  # TreeQSM 2.0
        boc = np.atleast_2d(m["BoC"])
        return Qsm(m["Rad"], m["Len"], m["Sta"], m["Axe"], m["CPar"], boc[:, 0], boc[:, 1])
    raise SystemExit("%s: no variable %r (has %s)" % (path, var,
                     ", ".join(k for k in m if not k.startswith("__"))))


def radius_exponent(rp, children):
    """sylva's radiusExponent (species/model/tree_metrics.cpp): NaN unless rp > 0, >= 2
    children, 0 < r < rp for each; roots outside [0.5, 6] clamp to the ends."""
    if not rp > 0 or len(children) < 2 or any(not (0 < r < rp) for r in children):
        return math.nan
    f = lambda n: sum((r / rp) ** n for r in children) - 1.0
    lo, hi = 0.5, 6.0
    if f(lo) <= 0:
        return lo
    if f(hi) >= 0:
        return hi
    for _ in range(100):
        if hi - lo <= 1e-13:
            break
        mid = 0.5 * (lo + hi)
        if f(mid) > 0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def measure(q):
    """The reference distributions of one tree, plus its counts."""
    n = len(q.radius)
    kids = [[] for _ in range(n)]
    roots = []
    for j in range(n):
        p = q.parent[j]
        if p < 0:
            roots.append(j)
        else:
            kids[p].append(j)
    end = q.start + q.axis * q.length[:, None]
    base = q.start[roots[0]]
    height = max(end[:, 2].max(), q.start[:, 2].max()) - base[2]
    out = {k: [] for k, _, _ in DISTRIBUTIONS}
    forks = capped = thick = steps = 0
    for c in range(n):
        if len(kids[c]) < 2:
            continue
        forks += 1
        rp = q.radius[c]
        lateral = [j for j in kids[c] if q.branch[j] != q.branch[c]]
        ratios = [q.radius[j] / rp for j in lateral]
        if any(r >= CAP_RATIO for r in ratios):
            capped += 1
            continue
        if rp >= THICK_FORK:
            thick += 1
            steps += max(q.radius[j] for j in kids[c]) < 0.5 * rp
        out["radius_ratio"] += ratios
        e = radius_exponent(rp, [q.radius[j] for j in kids[c]])
        if math.isfinite(e):
            out["radius_exponent"].append(e)
    # (c) first-order branch angles: a branch's first cylinder leaving a stem cylinder.
    for j in range(n):
        p = q.parent[j]
        if p >= 0 and q.order[j] == 1 and q.order[p] == 0 and q.branch[j] != q.branch[p]:
            cosang = float(np.clip(np.dot(q.axis[p], q.axis[j]), -1.0, 1.0))
            out["branch_angle_deg"].append(math.degrees(math.acos(cosang)))
    # (d) path length from the base to every tip (parents precede children in TreeQSM, but do
    # not rely on it: walk in topological order).
    dist = np.zeros(n)
    stack = list(roots)
    while stack:
        c = stack.pop()
        for j in kids[c]:
            along = float(np.dot(q.start[j] - q.start[c], q.axis[c]))
            dist[j] = dist[c] + min(max(along, 0.0), q.length[c])
            stack.append(j)
    for c in range(n):
        if not kids[c]:
            out["tip_path_ratio"].append((dist[c] + q.length[c]) / height)
            out["tip_height_ratio"].append((end[c, 2] - base[2]) / height)
    # (e) branch lengths by order.
    blen = {}
    for j in range(n):
        key = (q.branch[j], q.order[j])
        blen[key] = blen.get(key, 0.0) + q.length[j]
    for (b, o), l in sorted(blen.items()):
        if 1 <= o <= 3:
            out["branch_length_order%d" % o].append(l / height)
    counts = {"cylinders": n, "forks": forks, "capped_forks": capped, "height_m": height,
              "branches": len(blen), "thick_forks": thick, "step_forks": steps}
    return out, counts


def weighted_quantiles(groups, probs):
    """Quantiles of the pooled values where each group (tree) weighs 1 in total."""
    vals, wts = [], []
    for g in groups:
        if len(g):
            vals += list(g)
            wts += [1.0 / len(g)] * len(g)
    order = np.argsort(vals, kind="stable")
    v = np.asarray(vals)[order]
    w = np.asarray(wts)[order]
    if len(v) == 1:
        return [float(v[0])] * len(probs)
    c = np.cumsum(w) - 0.5 * w
    c = (c - c[0]) / (c[-1] - c[0])
    return [float(x) for x in np.interp(probs, c, v)]


def compact_json(x, indent=""):
    """JSON with one key per line but every list of numbers on one line."""
    inner = indent + "  "
    if isinstance(x, dict):
        items = ["%s%s: %s" % (inner, json.dumps(k), compact_json(v, inner)) for k, v in x.items()]
        return "{\n" + ",\n".join(items) + "\n" + indent + "}"
    if isinstance(x, list) and not all(isinstance(v, (int, float)) for v in x):
        return "[\n" + ",\n".join(inner + compact_json(v, inner) for v in x) + "\n" + indent + "]"
    return json.dumps(x)


def markdown_table(dists):
    """Quantiles as rows (min, 2 %, 5 %, 10 % ... 95 %, 98 %, max), distributions as columns."""
    rows = [0.0, 0.02] + [round(0.05 * k, 2) for k in range(1, 20)] + [0.98, 1.0]
    keys = [k for k, _, _ in DISTRIBUTIONS]
    out = "| p | " + " | ".join("`%s`" % k for k in keys) + " |\n"
    out += "|---|" + "---:|" * len(keys) + "\n"
    out += "| n (trees) | " + " | ".join("%d (%d)" % (dists[k]["n"], dists[k]["trees"])
                                         for k in keys) + " |\n"
    for p in rows:
        label = "min" if p == 0 else ("max" if p == 1 else "%g %%" % (100 * p))
        vals = []
        for k in keys:
            x = float(np.interp(p, dists[k]["p"], dists[k]["q"]))
            vals.append(("%.1f" if k == "branch_angle_deg" else "%.3f") % x)
        out += "| %s | %s |\n" % (label, " | ".join(vals))
    return out


SPLIT_RULE = (
    "by tree, stratified by source and height: the sources are taken from the fewest trees to "
    "the most (rTwig 1, qsm2r 2, ITSMe 5, treeRchitecture 43); within a source the trees are "
    "sorted by height (ascending, ties by file name) and dealt alternately to the two halves, "
    "starting with the half that has fewer trees so far (fit when equal). So rTwig's one tree "
    "goes to fit, the shorter walnut to holdout, ITSMe's 1st, 3rd and 5th by height to holdout, "
    "and treeRchitecture's 1st, 3rd, ... 43rd to fit: 26 trees fit, 25 holdout, each half with "
    "small and giant trees of every source it can have")


def split_trees(records):
    """The fit / holdout split of SPLIT_RULE: a list of 'fit' or 'holdout', one per record."""
    by_source = {}
    for i, r in enumerate(records):
        by_source.setdefault(r["source"], []).append(i)
    half = [None] * len(records)
    count = {"fit": 0, "holdout": 0}
    for source in sorted(by_source, key=lambda s: (len(by_source[s]), s)):
        idx = sorted(by_source[source],
                     key=lambda i: (records[i]["counts"]["height_m"], records[i]["file"]))
        first = "fit" if count["fit"] <= count["holdout"] else "holdout"
        second = "holdout" if first == "fit" else "fit"
        for k, i in enumerate(idx):
            half[i] = first if k % 2 == 0 else second
            count[half[i]] += 1
    return half


def distributions(records, probs, quiet=False):
    """The quantile tables of the records' trees (each tree weighs 1)."""
    dists = {}
    for key, unit, definition in DISTRIBUTIONS:
        groups = [r["values"][key] for r in records if len(r["values"][key]) >= MIN_VALUES]
        allv = [x for g in groups for x in g]
        qs = weighted_quantiles(groups, probs)
        dists[key] = {"unit": unit, "definition": definition, "n": len(allv),
                      "trees": len(groups), "min": min(allv), "max": max(allv),
                      "p": probs, "q": [round(x, 6) for x in qs]}
        if not quiet:
            print("%-22s n=%6d trees=%2d  q05 %.3f  q25 %.3f  q50 %.3f  q75 %.3f  q95 %.3f  "
                  "[%.3f, %.3f]" % (key, len(allv), len(groups), *[np.interp(p, probs, qs)
                                    for p in (0.05, 0.25, 0.5, 0.75, 0.95)],
                                    min(allv), max(allv)))
    return dists


def source_counts(records):
    sources = {}
    for r in records:
        s = sources.setdefault(r["source"], {"trees": 0, "cylinders": 0, "forks": 0,
                                             "capped_forks": 0, "species": []})
        s["trees"] += 1
        for k in ("cylinders", "forks", "capped_forks"):
            s[k] += r["counts"][k]
        if r["species"] not in s["species"]:
            s["species"].append(r["species"])
    return sources


def reference_json(records, dists, name, description, split=None):
    ref = {
        "name": name,
        "description": description,
        "derivation": "scripts/reference_from_treeqsm.py",
        "weighting": "every tree weighs 1 (each of its values 1/n_tree); a tree joins a "
                     "distribution with at least %d values of it" % MIN_VALUES,
        "quantiles": "p: probabilities (0 = min, 1 = max), q: quantiles of the "
                     "tree-weighted pooled values, linear between cumulative-weight "
                     "midpoints",
        "cap_ratio": CAP_RATIO,
        "trees": len(records),
    }
    if split is not None:
        ref["split"] = split
    ref["sources"] = [{"repository": SOURCES[src][0], "paper": SOURCES[src][1], **s}
                      for src, s in source_counts(records).items()]
    ref["distributions"] = dists
    return ref


def ks_weighted(groups_a, groups_b):
    """Exact two-sample KS distance between two tree-weighted samples (each group, a tree,
    weighs 1 in total): sup |F_a - F_b| of the weighted empirical step CDFs."""
    def cdf(groups):
        v = np.concatenate([np.asarray(g, float) for g in groups])
        w = np.concatenate([np.full(len(g), 1.0 / len(g)) for g in groups])
        o = np.argsort(v, kind="stable")
        return v[o], np.cumsum(w[o]) / w.sum()
    va, ca = cdf(groups_a)
    vb, cb = cdf(groups_b)
    x = np.union1d(va, vb)
    fa = np.concatenate([[0.0], ca])[np.searchsorted(va, x, side="right")]
    fb = np.concatenate([[0.0], cb])[np.searchsorted(vb, x, side="right")]
    return float(np.max(np.abs(fa - fb)))


def table_cdf(p, q, x, side):
    """The piecewise-linear CDF through the table's points (q_k, p_k), as `sylva stats` builds
    it (docs/metrics.md, "The KS distance"), at x from the left or the right."""
    p = np.asarray(p, float)
    q = np.asarray(q, float)
    if side == "right":
        if x < q[0]:
            return 0.0
        if x >= q[-1]:
            return 1.0
        k = int(np.searchsorted(q, x, side="right")) - 1
        return float(p[k] + (p[k + 1] - p[k]) * (x - q[k]) / (q[k + 1] - q[k]))
    if x <= q[0]:
        return 0.0
    if x > q[-1]:
        return 1.0
    k = int(np.searchsorted(q, x, side="left"))
    return float(p[k - 1] + (p[k] - p[k - 1]) * (x - q[k - 1]) / (q[k] - q[k - 1]))


def ks_tables(a, b):
    """KS distance between two quantile tables, both read as sylva reads a reference: the
    largest difference of their piecewise-linear CDFs at any knot, from either side."""
    d = 0.0
    for x in np.union1d(a["q"], b["q"]):
        for side in ("left", "right"):
            d = max(d, abs(table_cdf(a["p"], a["q"], x, side) -
                           table_cdf(b["p"], b["q"], x, side)))
    return d


def split_noise(records, halves, probs, random_splits, seed):
    """KS between the fit and holdout halves, per distribution, and the same over random
    splits of the same sizes per source (to show how much the floor itself varies)."""
    out = {}
    for key, _, _ in DISTRIBUTIONS:
        groups = {h: [r["values"][key] for r, hh in zip(records, halves)
                      if hh == h and len(r["values"][key]) >= MIN_VALUES]
                  for h in ("fit", "holdout")}
        out[key] = {"ks": ks_weighted(groups["fit"], groups["holdout"])}
    tabs = {h: distributions([r for r, hh in zip(records, halves) if hh == h], probs, True)
            for h in ("fit", "holdout")}
    for key in out:
        out[key]["ks_tables"] = ks_tables(tabs["fit"][key], tabs["holdout"][key])
    if random_splits:
        rng = np.random.default_rng(seed)
        by_source = {}
        for i, r in enumerate(records):
            by_source.setdefault(r["source"], []).append(i)
        n_fit = {s: sum(1 for i in idx if halves[i] == "fit") for s, idx in by_source.items()}
        ds = {key: [] for key in out}
        for _ in range(random_splits):
            fit = set()
            for s, idx in by_source.items():
                fit.update(rng.permutation(idx)[:n_fit[s]].tolist())
            for key in out:
                ga = [records[i]["values"][key] for i in range(len(records))
                      if i in fit and len(records[i]["values"][key]) >= MIN_VALUES]
                gb = [records[i]["values"][key] for i in range(len(records))
                      if i not in fit and len(records[i]["values"][key]) >= MIN_VALUES]
                ds[key].append(ks_weighted(ga, gb))
        for key in out:
            out[key]["random_median"] = float(np.median(ds[key]))
            out[key]["random_p90"] = float(np.quantile(ds[key], 0.9))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("data", help="directory with treeRchitecture/, qsm2r/, rTwig/, ITSMe/")
    ap.add_argument("--out", help="write the reference JSON here")
    ap.add_argument("--step", type=float, default=0.02, help="quantile step (default 0.02)")
    ap.add_argument("--per-tree", help="write a CSV of per-tree counts and medians here")
    ap.add_argument("--markdown", help="write the quantile table of docs/metrics.md here")
    ap.add_argument("--split", action="store_true",
                    help="also write <out>-fit.json and <out>-holdout.json next to --out (the "
                         "split by tree of SPLIT_RULE) and print the KS distance between them")
    ap.add_argument("--random-splits", type=int, default=0,
                    help="with --split: also KS over this many random splits of the same "
                         "sizes per source (seed 1)")
    ap.add_argument("--set", choices=["broadleaf", "temperate"], default="broadleaf",
                    help="broadleaf: the 51 trees of treeqsm-broadleaf.json (DATA holds "
                         "treeRchitecture/ ... ITSMe/); temperate: the 21 Wytham Woods trees of "
                         "treeqsm-temperate.json (DATA holds WindAndTrees_FEM/)")
    args = ap.parse_args()
    if args.split and not args.out:
        ap.error("--split needs --out")
    if args.split and args.set != "broadleaf":
        ap.error("--split splits the broadleaf set only")

    probs = [round(k * args.step, 10) for k in range(int(round(1 / args.step)) + 1)]
    records = []
    rows = []
    for source, name, var, species, note in (TREES if args.set == "broadleaf" else TEMPERATE):
        path = os.path.join(args.data, source, name)
        if not os.path.exists(path):
            raise SystemExit("%s: missing (see the recipe at the top of this script)" % path)
        values, counts = measure(load_qsm(path, var))
        records.append({"source": source, "file": name, "species": species, "values": values,
                        "counts": counts})
        row = {"source": source, "file": name, **counts}
        for k, _, _ in DISTRIBUTIONS:
            row[k + "_n"] = len(values[k])
            row[k + "_median"] = float(np.median(values[k])) if values[k] else math.nan
        rows.append(row)

    dists = distributions(records, probs)
    for src, s in source_counts(records).items():
        print("%-16s trees %3d  cylinders %6d  forks %5d (capped %d)" %
              (src, s["trees"], s["cylinders"], s["forks"], s["capped_forks"]))

    # A fork whose thickest child is under half its radius is a step in the axis (a stub under
    # sprouts); the library bounds its forks there (docs/specs.md, pipe_min_child_ratio).
    shares = [r["counts"]["step_forks"] / r["counts"]["thick_forks"] for r in records
              if r["counts"]["thick_forks"] >= MIN_VALUES]
    print("uncapped forks >= %g m whose thickest child is under half their radius: %.2f %% "
          "tree-weighted over %d trees (median tree %.2f %%)" %
          (THICK_FORK, 100 * np.mean(shares), len(shares), 100 * np.median(shares)))

    if args.per_tree:
        keys = list(rows[0].keys())
        with open(args.per_tree, "w") as f:
            f.write(",".join(keys) + "\n")
            for r in rows:
                f.write(",".join(("%.6g" % r[k]) if isinstance(r[k], float) else str(r[k])
                                 for k in keys) + "\n")
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write(markdown_table(dists))
    if args.out:
        if args.set == "broadleaf":
            ref = reference_json(records, dists, "treeqsm-broadleaf",
                                 "Broadleaf tree architecture from published TreeQSM models "
                                 "(terrestrial laser scans); see README.md for the sources")
        else:
            ref = reference_json(records, dists, "treeqsm-temperate",
                                 "Temperate broadleaf tree architecture: 21 trees of Wytham "
                                 "Woods (UK; ash, sycamore, oak) modelled by TreeQSM from "
                                 "terrestrial laser scans; never used to fit a species; see "
                                 "README.md")
        with open(args.out, "w") as f:
            f.write(compact_json(ref) + "\n")
    if args.split:
        halves = split_trees(records)
        stem = args.out[:-5] if args.out.endswith(".json") else args.out
        for h in ("fit", "holdout"):
            sub = [r for r, hh in zip(records, halves) if hh == h]
            print("\n%s half: %d trees" % (h, len(sub)))
            d = distributions(sub, probs)
            split = {"half": h, "rule": SPLIT_RULE,
                     "other_half": os.path.basename(stem) + "-" +
                                   ("holdout" if h == "fit" else "fit") + ".json",
                     "trees": ["%s/%s" % (r["source"], r["file"]) for r in sub],
                     "height_m": [round(r["counts"]["height_m"], 2) for r in sub]}
            ref = reference_json(sub, d, "treeqsm-broadleaf-" + h,
                                 "The %s half of treeqsm-broadleaf (51 TreeQSM broadleaf "
                                 "trees split by tree, see \"split\" and README.md)" % h,
                                 split)
            with open("%s-%s.json" % (stem, h), "w") as f:
                f.write(compact_json(ref) + "\n")
        noise = split_noise(records, halves, probs, args.random_splits, 1)
        print("\nKS distance, fit half vs holdout half (tree-weighted step CDFs; between the "
              "two quantile tables as sylva reads them%s):" %
              ("; median and 90 %% over %d random splits" % args.random_splits
               if args.random_splits else ""))
        for key, v in noise.items():
            extra = ("  random median %.3f  p90 %.3f" % (v["random_median"], v["random_p90"])
                     if "random_median" in v else "")
            print("  %-22s %.3f  tables %.3f%s" % (key, v["ks"], v["ks_tables"], extra))


if __name__ == "__main__":
    sys.exit(main())
