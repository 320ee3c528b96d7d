"""A/B benchmark of two checkouts of pyrt, interleaved, each in its own process.

Runs ``tools/bench.py``'s main scene (83k-triangle displaced sphere, ground, mirror ball, three lights,
640x480, 1 spp) in every tree alternately (A B, B A, A B, ...): each process builds the scene, warms up, and
reports the median of 3 timed renders and of Embree alone on the same recorded rays (``bench.measure``). The
tree's own ``pyrt`` and kernels are imported (``pyrt.shaders`` from the tree's ``shaders/``, or the top-level
``shaders`` package of trees from before the restructuring). Prints every round and the medians.

Usage: python tools/experiments/ab_trees.py TREE_A TREE_B [--rounds 8]
   e.g. git worktree add /tmp/before 283530d && python tools/experiments/ab_trees.py /tmp/before .
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))   # tools/, for _trees
from _trees import TREE_PREAMBLE  # noqa: E402  (tools/_trees.py)

SNIPPET = TREE_PREAMBLE + r'''
sys.path.insert(1, os.path.join(_TREE, "tools"))
import bench, pyrt
pyrt.render(bench.make_scene(bench.bumpy_sphere(2), 64, 48))
e2e, emb, _, _ = bench.measure(bench.make_scene(bench.bumpy_sphere(6)), 3)
print(json.dumps({"pyrt": e2e, "embree": emb, "file": pyrt.__file__}))
'''


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trees", nargs=2)
    ap.add_argument("--rounds", type=int, default=8)
    args = ap.parse_args(argv)
    trees = [os.path.abspath(t) for t in args.trees]
    res = {t: [] for t in trees}
    for r in range(args.rounds):
        for t in (trees if r % 2 == 0 else trees[::-1]):
            env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "PYTHONPATH": t}
            out = subprocess.run([sys.executable, "-c", SNIPPET, t], capture_output=True, text=True, env=env, cwd=t)
            if out.returncode:
                sys.exit(f"{t}: {out.stderr.strip()[-1500:]}")
            d = json.loads(out.stdout.strip().splitlines()[-1])
            res[t].append(d)
            print(f"{t}: pyrt {d['pyrt']:.3f} s, Embree only {d['embree']:.3f} s, ratio {d['pyrt'] / d['embree']:.2f}",
                  flush=True)
    for t, rows in res.items():
        p = statistics.median(d["pyrt"] for d in rows)
        e = statistics.median(d["embree"] for d in rows)
        ratios = statistics.median(d["pyrt"] / d["embree"] for d in rows)
        print(f"{t}: median pyrt {p:.3f} s, Embree only {e:.3f} s, ratio {ratios:.2f} ({len(rows)} rounds)")


if __name__ == "__main__":
    main()
