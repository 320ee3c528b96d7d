"""Command line: ``python -m pyrt render SCENE -o out.exr [-o out.png] [options]``.

Exit codes: 0 done; 2 an error, reported as one line ``pyrt: error: <message>`` (``--debug`` also prints
the traceback; bad arguments too, on one line), 130 interrupted. The first SIGINT
(Ctrl-C) or SIGTERM stops the render after the chunks in progress and writes what was rendered (the
rest of the image is black, and a line says how much was kept); a second one aborts at once. Output
paths are checked before the scene is loaded, and every file is replaced atomically.
"""
from __future__ import annotations

import argparse
from dataclasses import fields
import sys
import threading
import time
import traceback

import pyrt
from pyrt.core.image_io import TONEMAPS
from pyrt.geometry.offsets import STRATEGIES
from pyrt.render import INTEGRATORS, SAMPLERS
from pyrt.render.settings import INTEGRATOR_TYPES
from pyrt.integrators import kernel_cache
from pyrt.render.pool import PARALLEL
from pyrt.apps.common import (EXIT_ERROR, EXIT_INTERRUPTED, ArgumentParser, check_outputs, finite_float, interrupts,
                              nonnegative_int, positive_float, positive_int, run_console)


class CommandError(pyrt.Error, ValueError):
    """A command-line run that cannot proceed (the message says why)."""


def _value(text):
    """A ``KEY=VALUE`` value of ``--integrator``: an int, a float, true / false / none, else the string."""
    low = text.strip().lower()
    if low in ("true", "false", "none"):
        return {"true": True, "false": False, "none": None}[low]
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text.strip()


def integrator_spec(text):
    """``--integrator TYPE[:KEY=VALUE,...]`` -> ``(type, {key: value})``; the options are checked by the integrator's
    class (:mod:`pyrt.render.settings`) when the render starts, argparse's error for a bad TYPE or pair."""
    kind, _, rest = text.partition(":")
    if kind not in INTEGRATORS:
        raise argparse.ArgumentTypeError(f"must be one of {', '.join(INTEGRATORS)} (then :KEY=VALUE,...), got {kind!r}")
    options = {}
    for pair in filter(None, rest.split(",")):
        key, eq, value = pair.partition("=")
        if not eq or not key.strip():
            raise argparse.ArgumentTypeError(f"options are KEY=VALUE pairs separated by commas, got {pair!r}")
        options[key.strip()] = _value(value)
    return kind, options


def _parser():
    ap = ArgumentParser(prog="pyrt", description="pyrt: Embree + NumPy renderer")
    ap.add_argument("--debug", action="store_true", help="print the traceback of an error")
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("compile", help="compile the render kernels now (else the first compiled render does, once)")
    c.add_argument("--prune", action="store_true",
                   help="also remove the kernel caches of other pyrt, Numba or Python versions now (a compile removes "
                        "those unused for 30 days)")
    r = sub.add_parser("render", help="render a scene file (TOML or JSON)")
    r.add_argument("scene")
    # the option groups of pyrt.render (pyrt.Whitted / pyrt.Glossy, pyrt.Sampling, pyrt.Execution; docs/rendering.md)
    sampling = r.add_argument_group("sampling (pyrt.Sampling)")
    integrator = r.add_argument_group("integrator (pyrt.Whitted / pyrt.Glossy)")
    execution = r.add_argument_group("execution (pyrt.Execution)")
    r.add_argument("-o", "--output", action="append", required=True,
                   help="output file (.exr linear, .png tone-mapped); may be repeated")
    sampling.add_argument("--spp", type=positive_int, help="samples per pixel (overrides the scene)")
    sampling.add_argument("--target-error", type=positive_float, metavar="E",
                   help="adaptive: stop when the estimated relMSE is at most E (e.g. 1e-3)")
    sampling.add_argument("--time", type=positive_float, metavar="SECONDS", dest="time_budget",
                   help="adaptive: stop after about SECONDS of wall time")
    sampling.add_argument("--max-spp", type=positive_int, metavar="N", help="adaptive: at most N samples in any pixel")
    sampling.add_argument("--min-spp", type=positive_int, metavar="N", help="adaptive: samples of the base pass (even)")
    execution.add_argument("--dask", nargs="?", const=True, default=None, metavar="SCHEDULER",
                   help="render the chunks on Dask: a scheduler address, or without one a local cluster of "
                        "--dask-workers processes (needs the preview extra)")
    execution.add_argument("--dask-workers", type=positive_int, metavar="N",
                   help="worker processes of the local cluster of --dask (default 2)")
    r.add_argument("--write-every", type=positive_float, metavar="SECONDS",
                   help="adaptive: rewrite the outputs with the current image after a pass, at most every SECONDS")
    execution.add_argument("--threads", type=positive_int, help="render workers (default: all cores)")
    execution.add_argument("--backend", choices=["auto", "compiled", "numpy"],
                   help="compiled tile kernel or NumPy path (default auto: compiled where it covers the scene)")
    execution.add_argument("--parallel", choices=list(PARALLEL),
                   help="render workers as forked processes or threads (default auto: processes on Linux for renders of at least 16 chunks)")
    r.add_argument("--width", type=positive_int, help="image width in pixels (overrides the scene)")
    r.add_argument("--height", type=positive_int, help="image height in pixels (overrides the scene)")
    sampling.add_argument("--seed", type=nonnegative_int, help="random seed: the same seed gives the same image")
    integrator.add_argument("--max-depth", type=nonnegative_int, help="maximum specular depth (0: direct light only)")
    integrator.add_argument("--offset", choices=sorted(STRATEGIES), help="ray-origin offset strategy (default: robust)")
    integrator.add_argument("--integrator", type=integrator_spec, metavar="TYPE[:KEY=VALUE,...]",
                   help=f"one of {', '.join(INTEGRATORS)} and its options, as pyrt.Whitted / pyrt.Glossy take them: "
                        "whitted (default): only mirrors and glass spawn rays; glossy: glossy lobes too, e.g. "
                        "glossy:samples=8,depth=1,clamp=4 (an option the integrator does not take is an error)"),
    sampling.add_argument("--sampler", choices=list(SAMPLERS),
                   help="the camera hits' light and BSDF samples: padded over each pixel's samples (default) or "
                        "independent")
    integrator.add_argument("--transparent-shadows", action=argparse.BooleanOptionalAction, default=None,
                   help="shadow rays pass through glass, Fresnel- and absorption-attenuated (overrides the scene; "
                        "default off)")
    r.add_argument("--tonemap", default="reinhard", choices=TONEMAPS,
                   help="reinhard: on luminance; reinhard_rgb: per channel L/(1+L); pbr_neutral: Khronos PBR "
                        "Neutral; aces: Filament's ACES")
    r.add_argument("--encoding", default="srgb", choices=["srgb", "gamma"],
                   help="PNG transfer curve: exact sRGB or plain x^(1/gamma)")
    r.add_argument("--gamma", type=positive_float, default=2.2, help="exponent of --encoding gamma")
    r.add_argument("--exposure", type=finite_float, default=0.0, help="exposure in stops for PNG output")
    r.add_argument("--white", type=positive_float, default=None, help="Reinhard L_white (> 0)")
    r.add_argument("--aovs", action="store_true", help="write depth/normal/albedo channels into EXR outputs")
    r.add_argument("--half", action="store_true", help="write half-float EXR")
    r.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                   help="print the traceback of an error")
    return ap


#: seconds the pixels not rendered at the first Ctrl-C may take to get one sample each (the fill's deadline): with
#: the chunks in progress and the writes, the command ends ~2 s after the signal
FILL_BUDGET = 1.0


def main(argv=None):
    """Run ``pyrt ...``; returns the exit code (0 done, 2 error, 130 interrupted)."""
    ap = _parser()
    args = ap.parse_args(argv)
    if args.cmd == "compile":
        return _compile(args)
    if args.white is not None and args.tonemap != "reinhard":
        ap.error(f"--white applies to --tonemap reinhard only, not {args.tonemap}")
    if args.aovs and not any(o.lower().endswith(".exr") for o in args.output):
        ap.error("--aovs writes depth, normal and albedo channels into EXR outputs, and no -o ends in .exr "
                 "(a PNG holds the image alone)")
    adaptive = args.target_error is not None or args.time_budget is not None
    if args.spp is not None and (adaptive or args.max_spp is not None or args.min_spp is not None):
        ap.error("--spp (fixed samples per pixel) excludes --target-error/--time/--max-spp/--min-spp (adaptive)")
    if (args.max_spp is not None or args.min_spp is not None or args.write_every is not None) and not adaptive:
        ap.error("--max-spp, --min-spp and --write-every need --target-error or --time (adaptive rendering)")
    if args.min_spp is not None and args.min_spp % 2:
        ap.error(f"--min-spp must be even (two half-buffers estimate the error), got {args.min_spp}")
    if args.min_spp is not None and args.max_spp is not None and args.max_spp < args.min_spp:
        ap.error(f"--max-spp {args.max_spp} is below --min-spp {args.min_spp}")
    cancel = threading.Event()
    try:
        with interrupts(cancel, "pyrt"):
            return _render(args, cancel)
    except KeyboardInterrupt:
        print("pyrt: aborted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (pyrt.Error, OSError, ValueError) as exc:
        if args.debug:
            traceback.print_exc()
        print(f"pyrt: error: {exc}", file=sys.stderr)
        return EXIT_ERROR


def _compile(args):
    """``pyrt compile``: the render kernels compiled (or found in the cache), one line saying which."""
    try:
        seconds, cached, where = pyrt.compile_kernels()
    except (pyrt.Error, OSError, ValueError) as exc:
        if args.debug:
            traceback.print_exc()
        print(f"pyrt: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    print(f"pyrt: render kernels {'loaded from the cache' if cached else 'compiled'} in {seconds:.1f} s ({where})")
    if args.prune:
        removed = kernel_cache.prune(days=0, path=where)
        freed = sum(size for _path, size in removed) / 2**20
        print(f"pyrt: removed {len(removed)} other kernel cache(s), {freed:.0f} MB")
    return 0


def _render(args, cancel):
    check_outputs(args.output)
    scene, opts = pyrt.load_scene(args.scene)
    if not scene.meshes:
        raise CommandError(f"{args.scene}: the scene has no meshes; there is nothing to render")
    if args.width is not None:
        scene.camera.width = args.width
    if args.height is not None:
        scene.camera.height = args.height
    integ = dict(opts.pop("integrator", {}))
    sampling = dict(opts.pop("sampling", {}))
    execution = dict(opts.pop("execution", {}))
    if args.integrator is not None:
        kind, options = args.integrator
        if kind != integ.get("type", "whitted"):     # another type than the file's: keep what the new one takes
            allowed = {f.name for f in fields(INTEGRATOR_TYPES[kind])}
            integ = {k: v for k, v in integ.items() if k in allowed}
        integ.update(options, type=kind)
    for group, keys in ((integ, ("max_depth", "offset", "transparent_shadows")),
                        (sampling, ("target_error", "time_budget", "max_spp", "min_spp", "sampler")),
                        (execution, ("threads", "parallel", "backend", "dask_workers"))):
        group.update({key: getattr(args, key) for key in keys if getattr(args, key) is not None})
    if args.seed is not None:
        opts["seed"] = args.seed
    if args.spp is not None:      # the command line's --spp wins over a scene file's adaptive keys
        for key in ("target_error", "time_budget", "max_spp", "min_spp"):
            sampling.pop(key, None)
    adaptive = any(k in sampling for k in ("target_error", "time_budget", "max_spp"))
    last = {"t": time.perf_counter()}

    def on_pass(info):
        if args.write_every is not None and time.perf_counter() - last["t"] >= args.write_every:
            _write_outputs(args, info.film.image(), info.film.aovs(), quiet=True)
            last["t"] = time.perf_counter()

    if adaptive:
        sampling["on_pass"] = on_pass
    if args.dask is not None:
        execution["dask"] = args.dask
    t0 = time.perf_counter()
    res = pyrt.render_full(scene, spp=args.spp, integrator=integ, sampling=sampling,
                           output=pyrt.Output(aovs=args.aovs, fill=True, fill_budget=FILL_BUDGET),
                           execution=dict(execution, progress=True, cancel=cancel), **opts)
    dt = time.perf_counter() - t0
    if res.chunks_done == 0:
        print("pyrt: interrupted before any pixel was rendered; nothing written", file=sys.stderr)
        return EXIT_INTERRUPTED
    _write_outputs(args, res.image, res.aovs)
    s = res.stats
    print(f"{scene.camera.width}x{scene.camera.height}, {dt:.2f} s, {s.rays} rays "
          f"({s.primary_rays} primary, {s.secondary_rays} secondary, {s.shadow_rays} shadow), {s.backend} path"
          + (f" (not compiled: {'; '.join(s.fallback_reasons)})" if s.fallback_reasons else ""))
    if adaptive:
        w = res.film.weight
        print(f"adaptive: {res.passes} passes, {w.mean():.1f} spp on average ({w.min():.0f}..{w.max():.0f}), "
              f"estimated relMSE {res.estimated_error:.3g}, stopped by {res.stop_reason}")
        if not res.complete:
            print(f"pyrt: interrupted after {res.passes} passes: the outputs hold the image so far "
                  f"({w.mean():.1f} spp on average, estimated relMSE {res.estimated_error:.3g})"
                  + ("; pixels without any sample got 2" if res.pixels_filled else ""), file=sys.stderr)
            return EXIT_INTERRUPTED
    if not res.complete:
        others = scene.camera.width * scene.camera.height - res.pixels_done
        if res.pixels_filled >= others:
            rest = "the other pixels got 1 sample each (noisier)"
        elif res.pixels_filled:
            rest = (f"{100 * res.pixels_filled / others:.0f} % of the other pixels got 1 sample each (noisier), "
                    "the rest is black (the fill's time was up)")
        else:
            rest = "the rest is black"
        spp = scene.camera.spp if args.spp is None else args.spp
        if res.samples_done > res.pixels_done * spp:   # above 32768 spp a pixel's samples span several chunks
            share = res.samples_done / (scene.camera.width * scene.camera.height * spp)
            print(f"pyrt: interrupted: {res.chunks_done}/{res.chunks_total} chunks ({100 * share:.0f} % of the "
                  f"samples) rendered; a pixel keeps the samples of its finished chunks"
                  + ("; pixels without any got 1 sample each" if res.pixels_filled else ""), file=sys.stderr)
        else:
            print(f"pyrt: interrupted: {res.chunks_done}/{res.chunks_total} chunks "
                  f"({100 * res.fraction_done:.0f} % of the pixels) rendered at {spp} spp; {rest}", file=sys.stderr)
        return EXIT_INTERRUPTED
    if cancel.is_set():
        print("pyrt: interrupted after the render had finished; the outputs are complete", file=sys.stderr)
        return EXIT_INTERRUPTED
    return 0


def _write_outputs(args, image, aovs, quiet=False):
    """Write ``image`` to every ``-o`` output (each atomically: a failed write keeps the previous file)."""
    for out in args.output:
        if out.lower().endswith(".exr"):
            pyrt.write_exr(out, image, aovs=aovs, half=args.half)
        else:
            pyrt.write_png(out, image, tonemap=args.tonemap, exposure=args.exposure, L_white=args.white,
                           encoding=args.encoding, gamma=args.gamma)
        if not quiet:
            print(f"wrote {out}")


if __name__ == "__main__":
    sys.exit(main())


def console_main():
    """The console script: :func:`main` without the interpreter's teardown (:func:`pyrt.apps.common.run_console`)."""
    run_console(main)
