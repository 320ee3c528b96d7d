"""A/B of ``pyrt-preview`` at its defaults between two checkouts of pyrt, interleaved, each run in its own process.

Each run calls :func:`pyrt.apps.preview.render_preview` on the model (its default options, ``--size`` and
``--threads`` aside) and reports the render phase (``result.render_time``); rounds alternate the order (A B, B A,
...). Prints every run, the medians, the ratio B / A and the image difference between the two trees (max and mean
absolute difference of the linear images of their last runs; 0 when the change keeps images bit-identical), and
the CPU time of the render phase (``os.times`` around each view: all threads and the render's worker processes): on a machine shared with
other jobs the wall time follows the load, the CPU time much less.
``pyrt.shaders`` is imported from each tree's ``shaders/`` (not the editable install's checkout).

Usage: python tools/experiments/ab_preview.py TREE_A TREE_B MODEL [MODEL ...] [--rounds 2] [--threads 1] [--size 640x480]
   e.g. git archive BASE | tar -x -C /tmp/before && python tools/experiments/ab_preview.py /tmp/before . Duck.glb
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))   # tools/, for _trees
from _trees import TREE_PREAMBLE  # noqa: E402  (tools/_trees.py)

SNIPPET = TREE_PREAMBLE + r'''
import json
import time
import numpy as np
import pyrt.shaders.textures
from pyrt.apps.preview import render_preview, PreviewOptions
from pyrt.apps.preview.render import PreviewScene
_view, _cpu = PreviewScene.render_view, [0.0]


def timed_view(self, *args, **kwargs):
    """``render_view`` with the process's CPU time spent in it added up (all threads)."""
    c = sum(os.times()[:4])
    try:
        return _view(self, *args, **kwargs)
    finally:
        _cpu[0] += sum(os.times()[:4]) - c


PreviewScene.render_view = timed_view
w, h = (int(x) for x in sys.argv[3].split("x"))
threads = None if sys.argv[4] == "all" else int(sys.argv[4])
r = render_preview(sys.argv[2], PreviewOptions(width=w, height=h, threads=threads))
np.save(sys.argv[5], r.images[0])
print(json.dumps({"t": r.render_time, "cpu": _cpu[0], "shaders": pyrt.shaders.textures.__file__}))
'''


def main(argv=None):
    """Run the interleaved A/B for every model and print the runs, medians, ratio and image difference."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trees", nargs=2)
    ap.add_argument("models", nargs="+")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--threads", default="all", help="render threads, or 'all' (the preview's default)")
    ap.add_argument("--size", default="640x480")
    args = ap.parse_args(argv)
    a, b = (os.path.abspath(t) for t in args.trees)
    tmp = tempfile.mkdtemp(prefix="ab_preview_")
    for model in args.models:
        res = {a: [], b: []}
        cpu = {a: [], b: []}
        for r in range(args.rounds):
            for t in ((a, b) if r % 2 == 0 else (b, a)):
                out_npy = os.path.join(tmp, "a.npy" if t == a else "b.npy")
                out = subprocess.run([sys.executable, "-c", SNIPPET, t, os.path.abspath(model), args.size,
                                      args.threads, out_npy],
                                     capture_output=True, text=True, env={**os.environ, "PYTHONPATH": t})
                if out.returncode:
                    sys.exit(f"{t}: {out.stderr.strip()[-1500:]}")
                d = json.loads(out.stdout.strip().splitlines()[-1])
                res[t].append(d["t"])
                cpu[t].append(d["cpu"])
                print(f"{os.path.basename(model)} {t}: {d['t']:.2f} s, CPU {d['cpu']:.2f} s (shaders {d['shaders']})",
                      flush=True)
        ia, ib = np.load(os.path.join(tmp, "a.npy")), np.load(os.path.join(tmp, "b.npy"))
        diff = np.abs(ia.astype(np.float64) - ib)
        ma, mb = statistics.median(res[a]), statistics.median(res[b])
        ca, cb = statistics.median(cpu[a]), statistics.median(cpu[b])
        print(f"{os.path.basename(model)}: A median {ma:.2f} s {[round(x, 2) for x in res[a]]}, B median {mb:.2f} s "
              f"{[round(x, 2) for x in res[b]]}, B / A {mb / ma:.3f}; CPU medians {ca:.2f} / {cb:.2f} s, B / A "
              f"{cb / ca:.3f}; image |A - B| max {diff.max():.4g} "
              f"mean {diff.mean():.4g} (A mean {ia.mean():.4g})", flush=True)


if __name__ == "__main__":
    main()
