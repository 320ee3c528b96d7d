"""A/B of rendering one asset between two checkouts of pyrt, interleaved, each run in its own process.

The scene: the asset framed from (0.6, 0.4, 1) at three times its bounding radius, a grey background, a
directional and a point light (no previewer rig, no ground), 320x240, 4 spp. Each process loads the asset,
renders once to warm up, then reports the median of 3 timed ``pyrt.render`` calls (render time only) and the
image mean (a check that both trees render the same thing). Rounds alternate the order (A B, B A, ...);
prints every run, the medians and the ratio B / A. ``tools/experiments/ab_trees.py`` does the same for the bench scene.

Usage: python tools/experiments/ab_asset.py TREE_A TREE_B MODEL [--integrator whitted] [--rounds 4]
   e.g. git archive BASE | tar -x -C /tmp/before && python tools/experiments/ab_asset.py /tmp/before . model.glb
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
import time, json
import numpy as np, pyrt
asset = pyrt.load_asset(sys.argv[2])
lo, hi = asset.bounds(); c = (lo + hi) / 2; r = float(np.linalg.norm(hi - lo)) / 2
eye = c + np.array([0.6, 0.4, 1.0]) / np.linalg.norm([0.6, 0.4, 1.0]) * 3 * r
cam = pyrt.Camera(position=eye, target=c, fov=40, width=320, height=240, spp=4)
scene = pyrt.Scene(cam, background=(0.3, 0.3, 0.3))
asset.add_to_scene(scene, lights=False)
scene.add_light(pyrt.DirectionalLight((-0.3, -1, -0.5), irradiance=3.0))
scene.add_light(pyrt.PointLight(c + np.array([2, 3, 2]) * r, intensity=5.0 * r * r))
pyrt.render(scene, seed=0, integrator=sys.argv[3])
ts = []
for _ in range(3):
    t0 = time.perf_counter(); img = pyrt.render(scene, seed=0, integrator=sys.argv[3]); ts.append(time.perf_counter() - t0)
print(json.dumps({"t": sorted(ts)[1], "mean": float(img.mean())}))
'''


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trees", nargs=2)
    ap.add_argument("model")
    ap.add_argument("--integrator", default="whitted")
    ap.add_argument("--rounds", type=int, default=4)
    args = ap.parse_args(argv)
    a, b = (os.path.abspath(t) for t in args.trees)
    res = {a: [], b: []}
    for r in range(args.rounds):
        for t in ((a, b) if r % 2 == 0 else (b, a)):
            out = subprocess.run([sys.executable, "-c", SNIPPET, t, os.path.abspath(args.model), args.integrator],
                                 capture_output=True, text=True, env={**os.environ, "PYTHONPATH": t})
            if out.returncode:
                sys.exit(f"{t}: {out.stderr.strip()[-1500:]}")
            d = json.loads(out.stdout.strip().splitlines()[-1])
            res[t].append(d["t"])
            print(f"{t}: {d['t']:.3f} s (image mean {d['mean']:.6g})", flush=True)
    for t in (a, b):
        print(f"{t}: median {statistics.median(res[t]):.3f} s {[round(x, 3) for x in res[t]]}")
    print(f"ratio B / A: {statistics.median(res[b]) / statistics.median(res[a]):.3f}")


if __name__ == "__main__":
    main()
