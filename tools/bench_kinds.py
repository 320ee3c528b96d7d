"""Samples per second on the four canonical scene kinds of issue 13, and an interleaved A/B between two trees.

The scenes (:func:`make_scene`, reusable: ``sys.path`` to ``tools/`` and ``import bench_kinds``):

``diffuse``   a Lambert sphere on a Lambert ground, one point light;
``shadowed``  a Lambert ground shadowed by a floating box and a sphere, one point light;
``specular``  a mirror sphere and a glass sphere over a checker-textured Lambert ground, one point light
              (Whitted: the glass and mirror rays recurse to ``max_depth`` 8);
``env``       an image-textured ground and a rough gold Cook-Torrance sphere (roughness 0.3) under a
              procedural HDR sky with a sun (:func:`pyrt.procedural_sky`), ``lighting="mis"``, one sample.

Each is 320x240 at ``--spp`` samples per pixel. One run builds the scene, prepares it (BVH built before
timing), renders once to warm up and then times ``--repeats`` renders (``pyrt.render_full``, seed 0, the
default thread count); it reports the median render time and samples/s (camera samples: width x height x spp).

Usage::

    python tools/bench_kinds.py [--spp 16] [--repeats 3] [--kinds diffuse shadowed specular env]
    python tools/bench_kinds.py --ab TREE_A TREE_B [--rounds 5] [--embree]   # interleaved, one process per run
    python tools/bench_kinds.py --profile env [--spp 16]          # pyinstrument profile of one kind (if installed)

``--ab`` runs every kind in TREE_A and TREE_B alternately (A B, B A, ...), each run a fresh process with
that tree's own ``pyrt`` and kernels (as :mod:`experiments.ab_trees`), and prints per-kind medians of wall and process CPU
time and the B/A ratios (``--embree``: also each tree's ratio to Embree alone on the same rays). CPU time is
the steadier figure on a shared machine; wall time is what a user waits.
Absolute times depend on the machine's load: compare trees only within one interleaved session.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import numpy as np

from _usage import cpu_seconds  # noqa: E402  (tools/_usage.py)

KINDS = ("diffuse", "shadowed", "specular", "env")


def _camera(pyrt, width, height, spp):
    return pyrt.Camera(position=(0, 1.5, 4.5), target=(0, 0.5, 0), fov=40, width=width, height=height, spp=spp)


def _ground_image(n=256):
    """A deterministic 256x256 RGB texture (tiles with a smooth tint), float32 in [0, 1], linear."""
    y, x = np.mgrid[0:n, 0:n] / n
    tiles = ((np.floor(x * 8) + np.floor(y * 8)) % 2)[..., None]
    tint = np.stack([0.5 + 0.4 * np.sin(6 * x), 0.5 + 0.4 * np.cos(5 * y), 0.5 + 0.3 * np.sin(3 * (x + y))], -1)
    return (0.25 + 0.6 * tiles * tint).astype(np.float32)


def make_scene(kind, width=320, height=240, spp=16):
    """The scene of ``kind`` (one of :data:`KINDS`) as a :class:`pyrt.Scene`."""
    import pyrt    # here so that --ab can pick each tree's pyrt (the tool imports nothing of pyrt at the top)
    s = pyrt.Scene(_camera(pyrt, width, height, spp))
    if kind == "diffuse":
        s.add_plane((0, 0, 0), 10.0, pyrt.Lambert(albedo=0.6), name="ground")
        s.add_sphere((0, 0.6, 0), 0.6, pyrt.Lambert(albedo=(0.8, 0.4, 0.3)), name="sphere")
        s.add_light(pyrt.PointLight((2, 4, 3), intensity=25))
    elif kind == "shadowed":
        s.add_plane((0, 0, 0), 10.0, pyrt.Lambert(albedo=0.6), name="ground")
        s.add_box((-0.5, 1.2, 0), (0.8, 0.1, 0.8), pyrt.Lambert(albedo=0.5), name="slab")
        s.add_sphere((0.8, 0.35, 0.5), 0.35, pyrt.Lambert(albedo=0.7), name="ball")
        s.add_light(pyrt.PointLight((-0.3, 3.5, 0.5), intensity=20))
    elif kind == "specular":
        checker = pyrt.CheckerTexture((0.9, 0.9, 0.9), (0.15, 0.15, 0.15), scale=4.0)
        s.add_plane((0, 0, 0), 10.0, pyrt.Lambert(albedo=checker), name="ground")
        s.add_sphere((-0.7, 0.6, 0), 0.6, pyrt.Mirror(0.9), name="mirror")
        s.add_sphere((0.7, 0.6, 0.3), 0.6, pyrt.Glass(ior=1.5), name="glass")
        s.add_light(pyrt.PointLight((2, 4, 3), intensity=25))
    elif kind == "env":
        tex = pyrt.ImageTexture(_ground_image(), scale=(4.0, 4.0), name="ground")
        s.add_plane((0, 0, 0), 10.0, pyrt.Lambert(albedo=tex), name="ground")
        s.add_sphere((0, 0.6, 0), 0.6, pyrt.CookTorrance(roughness=0.3, metal="gold"), name="gold")
        sky = pyrt.LatLongEnvironment(pyrt.procedural_sky(256, 128, sun_direction=(0.4, 0.6, 0.3), sun_angle=3.0))
        pyrt.set_environment(s, sky, lighting="mis", n_samples=1)
    else:
        raise SystemExit(f"bench_kinds: unknown kind {kind!r} (one of {', '.join(KINDS)})")
    return s


def measure(kind, spp, repeats, width=320, height=240, embree=False):
    """Renders of ``kind`` in this process: ``{"kind", "spp", "times", "cpu", "median_s", "median_cpu_s",
    "samples_per_s"}`` (wall and process CPU seconds per render), with ``embree`` also ``"embree_s"``: the
    median time of Embree alone on the same rays (recorded and replayed as in ``tools/bench.py``)."""
    import pyrt
    scene = make_scene(kind, width, height, spp)
    ps = pyrt.PreparedScene(scene)
    ps.accel.intersect(np.zeros((1, 3)), np.ones((1, 3)))        # BVH build outside the timing
    pyrt.render_full(scene, seed=0, execution=pyrt.Execution(prepared=ps, progress=False))   # warm-up (allocations, lazy tables)
    times, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), cpu_seconds()
        pyrt.render_full(scene, seed=0, execution=pyrt.Execution(prepared=ps, progress=False))
        times.append(time.perf_counter() - t0)
        cpu.append(cpu_seconds() - c0)
    med = statistics.median(times)
    out = {"kind": kind, "spp": spp, "times": times, "cpu": cpu, "median_s": med,
           "median_cpu_s": statistics.median(cpu), "samples_per_s": width * height * spp / med}
    if embree:
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import bench
        rec = pyrt.render_full(scene, seed=0, execution=pyrt.Execution(prepared=ps, progress=False),
                               output=pyrt.Output(record_rays=True)).stats.recorded
        merged = bench.replay_batches(rec)
        out["embree_s"] = statistics.median(bench.replay_seconds(ps.accel, merged) for _ in range(repeats))
    ps.close()
    return out

from _trees import TREE_PREAMBLE  # noqa: E402  (tools/_trees.py)

_SNIPPET = TREE_PREAMBLE + r'''
import json
sys.path.insert(1, sys.argv[2])
import bench_kinds, pyrt
out = bench_kinds.measure(sys.argv[3], int(sys.argv[4]), int(sys.argv[5]), embree=sys.argv[6] == "1")
out["file"] = pyrt.__file__
print(json.dumps(out))
'''


def ab(trees, kinds, spp, rounds, repeats, embree=False):
    """Interleaved A/B: for each round and kind, one process per tree (order alternating by round)."""
    here = os.path.dirname(os.path.abspath(__file__))
    trees = [os.path.abspath(t) for t in trees]
    res = {(t, k): [] for t in trees for k in kinds}
    cpu = {(t, k): [] for t in trees for k in kinds}
    emb = {(t, k): [] for t in trees for k in kinds}
    for r in range(rounds):
        for k in kinds:
            for t in (trees if r % 2 == 0 else trees[::-1]):
                env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "PYTHONPATH": t}
                out = subprocess.run([sys.executable, "-c", _SNIPPET, t, here, k, str(spp), str(repeats),
                                      "1" if embree else "0"],
                                     capture_output=True, text=True, env=env, cwd=t)
                if out.returncode:
                    sys.exit(f"{t}: {out.stderr.strip()[-1500:]}")
                d = json.loads(out.stdout.strip().splitlines()[-1])
                res[(t, k)].append(d["median_s"])
                cpu[(t, k)].append(d["median_cpu_s"])
                emb[(t, k)].append(d.get("embree_s", float("nan")))
                print(f"round {r} {k:9s} {t}: {d['median_s']:.3f} s (CPU {d['median_cpu_s']:.3f} s)", flush=True)
    print(f"\n{spp} spp, 320x240, medians of {rounds} interleaved rounds (each the median of {repeats} renders); "
          f"A = {trees[0]}, B = {trees[1]}")
    print("| kind | A s | B s | A samples/s | B samples/s | B/A time | A CPU s | B CPU s | B/A CPU |"
          + (" A / Embree-only | B / Embree-only |" if embree else ""))
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|" + ("---:|---:|" if embree else ""))
    n = 320 * 240 * spp
    for k in kinds:
        a, b = (statistics.median(res[(t, k)]) for t in trees)
        ca, cb = (statistics.median(cpu[(t, k)]) for t in trees)
        row = f"| {k} | {a:.3f} | {b:.3f} | {n / a:,.0f} | {n / b:,.0f} | {b / a:.3f} | {ca:.3f} | {cb:.3f} | {cb / ca:.3f} |"
        if embree:
            ra, rb = (statistics.median(x / y for x, y in zip(res[(t, k)], emb[(t, k)])) for t in trees)
            row += f" {ra:.2f} | {rb:.2f} |"
        print(row)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    ap.add_argument("--ab", nargs=2, metavar=("TREE_A", "TREE_B"))
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--embree", action="store_true", help="also time Embree alone on the same rays (ratio)")
    ap.add_argument("--profile", choices=KINDS, help="profile one render of this kind with pyinstrument")
    args = ap.parse_args(argv)
    if args.ab:
        ab(args.ab, args.kinds, args.spp, args.rounds, args.repeats, args.embree)
        return
    if args.profile:
        import pyrt
        from pyinstrument import Profiler      # a developer tool, not a dependency of pyrt
        scene = make_scene(args.profile, spp=args.spp)
        ps = pyrt.PreparedScene(scene)
        pyrt.render_full(scene, seed=0, execution=pyrt.Execution(prepared=ps, progress=False, threads=1))
        prof = Profiler(interval=0.001)
        prof.start()
        pyrt.render_full(scene, seed=0, execution=pyrt.Execution(prepared=ps, progress=False, threads=1))
        prof.stop()
        print(prof.output_text(unicode=False, color=False, show_all=False))
        return
    for k in args.kinds:
        d = measure(k, args.spp, args.repeats, embree=args.embree)
        emb = f", Embree only {d['embree_s']:.3f} s (ratio {d['median_s'] / d['embree_s']:.2f})" if args.embree else ""
        print(f"{k:9s} {args.spp} spp: median {d['median_s']:.3f} s (CPU {d['median_cpu_s']:.3f} s), "
              f"{d['samples_per_s']:,.0f} samples/s{emb} (runs {', '.join(f'{t:.3f}' for t in d['times'])})", flush=True)


if __name__ == "__main__":
    main()
