"""A/B of the whole ``pyrt-preview`` command between two checkouts of pyrt: the wall time of the process, Python's
start, the imports, loading, rendering, encoding and exit included, interleaved (A, B, A, B, ...).

``tools/experiments/ab_preview.py`` times the render phase inside the process; this one times what a user waits for. Each run
is ``python -c <pyrt.apps.preview.cli.main>`` with the tree first on ``sys.path`` (``tools/_trees.py``); any further
arguments are passed to the previewer.

Usage: python tools/experiments/ab_cli.py TREE_A TREE_B MODEL [--rounds 5] [PREVIEW_ARGS...]
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))   # tools/, for _trees
from _trees import TREE_PREAMBLE  # noqa: E402  (tools/_trees.py)

CODE = TREE_PREAMBLE + "\nfrom pyrt.apps.preview.cli import main\nsys.exit(main(sys.argv[2:]))\n"


def main(argv=None):
    """Run the interleaved rounds and print each tree's runs and median wall time, and B / A."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trees", nargs=2)
    ap.add_argument("model")
    ap.add_argument("--rounds", type=int, default=5)
    args, extra = ap.parse_known_args(argv)       # the rest goes to the previewer
    extra = [a for a in extra if a != "--"]
    walls = {t: [] for t in args.trees}
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "ab.png")
        for _ in range(args.rounds):
            for t in args.trees:
                t0 = time.perf_counter()
                subprocess.run([sys.executable, "-c", CODE, os.path.abspath(t), args.model, "-o", out, "--quiet",
                                *extra], check=True)
                walls[t].append(time.perf_counter() - t0)
    a, b = (statistics.median(walls[t]) for t in args.trees)
    for t in args.trees:
        print(f"{t}: median wall {statistics.median(walls[t]):.2f} s, runs {[round(x, 2) for x in walls[t]]}")
    print(f"{os.path.basename(args.model)}: B / A {b / a:.3f} (load average {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    sys.exit(main())
