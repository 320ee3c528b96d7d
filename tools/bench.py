"""Benchmark: pyrt end-to-end time vs the time Embree alone takes for exactly the same rays.

Scene: a displaced icosphere (~82k triangles at the default size) on a ground plane, three lights
(point, spot, directional), Lambert + Blinn-Phong + mirror materials, 640x480, 1 spp.

Each run times a render (``pyrt.render_full``'s default path: the compiled kernel, which covers this scene; the
NumPy path is timed too, for comparison), then renders again recording every ray it traced (primary, secondary, shadow;
float32, as given to Embree; same seed, so the same rays) and replays them through the binding alone
(same chunking, same thread pool, no shading, no post-processing). The BVH is built before timing. Reported: both times, their ratio, rays per second, peak RSS.
Medians over ``--repeats`` runs (the machine is shared and noisy). Also sweeps triangle count
(1k ... 1M) and resolution.

Usage: python tools/bench.py [--repeats 3] [--quick] [--out out/bench] [--chart docs/bench_chart.png]
       python tools/bench.py --plot-only out/bench/bench.json --chart docs/bench_chart.png
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import time

import numpy as np
import trimesh

import pyrt

from _charts import pyplot  # noqa: E402  (tools/_charts.py)


def bumpy_sphere(subdivisions, seed=0):
    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    v = m.vertices
    bump = 1 + 0.03 * np.sin(9 * v[:, 0]) * np.sin(11 * v[:, 1]) * np.sin(7 * v[:, 2])
    return trimesh.Trimesh(vertices=v * bump[:, None], faces=m.faces, process=False)


def grid_mesh(n_tris):
    """A displaced height-field patch with about ``n_tris`` triangles (for the triangle sweep)."""
    k = max(2, int(np.sqrt(n_tris / 2)))
    x, z = np.meshgrid(np.linspace(-1, 1, k + 1), np.linspace(-1, 1, k + 1))
    y = 0.1 * np.sin(6 * x) * np.cos(5 * z) + 0.5
    v = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    i = np.arange(k * k).reshape(k, k)
    r, c = np.divmod(i.ravel(), k)
    a = r * (k + 1) + c
    f = np.concatenate([np.column_stack([a, a + k + 1, a + 1]), np.column_stack([a + 1, a + k + 1, a + k + 2])])
    return trimesh.Trimesh(vertices=v, faces=f, process=False)


def make_scene(mesh, width=640, height=480):
    cam = pyrt.Camera(position=(0, 1.6, 3.6), target=(0, 0.6, 0), fov=40, width=width, height=height, spp=1)
    s = pyrt.Scene(cam)
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=0.7), name="ground")
    s.add_mesh(mesh, pyrt.BlinnPhong(kd=0.5, ks=0.3, exponent=60), transform=pyrt.transform_matrix(translate=(0, 1.0, 0)),
               smooth=True, name="model")
    s.add_sphere((1.6, 0.4, 0.4), 0.4, pyrt.Mirror(0.9), subdivisions=4, name="mirror")
    s.add_light(pyrt.PointLight((2, 4, 2), intensity=30))
    s.add_light(pyrt.SpotLight((-2, 3, 1), target=(0, 0.5, 0), intensity=40, inner_angle=15, outer_angle=25))
    s.add_light(pyrt.DirectionalLight((-0.3, -1, -0.4), 1.5))
    return s


def replay_batches(rec):
    """The recorded rays (``RenderStats.recorded``) merged into one big batch per query kind (float32, as Embree
    reads them): ``{kind: (origins, directions, tmax)}``."""
    groups = {}
    for kind, o, d, tm in rec:
        tm = tm if tm is not None else np.full(o.shape[0], 1e37, np.float32)
        groups.setdefault(kind, []).append((o, d, tm))
    return {k: tuple(np.ascontiguousarray(np.concatenate([g[i] for g in v])) for i in range(3))
            for k, v in groups.items()}


def replay_seconds(accel, merged):
    """Seconds Embree alone takes for the :func:`replay_batches` rays ``merged``: each query kind's rays as one
    batch, split over all cores by ``accel``'s thread pool (the best the binding does on this machine)."""
    t0 = time.perf_counter()
    for kind, (o, d, tm) in merged.items():
        accel.replay(kind, o, d, tm)
    return time.perf_counter() - t0


def measure(scene, repeats):
    """Median times over ``repeats`` runs (BVH built before timing).

    Returns ``(pyrt_s, embree_s, embree_chunked_s, stats)``: the end-to-end render (the default path; the NumPy
    path's medians are kept in ``measure.last_numpy_s``, the path taken in ``measure.last_backend``); Embree alone on
    the same rays merged into one batch per query kind and split over all cores by the accel's
    thread pool (the best the binding does on this machine); and Embree alone on the render's own
    batches, one after another (how the render feeds it: one chunk per worker thread).
    """
    e2e, emb, emb_chunked, stats, e2e_np = [], [], [], None, []
    for _ in range(repeats):
        ps = pyrt.PreparedScene(scene)
        # Embree builds its BVH on the first query: do that before timing (build time is reported apart)
        ps.accel.intersect(np.zeros((1, 3)), np.ones((1, 3)))
        t0 = time.perf_counter()
        measure.last_backend = pyrt.render_full(scene, seed=0, execution=pyrt.Execution(prepared=ps)).stats.backend
        e2e.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        pyrt.render_full(scene, seed=0, execution=pyrt.Execution(prepared=ps, backend="numpy"))
        e2e_np.append(time.perf_counter() - t0)
        # the same render again, recording its rays (deterministic: identical rays) for the replay
        res = pyrt.render_full(scene, seed=0, output=pyrt.Output(record_rays=True),
                               execution=pyrt.Execution(prepared=ps))
        rec = res.stats.recorded
        merged = replay_batches(rec)
        emb.append(replay_seconds(ps.accel, merged))
        t0 = time.perf_counter()
        for kind, o, d, tm in rec:
            ps.accel.replay(kind, o, d, tm if tm is not None else np.full(o.shape[0], 1e37, np.float32))
        emb_chunked.append(time.perf_counter() - t0)
        stats = res.stats
        stats.recorded = []
        ps.close()
    measure.last_ratios = [a / b for a, b in zip(e2e, emb)]
    measure.last_numpy_s = statistics.median(e2e_np)
    return statistics.median(e2e), statistics.median(emb), statistics.median(emb_chunked), stats


def plot(result, path):
    """Chart of a bench.json result: pyrt and Embree-only times against triangles and against pixels."""
    plt = pyplot()

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    tri = result["triangles"]
    res = result["resolution"]
    pixels = [int(r["resolution"].split("x")[0]) * int(r["resolution"].split("x")[1]) for r in res]
    for ax, xs, rows, xlabel in ((axes[0], [r["triangles"] for r in tri], tri, "triangles (640x480, 1 spp)"),
                                 (axes[1], pixels, res, "pixels (main scene, 1 spp)")):
        ax.loglog(xs, [r["pyrt_s"] for r in rows], "o-", color="tab:blue", label="pyrt end to end")
        ax.loglog(xs, [r["embree_s"] for r in rows], "s--", color="tab:gray", label="Embree only, same rays")
        ax.loglog(xs, [3 * r["embree_s"] for r in rows], ":", color="tab:red", label="3x Embree (target)")
        for x, r in zip(xs, rows):
            ax.annotate(f"{r['ratio']:.1f}x", (x, r["pyrt_s"]), textcoords="offset points", xytext=(0, 6),
                        ha="center", fontsize=8)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("seconds (median)")
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=8, loc="lower right")
    m = result["main"]
    fig.suptitle(f"pyrt vs Embree alone on the same rays ({result['machine']}); main scene "
                 f"{m['ratio']:.2f}x", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="smaller sweeps")
    ap.add_argument("--out", default="out/bench")
    ap.add_argument("--chart", help="also write the chart here (e.g. docs/bench_chart.png)")
    ap.add_argument("--plot-only", metavar="BENCH_JSON", help="only draw the chart of an earlier bench.json")
    args = ap.parse_args(argv)
    if args.plot_only:
        with open(args.plot_only) as f:
            plot(json.load(f), args.chart or os.path.join(os.path.dirname(args.plot_only), "bench.png"))
        return
    os.makedirs(args.out, exist_ok=True)
    machine = f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, {platform.python_version()}"
    mesh = bumpy_sphere(6)
    scene = make_scene(mesh)
    # warm-up (imports, allocations)
    pyrt.render(make_scene(bumpy_sphere(2), 64, 48))
    t_e2e, t_emb, t_emb_chunked, st = measure(scene, args.repeats)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    main_row = {"triangles": int(mesh.faces.shape[0]) + 2 + 1280, "resolution": "640x480", "spp": 1,
                "primary": st.primary_rays, "secondary": st.secondary_rays, "shadow": st.shadow_rays,
                "rays": st.rays, "embree_s": t_emb, "embree_render_batches_s": t_emb_chunked, "pyrt_s": t_e2e,
                "ratio": t_e2e / t_emb, "ratio_vs_render_batches": t_e2e / t_emb_chunked,
                "pyrt_Mrays_per_s": st.rays / t_e2e / 1e6, "embree_Mrays_per_s": st.rays / t_emb / 1e6,
                "peak_rss_MB": peak_mb, "backend": measure.last_backend, "pyrt_numpy_s": measure.last_numpy_s}
    lines = [f"# pyrt benchmark ({machine}; medians of {args.repeats} runs)", "",
             "## Main scene", "",
             "| triangles | rays (primary/secondary/shadow) | Embree only, both cores (s) | Embree only, render's batches (s) "
             f"| pyrt, {measure.last_backend} path (s) | ratio | pyrt NumPy path (s) | pyrt Mrays/s | peak RSS (MB) |",
             "|---|---|---|---|---|---|---|---|---|",
             f"| {main_row['triangles']} | {st.rays} ({st.primary_rays}/{st.secondary_rays}/{st.shadow_rays}) | "
             f"{t_emb:.3f} | {t_emb_chunked:.3f} | {t_e2e:.3f} | {t_e2e / t_emb:.2f}x | {measure.last_numpy_s:.3f} | "
             f"{main_row['pyrt_Mrays_per_s']:.2f} | {peak_mb:.0f} |",
             "", "ratio = pyrt / Embree only on both cores (the same rays merged into one batch per query kind, through "
             f"embreex's `run` on the accelerator's thread pool); per-run ratios: "
             f"{', '.join(f'{r:.2f}' for r in measure.last_ratios)}. Kernel compilation is not in these times "
             "(a warm-up render compiles or loads the kernel first).", ""]
    print("\n".join(lines))
    sweep_tris = []
    counts = [1_000, 10_000, 100_000, 1_000_000] if not args.quick else [1_000, 100_000]
    lines += ["## Triangle count (640x480, 1 spp)", "", "| triangles | Embree only (s) | pyrt (s) | ratio |", "|---|---|---|---|"]
    for n in counts:
        m = grid_mesh(n)
        te, tb, _, _ = measure(make_scene(m), max(1, args.repeats - 1))
        sweep_tris.append({"triangles": int(m.faces.shape[0]), "embree_s": tb, "pyrt_s": te, "ratio": te / tb})
        lines.append(f"| {m.faces.shape[0]} | {tb:.3f} | {te:.3f} | {te / tb:.2f}x |")
        print(lines[-1], flush=True)
    lines += ["", "## Resolution (main scene, 1 spp)", "", "| resolution | Embree only (s) | pyrt (s) | ratio |", "|---|---|---|---|"]
    sweep_res = []
    res_list = [(160, 120), (320, 240), (640, 480), (1280, 960)] if not args.quick else [(160, 120), (640, 480)]
    for w, h in res_list:
        te, tb, _, _ = measure(make_scene(mesh, w, h), max(1, args.repeats - 1))
        sweep_res.append({"resolution": f"{w}x{h}", "embree_s": tb, "pyrt_s": te, "ratio": te / tb})
        lines.append(f"| {w}x{h} | {tb:.3f} | {te:.3f} | {te / tb:.2f}x |")
        print(lines[-1], flush=True)
    with open(os.path.join(args.out, "bench.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    result = {"machine": machine, "main": main_row, "triangles": sweep_tris, "resolution": sweep_res}
    with open(os.path.join(args.out, "bench.json"), "w") as f:
        json.dump(result, f, indent=1)
    plot(result, os.path.join(args.out, "bench.png"))
    if args.chart:
        plot(result, args.chart)
    print(f"wrote {args.out}/bench.md, bench.json and bench.png")


if __name__ == "__main__":
    main()
