"""Models of many parts: pyrt-preview's phases on generated N-part GLBs, with material merging on and off.

CAD exports and scenes assembled part by part give every part a material of its own (usually differing only in
``baseColorFactor``) or vertex colours. This tool writes two such models with trimesh (``N`` boxes of random
sizes and colours scattered in a 4 m cube):

- ``materials``: one material per part, base colour factors differing, ``--roughness`` (default 0.6: glossy
  rays are traced, which is where the number of materials costs most);
- ``colours``: one ``COLOR_0`` per part, no material.

It renders each with :func:`pyrt.apps.preview.render_preview` at the previewer's defaults (or ``--width`` /
``--height``), in this process, with :attr:`pyrt.io.assets.Asset.merge_materials` on and off (the ``colours``
model has nothing to merge: its rows show the shared vertex-colour material alone). The runs are
interleaved, ``--rounds`` of them, and the medians of every phase of the preview's summary are printed
(load, normals, scene, geometry, render, total).

Usage: python tools/bench_parts.py [--parts 2000] [--rounds 3] [--width 640 --height 480] [--out out/parts]
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np
import trimesh
from trimesh.visual.material import PBRMaterial

from pyrt.apps.preview import PreviewOptions, render_preview
from pyrt.io.assets import load_asset


def write_parts(path, n, *, kind, roughness=0.6, seed=0):
    """A GLB of ``n`` boxes: ``kind`` "materials" (a material each) or "colours" (COLOR_0 each)."""
    rng = np.random.default_rng(seed)
    s = trimesh.Scene()
    for i in range(n):
        b = trimesh.creation.box(extents=rng.uniform(0.05, 0.2, 3))
        rgb = rng.integers(0, 255, 3).tolist()
        if kind == "materials":
            b.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(
                baseColorFactor=rgb + [255], metallicFactor=0.0, roughnessFactor=roughness, name=f"m{i}"))
        else:
            b.visual.face_colors = rgb + [255]
        s.add_geometry(b, node_name=f"n{i}", geom_name=f"g{i}",
                       transform=trimesh.transformations.translation_matrix(rng.uniform(-2, 2, 3)))
    s.export(path)
    return path


def run(path, merge, options):
    """Phases (dict of seconds, plus "total") of one preview of ``path``."""
    t0 = time.perf_counter()
    asset = load_asset(path, max_texture=options.texture_budget())
    asset.merge_materials = merge
    t_load = time.perf_counter() - t0
    res = render_preview(asset, options)
    phases = dict(res.phases, load=t_load)
    phases["total"] = time.perf_counter() - t0
    return phases


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--parts", type=int, default=2000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--roughness", type=float, default=0.6)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--out", default="out/parts")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    models = {k: write_parts(os.path.join(args.out, f"{k}_{args.parts}.glb"), args.parts, kind=k,
                             roughness=args.roughness) for k in ("materials", "colours")}
    options = PreviewOptions(width=args.width, height=args.height)
    cases = [(k, merge) for k in models for merge in (True, False)]
    got = {c: [] for c in cases}
    for r in range(args.rounds):
        for c in (cases if r % 2 == 0 else cases[::-1]):
            got[c].append(run(models[c[0]], c[1], options))
            print(f"round {r + 1} {c[0]:9s} merge={c[1]!s:5s} total {got[c][-1]['total']:.2f} s "
                  f"(load avg {os.getloadavg()[0]:.1f})", flush=True)
    cols = ("load", "normals", "scene", "geometry", "render", "total")
    print(f"\n{args.parts} parts, {args.width}x{args.height}, medians of {args.rounds} interleaved rounds (seconds)")
    print("| model | merge | " + " | ".join(cols) + " |")
    print("|---|---|" + "---:|" * len(cols))
    for c, runs in got.items():
        print(f"| {c[0]} | {'on' if c[1] else 'off'} | "
              + " | ".join(f"{statistics.median(x.get(k, 0.0) for x in runs):.2f}" for k in cols) + " |")


if __name__ == "__main__":
    main()
