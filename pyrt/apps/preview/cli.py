"""The ``pyrt-preview`` command line."""
from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time

from pyrt.io.assets import AssetError
from pyrt.apps.preview.options import AXES, BudgetExceeded, PreviewError, PreviewOptions
from pyrt.apps.preview.render import render_preview, write_files
from pyrt.apps.preview.batch import collect_inputs, format_summary, preview_batch


# ============================================================================ command line

def _parser():
    ap = argparse.ArgumentParser(prog="pyrt-preview", description="Preview 3D models (glTF/GLB, OBJ, PLY, STL) "
                                 "with a studio rig, auto-framing and auto-exposure.")
    ap.add_argument("models", nargs="+", help="model files, folders or glob patterns")
    ap.add_argument("-o", "--output", action="append",
                    help="output file for a single model (.png and/or .exr; may be repeated)")
    ap.add_argument("--out-dir", help="output folder (batch mode; default: preview_out)")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--fov", type=float, default=35.0, help="vertical field of view (degrees)")
    ap.add_argument("--azimuth", type=float, default=35.0)
    ap.add_argument("--elevation", type=float, default=20.0)
    ap.add_argument("--up", default="auto", choices=["auto", *AXES])
    ap.add_argument("--camera", default="auto", choices=["auto", "asset"])
    ap.add_argument("--lights", default="studio", choices=["studio", "asset", "both"])
    ap.add_argument("--no-ground", action="store_true", help="no shadow-catcher ground plane")
    ap.add_argument("--env", help="lat-long environment map (OpenEXR)")
    ap.add_argument("--env-lighting", default="mis", help="environment light strategy (mis, map, bsdf, preview, ...)")
    ap.add_argument("--env-samples", type=int, default=8, help="environment light samples per hit")
    ap.add_argument("--exposure", type=float, help="exposure in stops (default: automatic)")
    ap.add_argument("--tonemap", default="reinhard", choices=["linear", "film", "reinhard"])
    ap.add_argument("--turntable", type=int, default=0, metavar="N", help="render N views around the model")
    ap.add_argument("--format", default=None, help="batch output formats, e.g. png,exr (default png)")
    ap.add_argument("--aovs", action="store_true", help="also write depth/normal/albedo")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--budget", type=float, help="time budget per asset (s)")
    ap.add_argument("--threads", type=int, help="render threads per asset")
    ap.add_argument("--dask", nargs="?", const="local", default=None, metavar="SCHEDULER",
                    help="run the batch on Dask: a LocalCluster, or the given scheduler address")
    ap.add_argument("--workers", type=int, default=2, help="LocalCluster workers (with --dask)")
    ap.add_argument("--quiet", action="store_true")
    return ap


def main(argv=None):
    """``pyrt-preview MODEL -o out.png`` (one model) or ``pyrt-preview FOLDER/ --out-dir out`` (batch)."""
    args = _parser().parse_args(argv)
    formats = tuple(args.format.split(",")) if args.format else ("png",)
    opts = PreviewOptions(width=args.width, height=args.height, spp=args.spp, fov=args.fov, azimuth=args.azimuth,
                          elevation=args.elevation, up=args.up, camera=args.camera, lights=args.lights,
                          ground=not args.no_ground, environment=args.env, environment_lighting=args.env_lighting,
                          environment_samples=args.env_samples, exposure=args.exposure,
                          tonemap=args.tonemap, turntable=args.turntable, formats=formats, aovs=args.aovs,
                          seed=args.seed, time_budget=args.budget, threads=args.threads)
    try:
        opts.validate()
    except PreviewError as exc:
        print(f"pyrt-preview: error: {exc}", file=sys.stderr)
        return 2
    paths = collect_inputs(args.models)
    single = args.output and len(paths) == 1 and os.path.isfile(paths[0])
    if args.output and not single:
        print("pyrt-preview: error: -o needs exactly one model file; use --out-dir for batches", file=sys.stderr)
        return 2
    if single:
        return _main_single(paths[0], args.output, opts, args.quiet)
    out_dir = args.out_dir or "preview_out"
    dask = None if args.dask is None else (True if args.dask == "local" else args.dask)
    try:
        reports = preview_batch(paths, out_dir, opts, dask=dask, n_workers=args.workers, progress=not args.quiet)
    except PreviewError as exc:
        print(f"pyrt-preview: error: {exc}", file=sys.stderr)
        return 2
    print(format_summary(reports))
    return 0 if all(r.status == "ok" for r in reports) else 1


def _main_single(path, outputs, opts, quiet):
    for out in outputs:
        if not out.lower().endswith((".png", ".exr")):
            print(f"pyrt-preview: error: output must end in .png or .exr: {out}", file=sys.stderr)
            return 2
    fmts = tuple(sorted({os.path.splitext(out)[1].lower()[1:] for out in outputs}))
    opts = dataclasses.replace(opts, formats=fmts)
    deadline = time.perf_counter() + opts.time_budget if opts.time_budget else None
    name = "view"
    try:
        res = render_preview(path, opts, name=name, deadline=deadline)
    except (AssetError, PreviewError, BudgetExceeded, ValueError, OSError) as exc:
        print(f"pyrt-preview: error: {exc}", file=sys.stderr)
        return 1
    for out in outputs:
        stem, ext = os.path.splitext(out)
        base = os.path.basename(stem)
        # "view.png" -> "OUT.png"; also OUT_depth.png, OUT_turntable/frame_000.png, OUT_sheet.png
        sel = {base + k[len(name):]: v for k, v in res.files.items() if k.endswith(ext.lower())}
        for p in write_files(sel, os.path.dirname(stem) or "."):
            if not quiet:
                print(f"wrote {p}")
    for w in dict.fromkeys(res.warnings):
        print(f"warning: {w}", file=sys.stderr)
    if not quiet:
        print(f"{res.triangles} triangles, up {res.up_axis} ({res.up_reason}), load {res.load_time:.2f} s, "
              f"render {res.render_time:.2f} s, exposure {res.exposure:+.2f} stops")
    return 0
