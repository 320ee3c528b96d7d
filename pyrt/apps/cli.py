"""Command line: ``python -m pyrt render SCENE -o out.exr [-o out.png] [options]``."""
from __future__ import annotations

import argparse
import sys
import time

import pyrt


def main(argv=None):
    ap = argparse.ArgumentParser(prog="pyrt", description="pyrt: Embree + NumPy renderer")
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("render", help="render a scene file (TOML or JSON)")
    r.add_argument("scene")
    r.add_argument("-o", "--output", action="append", required=True,
                   help="output file (.exr linear, .png tone-mapped); may be repeated")
    r.add_argument("--spp", type=int, help="samples per pixel (overrides the scene)")
    r.add_argument("--width", type=int)
    r.add_argument("--height", type=int)
    r.add_argument("--seed", type=int)
    r.add_argument("--max-depth", type=int)
    r.add_argument("--tonemap", default="reinhard", choices=["linear", "film", "reinhard"])
    r.add_argument("--exposure", type=float, default=0.0, help="exposure in stops for PNG output")
    r.add_argument("--white", type=float, default=None, help="Reinhard L_white")
    r.add_argument("--aovs", action="store_true", help="write depth/normal/albedo channels into EXR outputs")
    r.add_argument("--half", action="store_true", help="write half-float EXR")
    args = ap.parse_args(argv)
    try:
        scene, opts = pyrt.load_scene(args.scene)
    except (ValueError, FileNotFoundError) as e:
        print(f"pyrt: error: {e}", file=sys.stderr)
        return 2
    if args.width:
        scene.camera.width = args.width
    if args.height:
        scene.camera.height = args.height
    if args.seed is not None:
        opts["seed"] = args.seed
    if args.max_depth is not None:
        opts["max_depth"] = args.max_depth
    for out in args.output:
        if not out.lower().endswith((".exr", ".png")):
            print(f"pyrt: error: output must end in .exr or .png: {out}", file=sys.stderr)
            return 2
    t0 = time.perf_counter()
    res = pyrt.render_full(scene, spp=args.spp, aovs=args.aovs, progress=True, **opts)
    dt = time.perf_counter() - t0
    for out in args.output:
        if out.lower().endswith(".exr"):
            pyrt.write_exr(out, res.image, aovs=res.aovs, half=args.half)
        else:
            pyrt.write_png(out, res.image, tonemap=args.tonemap, exposure=args.exposure, L_white=args.white)
        print(f"wrote {out}")
    s = res.stats
    print(f"{scene.camera.width}x{scene.camera.height}, {dt:.2f} s, {s.rays} rays "
          f"({s.primary_rays} primary, {s.secondary_rays} secondary, {s.shadow_rays} shadow)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
