"""Benchmark: the same render on Dask workers against one local process, and the per-pass overhead.

Scene: ``assets/default_scene.toml`` (or ``--scene``) at ``--width x --height``. Interleaved rounds, each:

- ``local``: ``pyrt.render_full`` in this process on all cores (its thread pool, the default);
- ``dask``: the same render on a ``LocalCluster`` of ``--workers`` single-threaded worker processes, the
  cluster started once before the rounds (each render pays the scene broadcast, the workers' BVH builds and
  the tasks); the image is checked equal to the local one;
- ``overhead``: a 1 x 1, 1 spp render on the cluster (broadcast + build + one task: the fixed cost of a render)
  and the round trip of an empty task (the cost of one more pass's tasks).

Reported: medians, the speed-up local / dask, and the model ``T(N machines) = T_work / N + overhead``,
``T_work`` the dask time minus the measured overhead, which is what N machines would give if the work
split evenly. The machine (cores, load) is printed; on a 2-core machine two worker processes compete with
the client for the same cores.

Usage: python tools/bench_dask.py [--rounds 5] [--spp 16] [--width 320 --height 240] [--workers 2]
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import pyrt


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default=os.path.join(os.path.dirname(__file__), "..", "assets", "default_scene.toml"))
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--target-error", type=float, default=None,
                    help="also time an adaptive render to this relMSE (passes: per-pass overhead counts)")
    a = ap.parse_args(argv)
    try:
        import distributed
    except ImportError:
        raise SystemExit("bench_dask: needs dask[distributed]: pip install 'pyrt-embree[preview]'")
    scene, opts = pyrt.load_scene(a.scene)
    opts.pop("seed", None)
    scene.camera.width, scene.camera.height = a.width, a.height
    tiny, _ = pyrt.load_scene(a.scene)
    tiny.camera.width = tiny.camera.height = 1
    cluster = distributed.LocalCluster(n_workers=a.workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
    client = distributed.Client(cluster)
    t = {"local": [], "dask": [], "render_overhead": [], "task_roundtrip": [], "local_adaptive": [],
         "dask_adaptive": []}
    try:
        pyrt.render(tiny, spp=1, execution=pyrt.Execution(dask=client))   # warm the workers' imports
        for r in range(a.rounds):
            t0 = time.perf_counter()
            loc = pyrt.render_full(scene, spp=a.spp, seed=r, **opts)
            t["local"].append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            dk = pyrt.render_full(scene, spp=a.spp, seed=r, execution=pyrt.Execution(dask=client), **opts)
            t["dask"].append(time.perf_counter() - t0)
            if not np.array_equal(loc.image, dk.image):
                raise SystemExit("bench_dask: the Dask image differs from the local one")
            t0 = time.perf_counter()
            pyrt.render(tiny, spp=1, execution=pyrt.Execution(dask=client))
            t["render_overhead"].append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            client.submit(int, 0, pure=False).result()
            t["task_roundtrip"].append(time.perf_counter() - t0)
            if a.target_error:
                t0 = time.perf_counter()
                pyrt.render_full(scene, seed=r, sampling=pyrt.Sampling(target_error=a.target_error), **opts)
                t["local_adaptive"].append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                res = pyrt.render_full(scene, seed=r, sampling=pyrt.Sampling(target_error=a.target_error),
                                       execution=pyrt.Execution(dask=client), **opts)
                t["dask_adaptive"].append(time.perf_counter() - t0)
                t["passes"] = res.passes
    finally:
        client.close()
        cluster.close()
    med = {k: statistics.median(v) for k, v in t.items() if isinstance(v, list) and v}
    print(f"machine: {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; {a.width}x{a.height} {a.spp} spp, "
          f"{a.rounds} interleaved rounds, medians")
    for k, v in med.items():
        print(f"  {k:16s} {v:8.3f} s")
    print(f"speed-up local / dask ({a.workers} workers): {med['local'] / med['dask']:.2f}x")
    work = med["dask"] - med["render_overhead"]
    print(f"model: T(N) = {work:.2f} s x {a.workers} workers / N + {med['render_overhead']:.2f} s "
          f"(+ {med['task_roundtrip'] * 1e3:.1f} ms per pass)")
    for n in (2, 4, 8, 16, 32):
        print(f"  N = {n:2d} single-core workers: {work * a.workers / n + med['render_overhead']:.2f} s "
              f"(local on this machine: {med['local']:.2f} s)")


if __name__ == "__main__":
    main()
