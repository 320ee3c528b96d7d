"""Render workers as threads against forked processes (``pyrt.render_full``'s ``parallel``), side by side.

Every case is rendered with ``parallel="threads"`` and ``parallel="processes"`` alternately (T P, P T, ...) in
this one process, the scene prepared once (BVH built outside the timing), on ``--threads`` workers (default:
all cores). Reported per case: the median wall time of each, their ratio, and the CPU seconds per render of
each (this process's threads plus the render's worker processes, :func:`_usage.cpu_seconds`): threads that
wait for the GIL show up as wall time above CPU / workers.

Cases:

``bench``        tools/bench.py's main scene (83k-triangle displaced sphere, mirror ball, 3 lights), 640x480,
                 1 spp: 10 chunks, each cheap -- the worst case for the processes' fixed cost;
``default``      assets/default_scene.toml at ``--default-spp`` (16) spp, 640x480;
``diffuse`` ...  tools/bench_kinds.py's kinds at 320x240 and ``--kinds-spp`` (16) spp;
``MODEL.glb``    any asset path: ``pyrt.apps.preview``'s view at its defaults (640x480, 4 spp, studio rig).

Usage::

    python tools/bench_parallel.py [bench default diffuse shadowed specular env MODEL ...] [--rounds 5]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

from _usage import cpu_seconds  # noqa: E402  (tools/_usage.py)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
KINDS = ("diffuse", "shadowed", "specular", "env")
MODES = ("threads", "processes")


def _case(name, args):
    """``(label, render(parallel))`` for a case name (see the module docstring)."""
    import pyrt
    if name == "bench":
        import bench
        scene = bench.make_scene(bench.bumpy_sphere(6))
        kw = {}
    elif name == "default":
        scene, kw = pyrt.load_scene(os.path.join(ROOT, "assets", "default_scene.toml"))
        kw = {k: v for k, v in kw.items() if k == "integrator"}     # the file's sampling and execution: the tool's
        kw["spp"] = args.default_spp
    elif name in KINDS:
        import bench_kinds
        scene, kw = bench_kinds.make_scene(name, spp=args.kinds_spp), {}
    else:
        import dataclasses
        from pyrt.apps.preview import PreviewOptions
        from pyrt.apps.preview.render import PreviewScene
        view = PreviewScene(pyrt.load_asset(name), PreviewOptions(threads=args.threads))

        def render_model(mode):
            view.options = dataclasses.replace(view.options, parallel=mode)
            view.render_view(view.azimuth)
        return os.path.basename(name) + " (preview)", render_model
    ps = pyrt.PreparedScene(scene, threads=args.threads)
    ps.accel.intersect(np.zeros((1, 3)), np.ones((1, 3)))          # BVH build outside the timing

    def render(mode):
        pyrt.render_full(scene, seed=0,
                         execution=pyrt.Execution(prepared=ps, progress=False, threads=args.threads, parallel=mode),
                         **kw)
    return f"{name} ({scene.camera.width}x{scene.camera.height}, {kw.get('spp', scene.camera.spp)} spp)", render


def main(argv=None):
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("cases", nargs="*", default=["bench", "default", *KINDS])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--threads", type=int, default=None, help="workers (default: all cores)")
    ap.add_argument("--default-spp", type=int, default=16)
    ap.add_argument("--kinds-spp", type=int, default=16)
    a = ap.parse_args(argv)
    load = os.getloadavg()[0]
    rows = ["| case | threads s | processes s | processes / threads | threads CPU s | processes CPU s |",
            "|---|---:|---:|---:|---:|---:|"]
    for name in a.cases:
        label, render = _case(name, a)
        render("threads")                                             # warm-up: lazy tables, allocator
        wall = {m: [] for m in MODES}
        cpu = {m: [] for m in MODES}
        for r in range(a.rounds):
            for m in (MODES if r % 2 == 0 else MODES[::-1]):
                t, c = time.perf_counter(), cpu_seconds()
                render(m)
                wall[m].append(time.perf_counter() - t)
                cpu[m].append(cpu_seconds() - c)
        mt, mp = statistics.median(wall["threads"]), statistics.median(wall["processes"])
        rows.append(f"| {label} | {mt:.3f} | {mp:.3f} | {mp / mt:.2f} | {statistics.median(cpu['threads']):.2f} | "
                    f"{statistics.median(cpu['processes']):.2f} |")
        print(rows[-1], flush=True)
    print(f"\n{os.cpu_count()} cores, load average {load:.2f} at the start, {os.getloadavg()[0]:.2f} at the end; "
          f"medians of {a.rounds} interleaved rounds\n")
    print("\n".join(rows))


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    main()
