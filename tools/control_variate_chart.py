"""The environment light's control variate at equal time: relMSE and render time with and without it.

``EnvironmentLight(control_variate=True)`` gives Lambertian hits on flat faces the unshadowed irradiance
``albedo / pi E(n)`` and leaves only the occluded part to the samples (:mod:`pyrt.lights.environment_light`). This
tool renders, at 320 x 240 (``--width``, ``--height``):

- ``sky``: issue 13's benchmark scene (``tools/_mitsuba_scenes.py`` ``scene_sky``: an image-textured Lambert ground,
  a rough gold CookTorrance sphere, a 512 x 256 lat-long sky with a 3 degree sun; ``mis``, 4 map + 4 BSDF samples
  per hit, compensated);
- ``env``: the ``env`` kind of ``tools/bench_kinds.py`` (image-textured Lambert ground, gold sphere, a 256 x 128
  sky; ``mis`` with 1 + 1 samples per hit);

each at ``--spp`` levels with the variate on and off, ``--repeats`` times, the two variants interleaved (order
alternating by repeat) and rendered with the same seed (common random numbers: the variate adds none, so only the
hits it touches differ). Time: ``stats.time_total`` of ``pyrt.render_full`` (inside the process; BVH, importance
tables and the irradiance grid built before timing), median over the repeats. Error: ``pyrt.core.metrics.relmse``
against a ``--ref-spp`` reference rendered *without* the variate (two halves of different seeds; their relMSE / 4,
the reference's own error, is subtracted), mean over the repeats; also over the ground's pixels alone (normal AOV
+y), and the parts of the image's relMSE (sums over the region / all pixels) from the lit ground and from the
ground in shadow (the reference below 0.6 x the ground rendered without the sphere): the variate takes the map
samples' noise off the lit ground and puts it into the shadows, where relMSE's ``1 / R^2`` weighs it more. relMSE x time is constant in the sample count for an unbiased
estimator: the ratio on/off < 1 means the variate wins at equal time (its inverse: the speed-up at equal error).

Usage::

    python tools/control_variate_chart.py [--scenes sky env] [--spp 4 16 64] [--repeats 3] [--ref-spp 256]
                                          [--threads 1] [--filter bilinear|nearest] [--out out/control_variate]
                                          [--chart PATH]

``--filter nearest`` reads both maps with the nearest filter, whose importance table is exact (the bilinear one is
3 x 3-dilated, which makes the sun's own estimate noisy): it separates the variate from that noise.

Writes ``control_variate.csv`` and ``control_variate_table.md`` in ``--out`` (and the chart: relMSE against time,
log-log, one panel per scene); prints the load average before and after.
"""
from __future__ import annotations

import argparse
import csv
import os
import statistics
import sys
import time

import numpy as np

import pyrt
from pyrt.core.metrics import relmse

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _mitsuba_scenes  # noqa: E402  (tools/_mitsuba_scenes.py)
import bench_kinds  # noqa: E402  (tools/bench_kinds.py)
from _charts import finish_error_time_axes, pyplot, save_figure  # noqa: E402  (tools/_charts.py)


def make_scene(name, width, height, workdir, filter="bilinear"):
    """The scene ``name`` ("sky" or "env") at ``width x height``, its map read with ``filter`` (the scenes' own:
    "bilinear"); returns (scene, its EnvironmentLight)."""
    if name == "sky":
        sc = _mitsuba_scenes.scene_sky(workdir)
        c = sc.camera
        sc.camera = pyrt.Camera(position=c.position, target=c.target, up=(0, 1, 0), fov=c.fov, width=width,
                                height=height)
    else:
        sc = bench_kinds.make_scene("env", width, height)
    light = [lt for lt in sc.lights if lt.environment is not None][0]
    if filter != light.environment.filter:
        env = pyrt.LatLongEnvironment(light.environment.image, filter=filter)
        light = pyrt.set_environment(sc, env, n_samples=light.n_samples, bsdf_samples=light.bsdf_samples)
    return sc, light


def uptime():
    """The load averages of /proc/loadavg (what ``uptime`` prints)."""
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def render(scene, prepared, light, cv, spp, seed, threads):
    """One render with the variate ``cv``: (image float64, seconds inside the renderer)."""
    light.control_variate = cv
    r = pyrt.render_full(scene, spp=spp, seed=seed,
                         execution=pyrt.Execution(progress=False, threads=threads, prepared=prepared))
    return r.image.astype(np.float64), r.stats.time_total


def region_relmse(img, ref, mask):
    """relMSE over the pixels of ``mask`` (mean over them and the channels), and their part of the image's relMSE
    (their sum over all the image's pixels and channels)."""
    e = (img - ref) ** 2 / (ref ** 2 + 0.01)
    return float(e[mask].mean()), float(e[mask].sum() / e.size)


def ground_only(name, spp, workdir, args):
    """The scene ``name`` without its sphere (the ground alone, unshadowed), rendered at ``spp``."""
    sc, light = make_scene(name, args.width, args.height, workdir, args.filter)
    sc.meshes[:] = [m for m in sc.meshes if m.name == "ground"]
    light.control_variate = False
    return pyrt.render_full(sc, spp=spp, seed=3000, execution=pyrt.Execution(progress=False)).image.astype(np.float64)


def run_scene(name, args):
    """Reference, then both variants at every spp level, interleaved over the repeats; rows for the CSV."""
    sc, light = make_scene(name, args.width, args.height, os.path.join(args.out, "maps"), args.filter)
    prepared = pyrt.PreparedScene(sc)
    rows = []
    try:
        env = light.environment
        _ = env.distribution, env.compensated_distribution, env.irradiance(np.array([[0.0, 1.0, 0.0]]))
        normal = pyrt.render_full(sc, spp=4, seed=0, output=pyrt.Output(aovs=True),
                                  execution=pyrt.Execution(progress=False, prepared=prepared)).aovs["normal"]
        ground = normal[..., 1] > 0.999
        t0 = time.perf_counter()
        half = max(1, args.ref_spp // 2)
        a, _ = render(sc, prepared, light, False, half, 1000, args.threads)
        b, _ = render(sc, prepared, light, False, half, 2000, args.threads)
        ref = 0.5 * (a + b)
        ref_err = relmse(a, b) / 4.0
        ref_ground = region_relmse(a, b, ground)[0] / 4.0
        print(f"[{name}] reference {2 * half} spp without the variate in {time.perf_counter() - t0:.0f} s, own relMSE "
              f"~ {ref_err:.2e} (ground {ref_ground:.2e}); {int(ground.sum())} ground pixels (load {uptime()})")
        pyrt.write_png(os.path.join(args.out, f"{name}_reference.png"), ref.astype(np.float32), tonemap="reinhard")
        # the ground in shadow: where the reference is below 0.6 x the same ground without the sphere
        unshadowed = ground_only(name, max(16, args.ref_spp // 4), os.path.join(args.out, "maps"), args)
        shadow = ground & (ref.mean(axis=-1) < 0.6 * unshadowed.mean(axis=-1))
        lit = ground & ~shadow
        print(f"[{name}] {int(shadow.sum())} ground pixels in shadow")
        runs = {}
        for rep in range(args.repeats):
            for spp in args.spp:
                for cv in ((True, False) if rep % 2 == 0 else (False, True)):
                    img, secs = render(sc, prepared, light, cv, spp, 7 + 1000 * rep + spp, args.threads)
                    g = region_relmse(img, ref, ground)[0]
                    parts = [region_relmse(img, ref, m)[1] for m in (lit, shadow)]
                    runs.setdefault((cv, spp), []).append((secs, relmse(img, ref), g, *parts))
            print(f"[{name}] repeat {rep + 1}/{args.repeats} done (load {uptime()})")
    finally:
        prepared.close()
    for (cv, spp), v in runs.items():
        rows.append({"scene": name, "control_variate": cv, "spp": spp,
                     "time_s": statistics.median(x[0] for x in v),
                     "relmse": max(float(np.mean([x[1] for x in v])) - ref_err, 1e-12),
                     "relmse_ground": max(float(np.mean([x[2] for x in v])) - ref_ground, 1e-12),
                     "part_lit_ground": float(np.mean([x[3] for x in v])),
                     "part_shadowed_ground": float(np.mean([x[4] for x in v])),
                     "relmse_raw": float(np.mean([x[1] for x in v])), "ref_relmse": ref_err})
    return rows


def table(rows, header):
    """Markdown: per scene and spp, both variants and the on/off ratios of time, relMSE and relMSE x time."""
    lines = [header, "", "| scene | spp | time on / off (s) | relMSE on / off | ground relMSE on / off | "
             "part: lit ground on / off | part: ground in shadow on / off | time ratio | relMSE ratio | "
             "relMSE x time ratio |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for spp in sorted({r["spp"] for r in rows if r["scene"] == scene}):
            on = next(r for r in rows if r["scene"] == scene and r["spp"] == spp and r["control_variate"])
            off = next(r for r in rows if r["scene"] == scene and r["spp"] == spp and not r["control_variate"])
            tr, er = on["time_s"] / off["time_s"], on["relmse"] / off["relmse"]
            lines.append(f"| {scene} | {spp} | {on['time_s']:.2f} / {off['time_s']:.2f} | {on['relmse']:.2e} / "
                         f"{off['relmse']:.2e} | {on['relmse_ground']:.2e} / {off['relmse_ground']:.2e} | "
                         f"{on['part_lit_ground']:.2e} / {off['part_lit_ground']:.2e} | "
                         f"{on['part_shadowed_ground']:.2e} / {off['part_shadowed_ground']:.2e} | {tr:.3f} | {er:.3f} | "
                         f"{tr * er:.3f} |")
    return "\n".join(lines) + "\n"


def plot(rows, path, title):
    plt = pyplot()
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(1, len(scenes), figsize=(5.2 * len(scenes), 4.2))
    for ax, scene in zip(np.atleast_1d(axes), scenes):
        for cv in (False, True):
            pts = sorted((r for r in rows if r["scene"] == scene and r["control_variate"] == cv), key=lambda r: r["spp"])
            ax.loglog([p["time_s"] for p in pts], [p["relmse"] for p in pts], "-o" if cv else "--o", ms=3,
                      label="control variate" if cv else "plain")
        finish_error_time_axes(ax, scene)
    save_figure(fig, title, path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="out/control_variate")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--scenes", nargs="+", default=["sky", "env"], choices=["sky", "env"])
    ap.add_argument("--spp", type=int, nargs="+", default=[4, 16, 64])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--ref-spp", type=int, default=256)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--filter", default="bilinear", choices=["bilinear", "nearest"],
                    help="read the scenes' maps with this filter (theirs: bilinear; nearest: an exact importance table)")
    ap.add_argument("--chart", default=None, help="also write the chart here")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    load0, t0 = uptime(), time.perf_counter()
    rows = []
    for name in args.scenes:
        rows += run_scene(name, args)
    with open(os.path.join(args.out, "control_variate.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    header = (f"{args.width}x{args.height}, {args.filter} maps, spp {args.spp}, {args.repeats} interleaved repeats, threads="
              f"{args.threads}, reference {args.ref_spp} spp without the variate, {os.cpu_count()} cores, load "
              f"{load0} -> {uptime()}, {time.perf_counter() - t0:.0f} s")
    text = table(rows, header)
    with open(os.path.join(args.out, "control_variate_table.md"), "w") as f:
        f.write(text)
    print(text)
    if args.chart:
        plot(rows, args.chart, header)


if __name__ == "__main__":
    main()
