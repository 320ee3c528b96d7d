"""The ``pyrt-preview`` command line.

Exit codes: 0 every asset ok; 1 a batch in which some asset failed (the summary says which); 2 an error
(one line ``pyrt-preview: error: <message>``, bad arguments too; ``--debug`` adds the traceback); 130
interrupted. The first SIGINT / SIGTERM lets the view in progress finish, keeps the finished assets'
files, writes the summary and exits 130; a second one aborts at once.
"""
from __future__ import annotations

import dataclasses
import os
import sys
import threading
import time
import traceback

from pyrt.core.errors import Error
from pyrt.core.image_io import TONEMAPS
from pyrt.io.assets import FORMATS
from pyrt.io.assets.archive import split_member
from pyrt.apps.common import (EXIT_ERROR, EXIT_INTERRUPTED, ArgumentParser, check_output_folder, check_outputs,
                              finite_float, interrupts, nonnegative_int, positive_float, positive_int, process_age,
                              run_console)
from pyrt.integrators.compiled import BACKENDS
from pyrt.render.pool import PARALLEL
from pyrt.apps.preview.options import ADAPTIVE_MAX_SPP, AXES, PreviewError, PreviewInterrupted, PreviewOptions
from pyrt.apps.preview.render import format_phases, format_sampling, render_preview, write_files
from pyrt.apps.preview.batch import collect_inputs, format_summary, preview_batch


# ============================================================================ command line

def _max_texture(text):
    """argparse type of ``--max-texture``: ``auto`` or an integer >= 0."""
    return text if text == "auto" else nonnegative_int(text)


def _glossy_clamp(text):
    """argparse type of ``--glossy-clamp``: ``off`` (None) or a positive number."""
    return None if text == "off" else positive_float(text)


def _render_budget(text):
    """argparse type of ``--render-budget``: ``off`` (None) or a positive number of seconds."""
    return None if text == "off" else positive_float(text)


def _parser():
    ap = ArgumentParser(prog="pyrt-preview", description="Preview 3D models (glTF/GLB, OBJ, PLY, STL, OFF, or a ZIP "
                                 "archive holding one) with a studio rig, auto-framing and auto-exposure.")
    ap.add_argument("models", nargs="+", help="model files (ARCHIVE.zip!member: a model inside an archive), folders or "
                                              "glob patterns")
    ap.add_argument("-o", "--output", action="append",
                    help="output file for a single model (.png and/or .exr; may be repeated); with --turntable N, "
                         "-o X.png writes the frames X_turntable/frame_000.png ... frame_{N-1}.png and the "
                         "contact sheet X_sheet.png")
    ap.add_argument("--out-dir", help="output folder (batch mode; default: preview_out)")
    ap.add_argument("--width", type=positive_int, default=640)
    ap.add_argument("--height", type=positive_int, default=480)
    ap.add_argument("--spp", type=positive_int, help="a fixed number of samples per pixel instead of the adaptive "
                                                      "default (--target-error, --render-budget)")
    ap.add_argument("--target-error", type=positive_float, metavar="E",
                    help=f"adaptive passes until the estimated relMSE is at most E (default {PreviewOptions.target_error:g}), every pixel "
                         "has --max-spp samples or --render-budget is spent")
    ap.add_argument("--max-spp", type=positive_int, metavar="N",
                    help=f"adaptive: samples per pixel at most (default {ADAPTIVE_MAX_SPP})")
    ap.add_argument("--min-spp", type=positive_int, default=PreviewOptions.min_spp, metavar="N",
                    help="adaptive: the base pass's samples per pixel (even, default %(default)s)")
    ap.add_argument("--render-budget", type=_render_budget, default=PreviewOptions.render_budget, metavar="S",
                    help="adaptive: no pass starts after a view has rendered S seconds (the base pass always "
                         "completes); 'off': no limit (default %(default)s)")
    ap.add_argument("--fov", type=finite_float, default=35.0, help="vertical field of view (degrees)")
    ap.add_argument("--azimuth", type=finite_float, default=None,
                    help="camera azimuth in degrees (0 = from +z; default: 0 for thin boards, else 35)")
    ap.add_argument("--elevation", type=finite_float, default=20.0)
    ap.add_argument("--up", default="auto", choices=["auto", *AXES])
    ap.add_argument("--framing", default="fit", choices=["fit", "sphere"],
                    help="fit: the model's projected hull fills the frame (default); sphere: its bounding sphere")
    ap.add_argument("--camera", default="auto", choices=["auto", "asset"])
    ap.add_argument("--lights", default="studio", choices=["studio", "asset", "both"])
    ap.add_argument("--no-ground", action="store_true", help="no shadow-catcher ground plane")
    ap.add_argument("--studio-env", default="on", choices=["on", "off"],
                    help="the procedural studio environment (soft boxes, reflected by metals; replaces the constant "
                         "ambient with the same mean radiance; ignored with --env)")
    ap.add_argument("--env", help="lat-long environment map (OpenEXR or Radiance .hdr)")
    ap.add_argument("--env-lighting", default="mis", help="environment light strategy (mis, map, bsdf, preview, ...)")
    ap.add_argument("--env-samples", type=positive_int, default=PreviewOptions.environment_samples,
                    help="environment light samples per hit (default %(default)s)")
    ap.add_argument("--emissive-lights", default="auto", choices=["auto", "off"],
                    help="auto: the model's emissive surfaces light the scene by shadow rays too when they are a "
                         "light source (power >= 0.25 x the key light onto the model); off: only through glossy rays")
    ap.add_argument("--emissive-samples", type=positive_int, default=PreviewOptions.emissive_samples,
                    help="shadow rays per hit toward the emissive surfaces")
    ap.add_argument("--emissive-selection", default=PreviewOptions.emissive_selection, choices=["power", "oriented"],
                    help="how the emissive triangles are chosen: by power, or per shading point (distance, side)")
    ap.add_argument("--exposure", type=finite_float, help="exposure in stops (default: automatic)")
    ap.add_argument("--tonemap", default=PreviewOptions.tonemap, choices=TONEMAPS,
                    help="tone mapper: pbr_neutral (default: Khronos PBR Neutral, the glTF Sample Viewer's), reinhard "
                         "(luminance, automatic white point), aces (Filament's), film, linear, reinhard_rgb")
    ap.add_argument("--turntable", type=nonnegative_int, default=0, metavar="N", help="render N views around the model (N frames and a contact sheet: "
                         "with -o X.png, X_turntable/frame_000.png ... and X_sheet.png; in a batch, "
                         "NAME_turntable/ and NAME_sheet.png per model)")
    ap.add_argument("--format", default=None, help="batch output formats, e.g. png,exr (default png)")
    ap.add_argument("--aovs", action="store_true", help="also write depth/normal/albedo")
    ap.add_argument("--seed", type=nonnegative_int, default=0)
    ap.add_argument("--budget", type=positive_float, help="time budget per asset (s)")
    ap.add_argument("--threads", type=positive_int, help="render workers per asset (default: all cores)")
    ap.add_argument("--backend", default="auto", choices=list(BACKENDS),
                    help="render path (default auto: the compiled kernel where it covers the model, else NumPy)")
    ap.add_argument("--parallel", default="auto", choices=list(PARALLEL),
                    help="render workers as forked processes or threads (default auto: processes on Linux for renders of at least 16 chunks)")
    ap.add_argument("--root", metavar="DIR",
                    help="folder a loose model may read files from (it must contain the model; default: the model's "
                         "own folder and its subfolders: a URI leaving it is an error and nothing outside is read); "
                         "models in a ZIP read only the archive")
    ap.add_argument("--double-sided", action="store_true",
                    help="render both sides of every face (default: as the file says; back faces of single-sided "
                         "glTF materials are culled)")
    ap.add_argument("--glossy-clamp", type=_glossy_clamp, default=PreviewOptions.glossy_clamp, metavar="X",
                    help="limit what the light at a glossy ray's hit adds to a sample to X times the lighting's "
                         "scale (against fireflies; biased); 'off': unbiased (default %(default)s)")
    ap.add_argument("--max-texture", type=_max_texture, default="auto", metavar="N",
                    help="reduce glTF images longer than N texels by a power of two as they are decoded (auto: "
                         "the power of two at or above 3x the longer output side; 0: keep every image whole)")
    ap.add_argument("--bvh-quality", default="auto", choices=["auto", "low", "medium", "high"],
                    help="Embree's BVH build quality (auto: low from 1 M triangles, else medium)")
    ap.add_argument("--dask", nargs="?", const="local", default=None, metavar="SCHEDULER",
                    help="run the batch on Dask: a LocalCluster, or the given scheduler address")
    ap.add_argument("--workers", type=positive_int, default=2, help="LocalCluster workers (with --dask)")
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument("--debug", action="store_true", help="print the traceback of an error")
    return ap


def main(argv=None, *, started=None):
    """``pyrt-preview MODEL -o out.png`` (one model) or ``pyrt-preview FOLDER/ --out-dir out`` (batch).

    ``started``: the seconds the process had run before ``main`` (the interpreter's start and the imports:
    :func:`pyrt.apps.common.process_age`, what the console script passes), reported as the single model's ``start``
    phase; None (a call from Python): no such phase."""
    args = _parser().parse_args(argv)
    cancel = threading.Event()
    try:
        with interrupts(cancel, "pyrt-preview", "the view in progress"):
            return _run(args, cancel, started)
    except KeyboardInterrupt:
        print("pyrt-preview: aborted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (Error, OSError, ValueError) as exc:
        if args.debug:
            traceback.print_exc()
        print(f"pyrt-preview: error: {exc}", file=sys.stderr)
        return EXIT_ERROR


def _run(args, cancel, started=None):
    if args.spp is not None and (args.target_error is not None or args.max_spp is not None):
        raise PreviewError("--spp (a fixed count) and --target-error / --max-spp (adaptive passes) exclude each other")
    formats = tuple(args.format.split(",")) if args.format else ("png",)
    opts = PreviewOptions(width=args.width, height=args.height, spp=args.spp, fov=args.fov, azimuth=args.azimuth,
                          elevation=args.elevation, up=args.up, framing=args.framing, camera=args.camera, lights=args.lights,
                          ground=not args.no_ground, studio_env=args.studio_env == "on", environment=args.env, environment_lighting=args.env_lighting,
                          environment_samples=args.env_samples, emissive_lights=args.emissive_lights,
                          emissive_samples=args.emissive_samples, emissive_selection=args.emissive_selection,
                          exposure=args.exposure,
                          tonemap=args.tonemap, turntable=args.turntable, formats=formats, aovs=args.aovs,
                          seed=args.seed, time_budget=args.budget, threads=args.threads, parallel=args.parallel,
                          backend=args.backend,
                          bvh_quality=args.bvh_quality, double_sided=args.double_sided,
                          target_error=PreviewOptions.target_error if args.target_error is None else args.target_error,
                          max_spp=args.max_spp, max_texture=args.max_texture, glossy_clamp=args.glossy_clamp,
                          min_spp=args.min_spp, render_budget=args.render_budget, root=args.root).validate()
    paths = collect_inputs(args.models)
    if not paths:
        raise PreviewError(f"no models found in {' '.join(args.models)} "
                           f"(looked for {', '.join(sorted(FORMATS))})")
    if args.output:
        if len(paths) != 1:
            raise PreviewError(f"-o needs exactly one model file, got {len(paths)}; use --out-dir for batches")
        if not os.path.isfile(paths[0]) and split_member(paths[0]) is None:
            raise PreviewError(f"no such model file: {paths[0]}")
        check_outputs(args.output)
        return _main_single(paths[0], args.output, opts, args.quiet, cancel, started)
    out_dir = args.out_dir or "preview_out"
    check_output_folder(out_dir if os.path.exists(out_dir) else os.path.dirname(os.path.abspath(out_dir)))
    dask = None if args.dask is None else (True if args.dask == "local" else args.dask)
    reports = preview_batch(paths, out_dir, opts, dask=dask, n_workers=args.workers, progress=not args.quiet,
                            cancel=cancel)
    print(format_summary(reports))
    if cancel.is_set():
        done = sum(r.status not in ("interrupted", "skipped") for r in reports)
        print(f"pyrt-preview: interrupted: {done}/{len(reports)} assets finished and kept; "
              f"summary in {os.path.join(out_dir, 'summary.txt')}", file=sys.stderr)
        return EXIT_INTERRUPTED
    return 0 if all(r.status == "ok" for r in reports) else 1


def _main_single(path, outputs, opts, quiet, cancel, started=None):
    fmts = tuple(sorted({os.path.splitext(out)[1].lower()[1:] for out in outputs}))
    opts = dataclasses.replace(opts, formats=fmts)
    deadline = time.perf_counter() + opts.time_budget if opts.time_budget else None
    name = "view"
    try:
        res = render_preview(path, opts, name=name, deadline=deadline, cancel=cancel)
    except PreviewInterrupted as exc:
        print(f"pyrt-preview: {exc}; nothing written", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (Error, ValueError) as exc:
        # errors raised after the load (a degenerate mesh, a bad material value) name the part, not the file
        if os.path.basename(path) not in str(exc):
            raise PreviewError(f"{path}: {exc}") from exc
        raise
    t_write = time.perf_counter()
    for out in outputs:
        stem, ext = os.path.splitext(out)
        base = os.path.basename(stem)
        # "view.png" -> "OUT.png"; also OUT_depth.png, OUT_turntable/frame_000.png, OUT_sheet.png
        sel = {base + k[len(name):]: v for k, v in res.files.items() if k.endswith(ext.lower())}
        for p in write_files(sel, os.path.dirname(stem) or "."):
            if not quiet:
                print(f"wrote {p}")
    res.phases["write"] = time.perf_counter() - t_write
    if started is not None:
        res.phases["start"] = started
    for w in dict.fromkeys(res.warnings):
        print(f"warning: {w}", file=sys.stderr)
    if not quiet:
        print(f"{res.triangles} triangles, up {res.up_axis} ({res.up_reason}), {format_phases(res.phases)} "
              f"(total {sum(res.phases.values()):.2f} s), {format_sampling(res, None if opts.spp else opts.target_error)}, "
              f"exposure {res.exposure:+.2f} stops")
    if cancel.is_set():
        print("pyrt-preview: interrupted after the view had finished; the outputs are complete", file=sys.stderr)
        return EXIT_INTERRUPTED
    return 0


def console_main():
    """The console script: :func:`main` without the interpreter's teardown (:func:`pyrt.apps.common.run_console`),
    the process's age on entry reported as the ``start`` phase."""
    started = process_age()
    run_console(lambda: main(started=started))
