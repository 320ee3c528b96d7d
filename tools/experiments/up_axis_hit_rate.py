"""Hit rate of the previewer's up-axis guess on scan-like generated meshes, before and after issue 14.

Every case of :func:`scan_shapes.cases` (12 shapes x authored y-up / z-up x yaw 0 / 30 degrees, scan-like
noise) is written to a PLY file without comments (as a scanner would), loaded with ``pyrt.load_asset``
and guessed by

- *before*: the base-area score the previewer used until issue 14 (the area of downward-facing triangles
  within 1 % of the lowest point, +y against +z; kept here only as the baseline), and
- *after*: :func:`pyrt.apps.preview.detect_up_axis` (planar outlines stood up to face the camera, flat bases and
  cuts, then the convex-hull support polygon, centroid inside it, mirror symmetry; see
  :func:`pyrt.apps.preview.rig.guess_up_axis`).

Prints one line per case and the two hit rates.

Usage: python tools/experiments/up_axis_hit_rate.py [--noise 0.003]
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))   # tools/
import scan_shapes  # noqa: E402

from pyrt.apps.preview import detect_up_axis  # noqa: E402
from pyrt.io.assets import load_asset  # noqa: E402


def _base_area(v, f, up):
    h = v @ up
    lo, ext = h.min(), max(h.max() - h.min(), 1e-300)
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(n, axis=1)
    cos = np.divide(n @ up, area2, out=np.zeros_like(area2), where=area2 > 0)
    low = np.max(h[f], axis=1) <= lo + 0.01 * ext
    return 0.5 * float(np.sum(area2[(cos < -math.cos(math.radians(10))) & low]))


def legacy_up_axis(asset):
    """The pre-issue-14 guess (base area of downward-facing triangles, +y vs +z; PLY/OBJ default +y)."""
    v = np.concatenate([asset.meshes[i.mesh].vertices for i in asset.instances])
    off = np.cumsum([0] + [asset.meshes[i.mesh].vertices.shape[0] for i in asset.instances])[:-1]
    f = np.concatenate([asset.meshes[i.mesh].faces + o for i, o in zip(asset.instances, off)])
    area = {ax: _base_area(v, f, np.asarray(u, dtype=np.float64)) for ax, u in (("+y", (0, 1, 0)), ("+z", (0, 0, 1)))}
    total = 0.5 * float(np.sum(np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)))
    best = max(area, key=area.get)
    if area[best] > 1e-3 * total and area[best] > 1.5 * min(area.values()):
        return best
    return "+z" if asset.format == "stl" else "+y"


def main(argv=None):
    """Print the per-case guesses and the before/after hit rates."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--noise", type=float, default=0.003, help="scan noise, fraction of the largest extent")
    a = ap.parse_args(argv)
    hits = {"before": 0, "after": 0}
    cases = scan_shapes.cases(noise=a.noise)
    with tempfile.TemporaryDirectory() as tmp:
        print(f"{'case':<24} {'truth':>5} {'before':>7} {'after':>6}  reason")
        for k, (name, up, mesh) in enumerate(cases):
            path = os.path.join(tmp, f"case{k}.ply")
            mesh.export(path)
            asset = load_asset(path)
            before = legacy_up_axis(asset)
            after, reason = detect_up_axis(asset)
            hits["before"] += before == up
            hits["after"] += after == up
            print(f"{name:<24} {up:>5} {before:>7} {after:>6}  {reason}")
    n = len(cases)
    print(f"hit rate: before {hits['before']}/{n} ({hits['before'] / n:.0%}), after {hits['after']}/{n} "
          f"({hits['after'] / n:.0%}); noise {a.noise}")


if __name__ == "__main__":
    main()
