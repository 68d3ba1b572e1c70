#!/usr/bin/env python3
"""The sim-to-real benchmark's plumbing (bench/sim2real.py) with a known answer.

Usage: test_sim2real.py SYLVA SOURCE_DIR

No hand-labelled real tree can ship with sylva (bench/data/real/README.md), so the "real" tree
here is one of the simulated trees themselves, written out as a text file (x y z label) and
read back through the real-tree path: the classifier trained on the simulated trees, this one
among them, must then score it well (balanced accuracy >= 0.8, mIoU >= 0.7, its wood share
read back), and training on it (spatial blocks of the one tree) too; with its wood and leaf
labels swapped, the same classifier must score it badly (<= 0.3). A reader that misplaced a
column, a label mapping turned round or features computed differently on the two paths fails
one of them.
Runs `--quick` (3 species, one tree each: about a minute on 2 cores).
"""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def run(source, sylva, out, *extra):
    cmd = ["/usr/bin/python3", str(source / "bench" / "sim2real.py"), "--quick", "--sylva",
           sylva, "--out", str(out), *extra]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, (cmd, r.stdout[-3000:], r.stderr[-3000:])
    res = json.loads((out / "results.json").read_text())
    assert (out / "results.md").is_file()
    return res, r.stdout


def main():
    sylva, source = sys.argv[1], Path(sys.argv[2]).resolve()
    sys.path.insert(0, str(source / "python"))
    from sylva_dataset import read_las

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        out = tmp / "out"
        # Sim alone: the build, the features and sim -> sim (leave one species out).
        res, _ = run(source, sylva, out)
        assert not res["real_trees"], res["real_trees"]
        s2s = res["experiments"]["sim_to_sim"]["all"]["pooled"]
        assert 0.55 <= s2s["balanced_accuracy"] <= 1.0, s2s
        las_files = sorted((out / "sim" / "trees").glob("*/*/scan.las"))
        assert len(las_files) == 3, las_files

        # One simulated tree as the "real" one: x y z label (2 wood, 3 leaf; ground dropped).
        las = read_las(las_files[1])
        sem = las["semantic_seg"]
        keep = sem >= 2
        assert 0.02 < np.mean(sem[keep] == 2) < 0.9
        real = tmp / "tree.txt"
        np.savetxt(real, np.column_stack([las.positions[keep], sem[keep]]),
                   fmt="%.4f %.4f %.4f %d")

        res, log = run(source, sylva, out, "--real", str(real), "--real-label", "3",
                       "--real-wood", "2", "--real-leaf", "3")
        assert len(res["real_trees"]) == 1, res["real_trees"]
        s2r = res["experiments"]["sim_to_real"]["all"]["pooled"]
        assert s2r["balanced_accuracy"] >= 0.8, s2r
        assert s2r["miou"] >= 0.7, s2r
        assert abs(s2r["wood_share"] - np.mean(sem[keep] == 2)) < 0.05, s2r
        r2r = res["experiments"]["real_to_real"]["all"]["pooled"]
        assert r2r["balanced_accuracy"] >= 0.7, r2r
        assert "KS sim vs real" in log, log[-2000:]

        swapped, _ = run(source, sylva, out, "--real", str(real), "--real-label", "3",
                         "--real-wood", "3", "--real-leaf", "2")
        bad = swapped["experiments"]["sim_to_real"]["all"]["pooled"]
        assert bad["balanced_accuracy"] <= 0.3, bad
    print("sim2real: sim -> sim BA %.3f; a sim tree read as real: BA %.3f (labels swapped: %.3f)"
          % (s2s["balanced_accuracy"], s2r["balanced_accuracy"], bad["balanced_accuracy"]))


if __name__ == "__main__":
    main()
