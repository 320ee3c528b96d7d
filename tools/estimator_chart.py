"""Environment-light estimators at equal time: light/BSDF sample splitting and MIS compensation.

Two scenes at ``--width x --height`` (default 160 x 120), Whitted integrator, camera pixel jitter on (the
default, so spp also anti-aliases edges):

- ``sky``: a checker-textured Lambertian ground, a rough gold sphere (CookTorrance, roughness 0.3) and a
  Lambertian sphere (albedo 0.8) under ``pyrt.procedural_sky`` (256 x 128, a 1.5 degree sun of radiance 20000
  that gives most of the irradiance);
- ``studio``: the same objects under a smooth studio-like map generated here (:func:`studio_map`: a dim grey
  gradient and three broad soft boxes, no small bright source).

Estimators (``EnvironmentLight(strategy="mis")``): ``L<n_l>B<n_b>`` = ``n_samples = n_l`` light samples and
``bsdf_samples = n_b`` BSDF samples per hit, ``+c`` = ``compensate=True`` (MIS-compensated map samples),
``bal`` = balance instead of the power heuristic. ``L1B1`` is the estimator before this tool existed.
Each is rendered at spp = ``--spp`` values (default 2, 4, 8, 16 for ``L1B1``, scaled by ``2 / (n_l + n_b)``
for the others so every estimator traces about as many shadow rays per pixel), ``--repeats`` times with
different seeds, the estimators interleaved in each repeat (rotated order). Time: ``stats.time_total`` of
``pyrt.render_full`` (inside the process, the BVH and the importance tables built before timing), median
over the repeats. Error: ``pyrt.core.metrics.relmse`` against a reference (``L4B4+c``, for ``area`` ``A16``,
at ``--ref-spp``: two independent halves, whose relMSE / 4 is the reference's own error), mean over the
repeats, minus the reference's own error (``relmse_raw`` in the CSV keeps it).

- ``area``: the same objects under a visible 1.2 x 0.8 rectangle light (:func:`area_scene`); estimators
  ``A<n>`` = ``n_samples = n`` shadow rays per hit (``A16`` is the default), ``A<n>B<m>`` with ``bsdf_samples
  = m`` BSDF samples MIS-combined with them; spp scaled by ``16 / (n + m)``.

For an unbiased estimator relMSE x time is constant in the sample count; the table reports it per estimator
relative to ``L1B1`` (the *equal-time error ratio*: < 1 is better) and the speed-up at equal error
(its inverse), median over the spp values.

Usage::

    python tools/estimator_chart.py [--out out/estimators] [--width 160] [--height 120] [--repeats 3]
                                    [--spp 4 8 16] [--ref-spp 256] [--threads 1] [--scenes sky studio area]
                                    [--estimators L1B1+c L4B4+c ...] [--chart docs/estimator_chart.png]

Writes ``estimator_chart.csv``, ``estimator_table.md`` and the chart (two log-log panels of relMSE against
time); prints ``uptime``'s load before and after.
"""
from __future__ import annotations

import argparse
import csv
import os
import statistics
import time

import numpy as np

import pyrt
from pyrt.core.metrics import relmse
from pyrt.lights import LatLongEnvironment, set_environment
from pyrt.shaders.envmap import latlong_texel_directions
from _charts import finish_error_time_axes, pyplot, save_figure  # noqa: E402  (tools/_charts.py)

#: environment estimators: (label, n_light, n_bsdf, compensate, heuristic); shadow rays per hit n_light + n_bsdf
ESTIMATORS = [
    ("L1B1", 1, 1, False, "power"),
    ("L1B1+c", 1, 1, True, "power"),
    ("L1B1 bal", 1, 1, False, "balance"),
    ("L2B2", 2, 2, False, "power"),
    ("L2B2+c", 2, 2, True, "power"),
    ("L4B4", 4, 4, False, "power"),
    ("L4B4+c", 4, 4, True, "power"),
    ("L8B8+c", 8, 8, True, "power"),
    ("L1B2+c", 1, 2, True, "power"),
    ("L2B1", 2, 1, False, "power"),
    ("L2B1+c", 2, 1, True, "power"),
    ("L1B3+c", 1, 3, True, "power"),
]
#: area-light estimators: (label, n_samples, bsdf_samples) of the rectangle light; A16 is the default
AREA_ESTIMATORS = [("A1", 1, 0), ("A4", 4, 0), ("A16", 16, 0), ("A64", 64, 0), ("A4B4", 4, 4), ("A8B8", 8, 8),
                   ("A12B4", 12, 4), ("A16B16", 16, 16)]
#: the estimator each scene's ratios are taken against (the default before this tool)
BASELINE = {"sky": "L1B1", "studio": "L1B1", "area": "A16"}


def sky_map():
    """The ``sky`` scene's environment: a 1.5 degree sun over a blue gradient (256 x 128)."""
    return pyrt.procedural_sky(256, 128, sun_direction=(0.5, 0.55, 0.4), sun_angle=1.5,
                               sun_radiance=(20000.0, 18000.0, 15000.0))


def studio_map(width=256, height=128):
    """A smooth studio-like lat-long map (H, W, 3) float32: a grey gradient (0.3 at the zenith to 0.05 below
    the horizon) and three soft boxes, Gaussian lobes of 20-35 degrees and peak radiance 4-8."""
    d = latlong_texel_directions(height, width)
    y = d[..., 1:2]
    img = 0.05 + 0.25 * np.clip(0.5 + 0.5 * y, 0.0, 1.0) ** 2 * np.ones((1, 1, 3))
    for axis, width_deg, peak in (((0.6, 0.7, 0.4), 25.0, (8.0, 7.6, 7.0)),
                                  ((-0.8, 0.4, 0.3), 35.0, (4.0, 4.2, 4.6)),
                                  ((0.0, 0.5, -0.9), 20.0, (5.0, 5.0, 5.0))):
        a = np.asarray(axis) / np.linalg.norm(axis)
        ang = np.arccos(np.clip(d @ a, -1.0, 1.0))[..., None]
        img = img + np.asarray(peak) * np.exp(-0.5 * (ang / np.radians(width_deg)) ** 2)
    return img.astype(np.float32)


def make_scene(width, height):
    """Checker ground, rough gold sphere, Lambertian sphere (no environment yet)."""
    cam = pyrt.Camera(position=(0, 1.1, 4.4), target=(0, 0.45, 0), fov=38, width=width, height=height)
    sc = pyrt.Scene(cam)
    ground = pyrt.Lambert(albedo=pyrt.CheckerTexture(0.15, 0.6, scale=8.0))
    sc.add_plane((0, 0, 0), 8.0, ground, name="ground")
    sc.add_sphere((-0.7, 0.6, 0), 0.6, pyrt.materials.CookTorrance(kd=0.0, ks=1.0, roughness=0.3, metal="gold"),
                  name="gold")
    sc.add_sphere((0.7, 0.6, 0), 0.6, pyrt.Lambert(albedo=0.8), name="diffuse")
    return sc


def configure(scene, est):
    """Set the estimator ``est`` (a row of :data:`ESTIMATORS` or :data:`AREA_ESTIMATORS`) on ``scene``;
    returns the shadow rays it traces per hit."""
    if len(est) == 3:
        scene.lights[0].n_samples, scene.lights[0].bsdf_samples = est[1], est[2]
        return est[1] + est[2]
    _, nl, nb, comp, heur = est
    set_environment(scene, scene.environment, lighting="mis", n_samples=nl, bsdf_samples=nb, compensate=comp,
                    heuristic=heur)
    return nl + nb


def render(scene, prepared, est, spp, seed, threads):
    """One render: (image float64, seconds inside the renderer)."""
    configure(scene, est)
    r = pyrt.render_full(scene, spp=spp, seed=seed,
                         execution=pyrt.Execution(progress=False, threads=threads, prepared=prepared))
    return r.image.astype(np.float64), r.stats.time_total


def area_scene(width, height):
    """The ``area`` scene: the objects of :func:`make_scene` under a 1.2 x 0.8 rectangle light (power 60 W,
    visible) at height 2.4 and a dim constant environment (0.02, background only: no environment light)."""
    sc = make_scene(width, height)
    pyrt.RectLight(center=(0.3, 2.4, 0.5), normal=(0, -1, 0), size=(1.2, 0.8), power=60.0, name="panel").add_to(sc)
    sc.environment = pyrt.ConstantEnvironment(0.02)
    return sc


def uptime():
    """The load averages line of /proc/loadavg (what ``uptime`` prints)."""
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def run_scene(name, env, args):
    """Reference, then every estimator at every spp, interleaved over the repeats; rows for the CSV."""
    if env is None:
        sc, ests, ref_est, scale = area_scene(args.width, args.height), AREA_ESTIMATORS, ("ref", 16, 0), 16
    else:
        sc, ests, ref_est, scale = make_scene(args.width, args.height), ESTIMATORS, ("ref", 4, 4, True, "power"), 2
        sc.environment = env
        set_environment(sc, env)
        _ = env.distribution, env.compensated_distribution     # tables built before any timing
    if args.estimators:
        ests = [e for e in ests if e[0] in args.estimators or e[0] == BASELINE[name]]
    prepared = pyrt.PreparedScene(sc)
    try:
        ref_spp = max(2, args.ref_spp // 2 * 2)
        t = time.perf_counter()
        a, _ = render(sc, prepared, ref_est, ref_spp // 2, 1000, args.threads)
        b, _ = render(sc, prepared, ref_est, ref_spp // 2, 2000, args.threads)
        ref = 0.5 * (a + b)
        ref_err = relmse(a, b) / 4.0
        print(f"[{name}] reference {ref_est} x {ref_spp} spp in {time.perf_counter() - t:.0f} s, "
              f"own relMSE ~ {ref_err:.2e}")
        pyrt.write_png(os.path.join(args.out, f"{name}_reference.png"), ref.astype(np.float32), tonemap="reinhard")
        runs = {}
        for rep in range(args.repeats):
            order = ests[rep % len(ests):] + ests[:rep % len(ests)]
            for est in order:
                rays = configure(sc, est)
                for spp0 in args.spp:
                    spp = max(1, round(spp0 * scale / rays))
                    img, secs = render(sc, prepared, est, spp, 7 + 1000 * rep + spp, args.threads)
                    runs.setdefault((est[0], spp0), []).append((spp, secs, relmse(img, ref)))
            print(f"[{name}] repeat {rep + 1}/{args.repeats} done (load {uptime()})")
    finally:
        prepared.close()
    rows = []
    for (label, spp0), v in runs.items():
        err = float(np.mean([x[2] for x in v]))
        rows.append({"scene": name, "estimator": label, "spp_level": spp0, "spp": v[0][0],
                     "time_s": statistics.median(x[1] for x in v), "relmse_raw": err,
                     "relmse": max(err - ref_err, 1e-12), "ref_relmse": ref_err})
    return rows


def summarise(rows):
    """Per scene and estimator: (median over the spp levels of relMSE x time relative to the scene's
    :data:`BASELINE` at the same level, median time ratio, median relMSE ratio)."""
    out = {}
    for scene in sorted({r["scene"] for r in rows}):
        def at(label):
            return {r["spp_level"]: r for r in rows if r["scene"] == scene and r["estimator"] == label}
        base = at(BASELINE[scene])
        for label in sorted({r["estimator"] for r in rows if r["scene"] == scene}, key=_order):
            mine = at(label)
            lv = sorted(set(mine) & set(base))
            ratio = statistics.median(mine[k]["relmse"] * mine[k]["time_s"] / (base[k]["relmse"] * base[k]["time_s"])
                                      for k in lv)
            out[(scene, label)] = (ratio, statistics.median(mine[k]["time_s"] / base[k]["time_s"] for k in lv),
                                   statistics.median(mine[k]["relmse"] / base[k]["relmse"] for k in lv))
    return out


def _order(label):
    labels = [e[0] for e in ESTIMATORS + AREA_ESTIMATORS]
    return labels.index(label)


def write_table(summary, path, header):
    lines = [header, "", "| scene | estimator | relMSE x time vs baseline | speed-up at equal error | "
             "time ratio | relMSE ratio |", "|---|---|---:|---:|---:|---:|"]
    for (scene, label), (ratio, tr, er) in summary.items():
        lines.append(f"| {scene} | {label} | {ratio:.2f} | {1.0 / ratio:.2f}x | {tr:.2f} | {er:.2f} |")
    text = "\n".join(lines) + "\n"
    with open(path, "w") as f:
        f.write(text)
    print(text)


def plot(rows, path, title):
    plt = pyplot()
    scenes = [s for s in ("sky", "studio", "area") if any(r["scene"] == s for r in rows)]
    fig, axes = plt.subplots(1, len(scenes), figsize=(5.4 * len(scenes), 4.4))
    for ax, scene in zip(np.atleast_1d(axes), scenes):
        labels = sorted({r["estimator"] for r in rows if r["scene"] == scene}, key=_order)
        for label in labels:
            pts = sorted((r for r in rows if r["scene"] == scene and r["estimator"] == label),
                         key=lambda r: r["spp_level"])
            lw = 2.4 if label in (BASELINE[scene], "L4B4+c") else 1.0
            ax.loglog([p["time_s"] for p in pts], [p["relmse"] for p in pts], "-" if "+c" in label else "--",
                      marker="o", ms=3, lw=lw, label=label)
        finish_error_time_axes(ax, scene, legend_size=7, ncol=2)
    save_figure(fig, title, path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="out/estimators")
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--spp", type=int, nargs="+", default=[4, 8, 16])
    ap.add_argument("--ref-spp", type=int, default=256)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--scenes", nargs="+", default=["sky", "studio", "area"], choices=["sky", "studio", "area"])
    ap.add_argument("--estimators", nargs="+", default=None, help="only these labels (and each scene's baseline)")
    ap.add_argument("--chart", default=None, help="also write the chart here (e.g. docs/estimator_chart.png)")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    load0 = uptime()
    t0 = time.perf_counter()
    maps = {"sky": sky_map, "studio": studio_map}
    rows = []
    for name in args.scenes:
        rows += run_scene(name, LatLongEnvironment(maps[name]()) if name in maps else None, args)
    with open(os.path.join(args.out, "estimator_chart.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    header = (f"{args.width}x{args.height}, spp levels {args.spp} (equal shadow rays per pixel), "
              f"{args.repeats} interleaved repeats, threads={args.threads}, {os.cpu_count()} cores, "
              f"load {load0} -> {uptime()}, {time.perf_counter() - t0:.0f} s")
    write_table(summarise(rows), os.path.join(args.out, "estimator_table.md"), header)
    for path in [os.path.join(args.out, "estimator_chart.png")] + ([args.chart] if args.chart else []):
        plot(rows, path, header)


if __name__ == "__main__":
    main()
